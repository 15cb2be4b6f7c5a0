package orb.testbench

import orb._
import orb.model._
import spinal.core._
import spinal.core.sim._
import spinal.lib.Flow

import scala.collection.mutable.ArrayBuffer
import scala.util.Random

/** Blanking inserted by the driver: after each pixel (with probability `pixelGapProb`, 1..maxPixelGap idle
  * clocks), after each line and before each frame (uniform in the given inclusive ranges). */
final case class Blanking(
    pixelGapProb: Double = 0,
    maxPixelGap: Int = 0,
    lineGap: (Int, Int) = (0, 0),
    frameGap: (Int, Int) = (0, 0)
) {
  require(pixelGapProb >= 0 && pixelGapProb <= 1 && lineGap._1 <= lineGap._2 && frameGap._1 <= frameGap._2)
}
object Blanking {
  val none: Blanking = Blanking()

  /** A camera-like stream: no gaps inside lines, horizontal and vertical blanking. */
  val camera: Blanking = Blanking(lineGap = (16, 64), frameGap = (100, 400))

  /** Irregular gaps everywhere, including none at all between some lines. */
  val random: Blanking = Blanking(pixelGapProb = 0.2, maxPixelGap = 3, lineGap = (0, 20), frameGap = (0, 50))
}

/** One descriptor of the engine: its bin, the ring slot of its patch's oldest row, clocks from its start to its
  * finished descriptor (`DescriptorUnit.clocks`, more when `overlapped`) and until the front end had fetched its
  * last group (`fetched`); `overlapped`: the corner before it was still being described when it started. */
final case class EngineRun(bin: Int, base: Int, clocks: Int, fetched: Int, overlapped: Boolean)

/** Output events of the core in the order it emits them (a corner before a frame end of the same clock). */
sealed trait CoreEvent
final case class CornerEvent(c: Corner) extends CoreEvent
final case class FrameEndEvent(e: FrameEnd) extends CoreEvent

final case class RtlResult(
    events: Seq[CoreEvent],
    counters: FrameCounters,
    cornerCount: Long,
    cycles: Long,
    featureStream: Seq[Either[FrameEnd, Feature]],
    featureCount: Long,
    featureDrops: Long,
    deselected: Long,
    engineRuns: Seq[EngineRun] = Nil,
    holdBreaks: Seq[String] = Nil
) {
  def features: Seq[Feature] = featureStream.collect { case Right(f) => f }
  def corners: Seq[Corner] = events.collect { case CornerEvent(c) => c }
  def frameEnds: Seq[FrameEnd] = events.collect { case FrameEndEvent(e) => e }
}

object CoreEvents {

  /** The model's output as the same ordered event list the RTL monitor records. */
  def of(r: CoreResult): Seq[CoreEvent] = {
    val cs = r.corners.zip(r.cornerBeats).map { case (c, b) => (b, 0, CornerEvent(c): CoreEvent) }
    val es = r.frameEnds.zip(r.frameEndBeats).map { case (e, b) => (b, 1, FrameEndEvent(e): CoreEvent) }
    (cs ++ es).sortBy(t => (t._1, t._2)).map(_._3)
  }
}

/** Builds and drives the Verilator model of `OrbCore`. */
object CoreSim {
  def simConfig(workspace: String = "simWorkspace", wave: Boolean = false): SpinalSimConfig = {
    val c = SimConfig.withConfig(Generate.spinalConfig(s"$workspace/rtl").includeSimulation)
      .withVerilator.workspacePath(workspace)
    if (wave) c.withFstWave else c
  }

  def compile(cfg: OrbConfig, workspace: String = "simWorkspace", wave: Boolean = false): SimCompiled[OrbCore] =
    simConfig(workspace, wave).compile {
      val core = new OrbCore(cfg)
      // the descriptor engine's start and finish, for `EngineRun`s
      val engine = core.descriptors.engine
      core.descriptors.dispatch.start.simPublic()
      engine.fetch.group.simPublic()
      engine.fetch.tag.simPublic()
      for (s <- engine.slots) {
        s.state.simPublic()
        s.base.simPublic()
        s.corner.bin.simPublic()
      }
      core
    }

  /** A pixel port at rest (valid low, every field defined): call before the first clock edge. */
  def idlePixels(pixels: Flow[PixelBeat]): Unit = {
    pixels.valid #= false
    pixels.luma #= 0
    pixels.sof #= false
    pixels.eol #= false
    pixels.keyframe #= false
  }

  /** Drives every input to a defined value; call before the first clock edge. */
  def idle(dut: OrbCore, p: CornerParams): Unit = {
    idlePixels(dut.io.pixels)
    control(dut.io.cornerControl, p)
    dut.io.features.ready #= true
  }

  def control(c: CornerParamsHw, p: CornerParams): Unit = {
    c.threshold #= p.threshold
    c.segmentTest #= p.segmentThreshold.isDefined
    c.segmentThreshold #= p.segmentThreshold.fold(0L)(_.toLong)
    c.target #= p.target
  }

  /** Clock and reset for any block with a pixel port: defined inputs first, as Verilator 5 needs. */
  def startClock(cd: ClockDomain): Unit = { cd.forkStimulus(10); cd.waitSampling(4) }

  /** Records every corner and frame end the core emits, from now on. */
  final class Monitor(dut: OrbCore) {
    val events = ArrayBuffer[CoreEvent]()
    val featureStream = ArrayBuffer[Either[FrameEnd, Feature]]()
    def features: Seq[Feature] = featureStream.collect { case Right(f) => f }.toSeq

    /** the clock (counted from the monitor's start) of each corner event */
    val cornerClocks = ArrayBuffer[Long]()
    val engineRuns = ArrayBuffer[EngineRun]()
    private val engine = dut.descriptors.engine
    // per slot: the clock of its corner's start (-1: none), clocks to its fetch, whether it overlapped
    private val started = Array(-1L, -1L)
    private val fetched = Array(-1, -1)
    private val overlapped = Array(false, false)
    private val groups = orb.model.DescriptorSchedule.groups
    var cycles = 0L

    /** breaks of the features' hold (the matcher's input contract, `Matcher`): an offered item stays, unchanged,
      * until it is taken and in the clock after its take, its descriptor in the clock after that too, not offered
      * in those two clocks */
    val holdBreaks = ArrayBuffer[String]()
    // the last clock's offered item: its clock, whether it was taken, its fields
    private var offered: Option[(Long, Boolean, Seq[BigInt])] = None
    // the descriptor of the item taken two clocks ago, with the clock of its take
    private var takenBefore: Option[(Long, BigInt)] = None
    private var takenLast: Option[(Long, BigInt)] = None
    private def fields(d: Data): Seq[BigInt] = d.flatten.map {
      case b: Bool => BigInt(if (b.toBoolean) 1 else 0)
      case v: BitVector => v.toBigInt
      case other => throw new IllegalArgumentException(s"unexpected field $other")
    }.toSeq
    dut.clockDomain.onSamplings {
      cycles += 1
      for ((s, i) <- engine.slots.zipWithIndex) {
        if (started(i) >= 0 && s.state.toEnum == EngineState.FINISHED) {
          engineRuns += EngineRun(
            s.corner.bin.toInt,
            s.base.toInt,
            (cycles - started(i)).toInt,
            fetched(i),
            overlapped(i)
          )
          started(i) = -1
        }
      }
      val fetching = if (engine.fetch.tag.toBoolean) 1 else 0
      if (started(fetching) >= 0 && fetched(fetching) < 0 && engine.fetch.group.toInt == groups)
        fetched(fetching) = (cycles - started(fetching)).toInt
      if (dut.descriptors.dispatch.start.toBoolean) {
        val next = 1 - fetching
        started(next) = cycles
        fetched(next) = -1
        overlapped(next) = engine.slots(fetching).state.toEnum == EngineState.RUN
      }
      if (dut.io.corners.valid.toBoolean) {
        events += CornerEvent(Corner(dut.io.corners.x.toInt, dut.io.corners.y.toInt, dut.io.corners.score.toLong))
        cornerClocks += cycles
      }
      val f = dut.io.features
      offered.foreach { case (clock, taken, payload) =>
        if (f.valid.toBoolean == taken || fields(f.payload) != payload)
          holdBreaks += (
            if (taken) s"clock $clock: a taken item is not held, unoffered, in the clock after"
            else s"clock $clock: an offered item changed or was withdrawn before its take"
          )
      }
      takenBefore.foreach { case (clock, descriptor) =>
        if (f.valid.toBoolean || f.descriptor.toBigInt != descriptor)
          holdBreaks += s"clock $clock: a taken item's descriptor is not held, unoffered, two clocks after"
      }
      takenBefore = takenLast
      takenLast = if (f.valid.toBoolean && f.ready.toBoolean) Some((cycles, f.descriptor.toBigInt)) else None
      offered = if (f.valid.toBoolean) Some((cycles, f.ready.toBoolean, fields(f.payload))) else None
      if (f.valid.toBoolean && f.ready.toBoolean) {
        if (f.end.now.toBoolean) featureStream += Left(FrameEnd(f.end.info.ok.toBoolean, f.end.info.keyframe.toBoolean))
        else {
          val bits = f.descriptor.toBigInt
          featureStream += Right(Feature(f.x.toInt, f.y.toInt, f.bin.toInt, f.score.toLong, Feature.descriptorOf(bits)))
          if (f.rank.toInt != MatcherModel.rank(f.score.toLong))
            holdBreaks += s"clock $cycles: feature (${f.x.toInt}, ${f.y.toInt}) has a rank not its score's"
        }
      }
      if (dut.io.frameEnds.valid.toBoolean)
        events += FrameEndEvent(FrameEnd(dut.io.frameEnds.ok.toBoolean, dut.io.frameEnds.keyframe.toBoolean))
    }
  }

  def counters(dut: OrbCore): FrameCounters =
    FrameCounters(dut.io.status.frames.toLong, dut.io.status.badFrames.toLong, dut.io.status.badLines.toLong)

  /** Sends `beats` on a pixel port with the given blanking, one pixel per clock at most; `progress` is called
    * every 64k beats. */
  def drivePixels(
      pixels: Flow[PixelBeat],
      cd: ClockDomain,
      beats: Seq[Beat],
      blanking: Blanking,
      rng: Random,
      progress: Int => Unit = _ => ()
  ): Unit = {
    def gap(n: Int): Unit = if (n > 0) { pixels.valid #= false; cd.waitSampling(n) }
    def uniform(r: (Int, Int)) = r._1 + rng.nextInt(r._2 - r._1 + 1)
    var i = 0
    for (b <- beats) {
      if (b.sof) gap(uniform(blanking.frameGap))
      pixels.valid #= true
      pixels.luma #= b.luma
      pixels.sof #= b.sof
      pixels.eol #= b.eol
      pixels.keyframe #= b.keyframe
      cd.waitSampling()
      if (b.eol) gap(uniform(blanking.lineGap))
      if (blanking.pixelGapProb > 0 && rng.nextDouble() < blanking.pixelGapProb)
        gap(1 + rng.nextInt(blanking.maxPixelGap max 1))
      i += 1
      if ((i & 0xffff) == 0) progress(i)
    }
    pixels.valid #= false
  }

  def drive(dut: OrbCore, beats: Seq[Beat], blanking: Blanking, rng: Random, progress: Int => Unit = _ => ()): Unit =
    drivePixels(dut.io.pixels, dut.clockDomain, beats, blanking, rng, progress)

  /** Clocks enough for everything in flight to leave: the corners' pipeline, and the descriptor engine, which
    * may still be at work after the last pixel (a few descriptors of 256+ clocks each). */
  def drain(dut: OrbCore): Unit = dut.clockDomain.waitSampling(OrbCore.latency() + 4000)

  /** Defined inputs, clock and reset, then a monitor from the first clock after reset. */
  def start(dut: OrbCore, p: CornerParams): Monitor = {
    idle(dut, p)
    startClock(dut.clockDomain)
    new Monitor(dut)
  }

  /** What the monitor saw, with the core's counters now. */
  def result(dut: OrbCore, monitor: Monitor): RtlResult =
    RtlResult(
      monitor.events.toSeq,
      counters(dut),
      dut.io.status.corners.toLong,
      monitor.cycles,
      monitor.featureStream.toSeq,
      dut.io.status.features.toLong,
      dut.io.status.featureDrops.toLong,
      dut.io.status.deselected.toLong,
      monitor.engineRuns.toSeq,
      monitor.holdBreaks.toSeq
    )

  /** One complete run from reset: returns what the core emitted and its counters. */
  def run(dut: OrbCore, beats: Seq[Beat], p: CornerParams, blanking: Blanking, seed: Long): RtlResult = {
    val monitor = start(dut, p)
    drive(dut, beats, blanking, new Random(seed))
    drain(dut)
    result(dut, monitor)
  }
}
