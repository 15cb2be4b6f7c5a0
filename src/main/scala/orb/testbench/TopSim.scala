package orb.testbench

import orb._
import orb.model._
import spinal.core._
import spinal.core.sim._
import spinal.lib.bus.avalon.AvalonMM

import scala.collection.mutable.ArrayBuffer
import scala.util.Random

/** What `OrbTop` did in one run: every item of its internal feature stream (as the matcher consumed it), every
  * correspondence the consumer took, the per-stage values for tracing, and its registers at the end. */
final case class TopResult(
    featureStream: Seq[Either[FrameEnd, Feature]],
    correspondences: Seq[Correspondence],
    corners: Seq[Corner],
    oriented: Seq[TopSim.Oriented],
    scans: Seq[TopSim.Scan],
    registers: Map[String, Long],
    cycles: Long,
    pixels: Long
) {
  def features: Seq[Feature] = featureStream.collect { case Right(f) => f }
  def register(name: String): Long = registers(name)
}

/** Builds and drives the Verilator model of `OrbTop`: pixels in, Avalon-MM register accesses, a consumer of
  * correspondences with optional random back-pressure. */
object TopSim {

  /** A corner after the orientation unit: its moments (its bin comes with its feature). */
  final case class Oriented(x: Int, y: Int, m10: Long, m01: Long)

  /** A live feature's scan as the matcher decided it: best entry (store index, position), distance, second best. */
  final case class Scan(liveX: Int, liveY: Int, bestIndex: Int, keyX: Int, keyY: Int, best: Int, second: Int)

  /** the counters by their `summary.json` names */
  val registerNames: Seq[(String, Register)] = RegisterMap.counters.map(r => r.key -> r)

  /** OrbTop with the internal signals the monitor and the tracer read made visible to the simulator. */
  def compile(cfg: OrbConfig, workspace: String = "simWorkspace", wave: Boolean = false): SimCompiled[OrbTop] =
    CoreSim.simConfig(workspace, wave).compile {
      val top = new OrbTop(cfg)
      top.core.io.features.simPublic()
      top.core.io.corners.simPublic()
      top.core.orientation.io.oriented.simPublic()
      top.matcher.decide.done.simPublic()
      top.matcher.decide.emptyDone.simPublic()
      top.matcher.compare.acc.simPublic()
      top.matcher.swept.key.simPublic()
      top.matcher.scan.live.simPublic()
      top
    }

  /** One Avalon-MM master in the simulation thread: single reads and writes. */
  final class Avalon(bus: AvalonMM, cd: ClockDomain) {
    def idle(): Unit = { bus.read #= false; bus.write #= false; bus.address #= 0; bus.writeData #= 0 }
    def write(r: Register, value: Long): Unit = {
      bus.address #= r.address; bus.writeData #= value; bus.write #= true
      cd.waitSamplingWhere(bus.waitRequestn.toBoolean)
      bus.write #= false
    }
    def read(r: Register): Long = {
      bus.address #= r.address; bus.read #= true
      cd.waitSamplingWhere(bus.waitRequestn.toBoolean)
      bus.read #= false
      if (!bus.readDataValid.toBoolean) cd.waitSamplingWhere(bus.readDataValid.toBoolean)
      bus.readData.toLong
    }
  }

  /** Records the feature stream, corners, orientations, scans and the correspondences taken by the consumer;
    * `ready` is the probability that the consumer takes one on a clock. */
  final class Monitor(dut: OrbTop, ready: Double, rng: Random) {
    val featureStream = ArrayBuffer[Either[FrameEnd, Feature]]()
    val correspondences = ArrayBuffer[Correspondence]()
    val corners = ArrayBuffer[Corner]()
    val oriented = ArrayBuffer[Oriented]()
    val scans = ArrayBuffer[Scan]()
    var cycles = 0L
    dut.clockDomain.onSamplings {
      cycles += 1
      val f = dut.core.io.features
      if (f.valid.toBoolean && f.ready.toBoolean) {
        if (f.end.now.toBoolean) featureStream += Left(FrameEnd(f.end.info.ok.toBoolean, f.end.info.keyframe.toBoolean))
        else {
          val bits = f.descriptor.toBigInt
          featureStream += Right(Feature(f.x.toInt, f.y.toInt, f.bin.toInt, f.score.toLong, Feature.descriptorOf(bits)))
        }
      }
      val c = dut.core.io.corners
      if (c.valid.toBoolean) corners += Corner(c.x.toInt, c.y.toInt, c.score.toLong)
      val o = dut.core.orientation.io.oriented
      if (o.valid.toBoolean && !o.end.now.toBoolean)
        oriented += Oriented(o.corner.x.toInt, o.corner.y.toInt, o.m10.toLong, o.m01.toLong)
      val m = dut.matcher
      if (m.decide.done.toBoolean) {
        val a = m.compare.acc
        scans += Scan(
          m.scan.live.x.toInt,
          m.scan.live.y.toInt,
          a.best.index.toInt,
          m.swept.key.x.toInt,
          m.swept.key.y.toInt,
          a.best.distance.toInt,
          a.second.toInt
        )
      }
      val out = dut.io.correspondences
      if (out.valid.toBoolean && out.ready.toBoolean)
        correspondences += Correspondence(
          out.liveX.toInt,
          out.liveY.toInt,
          out.keyX.toInt,
          out.keyY.toInt,
          out.distance.toInt
        )
      out.ready #= ready >= 1 || rng.nextDouble() < ready
    }
  }

  /** Inputs defined, clock and reset, then the run-time parameters written over the bus. */
  def start(dut: OrbTop, corners: CornerParams, p: MatchParams, ready: Double, rng: Random): (Avalon, Monitor) = {
    import RegisterMap._
    CoreSim.idlePixels(dut.io.pixels)
    dut.io.correspondences.ready #= true
    val bus = new Avalon(dut.io.ctrl, dut.clockDomain)
    bus.idle()
    CoreSim.startClock(dut.clockDomain)
    require(bus.read(ID) == RegisterMap.id.toLong, "OrbTop's ID register")
    bus.write(HARRIS_THRESHOLD, corners.threshold)
    bus.write(SEGMENT_THRESHOLD, corners.segmentThreshold.getOrElse(0).toLong)
    bus.write(TARGET, corners.target.toLong)
    bus.write(HAMMING_THRESHOLD, p.hammingThreshold)
    bus.write(RATIO, p.ratio.getOrElse(0).toLong)
    bus.write(
      CONTROL,
      (if (p.ratio.isDefined) 1 else 0) | (if (p.crossCheck) 2 else 0) | (if (corners.segmentThreshold.isDefined) 4
                                                                          else 0)
    )
    (bus, new Monitor(dut, ready, rng))
  }

  /** Clocks for everything in flight to leave after the last pixel: descriptors, then at most a few hundred
    * scans of a full store and a cross-check sweep. */
  def drainClocks(cfg: OrbConfig): Int =
    OrbCore.latency() + 4000 + 400 * cfg.matcher.clocksPerFeature + cfg.matcher.storeCapacity

  /** Waits until the core has been idle (no feature, no scan, no correspondence) for `quiet` clocks, or `max`. */
  def drain(dut: OrbTop, monitor: Monitor, cfg: OrbConfig): Unit = {
    val quiet = 6000
    val max = drainClocks(cfg)
    var idle = 0; var waited = 0
    while (idle < quiet && waited < max) {
      val before = (monitor.featureStream.size, monitor.scans.size, monitor.correspondences.size)
      dut.clockDomain.waitSampling(100); waited += 100
      val after = (monitor.featureStream.size, monitor.scans.size, monitor.correspondences.size)
      if (before == after && !dut.io.correspondences.valid.toBoolean) idle += 100 else idle = 0
    }
  }

  def result(dut: OrbTop, bus: Avalon, monitor: Monitor, pixels: Long): TopResult =
    TopResult(
      monitor.featureStream.toSeq,
      monitor.correspondences.toSeq,
      monitor.corners.toSeq,
      monitor.oriented.toSeq,
      monitor.scans.toSeq,
      registerNames.map { case (n, r) => n -> bus.read(r) }.toMap,
      monitor.cycles,
      pixels
    )

  /** One complete run from reset. */
  def run(
      dut: OrbTop,
      cfg: OrbConfig,
      beats: Seq[Beat],
      corners: CornerParams,
      p: MatchParams,
      blanking: Blanking,
      ready: Double,
      seed: Long,
      progress: Int => Unit = _ => ()
  ): TopResult = {
    val rng = new Random(seed)
    val (bus, monitor) = start(dut, corners, p, ready, rng)
    CoreSim.drivePixels(dut.io.pixels, dut.clockDomain, beats, blanking, rng, progress)
    drain(dut, monitor, cfg)
    result(dut, bus, monitor, beats.size.toLong)
  }
}
