package orb

import orb.model._
import orb.testbench._
import org.scalatest.funsuite.AnyFunSuite
import spinal.core._
import spinal.core.sim._
import spinal.lib._

/** Tracker, a 31-row shared line buffer, the Harris detector, the feature budget (unless `budgeted` is false: then
  * every corner goes on) and the orientation unit. */
class OrientationHarness(c: OrbConfig, budgeted: Boolean = true) extends Component {
  val rows = 2 * OrbDescriptorConfig.patchRadius + 1
  val io = new Bundle {
    val pixels = slave Flow (PixelBeat())
    val control = in(CornerParamsHw())
    val oriented = master Flow (OrientedCorner(c.frame, c.harris))
    val dropped = out UInt (32 bits)
  }
  val tracker = new FrameTracker(c.frame, LineBuffer.readCopies(c.frame, rows))
  val lines = new LineBuffer(c.frame, rows)
  val harris = new HarrisDetector(c.frame, c.harris, rows)
  val orientation = new OrientationUnit(c.frame, c.harris, c.descriptor, rows)
  tracker.io.pixels << io.pixels
  lines.follow(tracker)
  harris.io.columns << lines.io.columns
  harris.io.geometry := tracker.io.geometry
  harris.io.control := io.control
  orientation.io.columns << lines.io.columns
  if (budgeted) {
    val budget = new FeatureBudget(c)
    budget.attach(lines.io.columns, harris, tracker.io.geometry, io.control.target)
    orientation.io.corners << budget.io.selected
  } else {
    orientation.io.corners << harris.io.corners
  }
  io.oriented << orientation.io.oriented
  io.dropped := orientation.io.dropped
}

/** The ports either harness drives. */
final case class OrientationDut(
    pixels: Flow[PixelBeat],
    control: CornerParamsHw,
    oriented: Flow[OrientedCorner],
    dropped: UInt,
    clockDomain: ClockDomain
)

class OrientationSpec extends AnyFunSuite {
  import TestSupport._
  lazy val harness = {
    println(s"[orb] compiling the orientation harness; seed = $seed")
    CoreSim.simConfig("simWorkspace/test").compile(new OrientationHarness(config))
  }

  /** a queue deep enough for every Harris corner of the test frames, with no budget in front */
  val denseConfig: OrbConfig = config.copy(descriptor = config.descriptor.copy(cornerQueueDepth = 4096))
  lazy val dense = CoreSim.simConfig("simWorkspace/test").compile(new OrientationHarness(denseConfig, budgeted = false))

  def check(
      name: String,
      img: GrayImage,
      blanking: Blanking,
      all: Boolean = false,
      p: CornerParams = cornerParams
  ): Unit = {
    val model = CoreModel.run(config, Beat.frame(img) ++ Beat.frame(img), p)
    val selected = if (all) model.corners else model.budget.last._2.selected
    val expected = selected.map { c =>
      val (m10, m01) = OrbModel.moments(img, c.x, c.y)
      (c.x, c.y, c.score, m10, m01)
    }
    val got = scala.collection.mutable.ArrayBuffer[(Int, Int, Long, Long, Long)]()
    var dropped = -1L
    def run(dut: OrientationDut): Unit = {
      CoreSim.idlePixels(dut.pixels)
      CoreSim.control(dut.control, p)
      CoreSim.startClock(dut.clockDomain)
      dut.clockDomain.onSamplings {
        val o = dut.oriented
        if (o.valid.toBoolean && !o.end.now.toBoolean)
          got += ((o.corner.x.toInt, o.corner.y.toInt, o.corner.score.toLong, o.m10.toLong, o.m01.toLong))
      }
      CoreSim.drivePixels(dut.pixels, dut.clockDomain, Beat.frame(img) ++ Beat.frame(img), blanking, rng(name))
      dut.clockDomain.waitSampling(50)
      dropped = dut.dropped.toLong
    }
    if (all) dense.doSim(name, seed.toInt)(dut =>
      run(OrientationDut(dut.io.pixels, dut.io.control, dut.io.oriented, dut.io.dropped, dut.clockDomain))
    )
    else harness.doSim(name, seed.toInt)(dut =>
      run(OrientationDut(dut.io.pixels, dut.io.control, dut.io.oriented, dut.io.dropped, dut.clockDomain))
    )
    val diffs = expected.zipAll(got, null, null).filter { case (a, b) => a != b }
    assert(
      diffs.isEmpty,
      s"$name: ${diffs.size} differ (model ${expected.size}, RTL ${got.size}); first ${diffs.take(3).mkString("; ")}"
    )
    assert(dropped == 0, s"$name: $dropped corners dropped")
    println(s"[orb] orientation $name: ${got.size} corners, moments equal to the model, none dropped")
  }

  lazy val search = CoreSim.simConfig("simWorkspace/test").compile(
    new AngleSearch(UInt(16 bits), config.descriptor)
  )

  test("angle search == model on moments at and beside every bin boundary, all signs, both halves of the octant, " +
    "in order under back-pressure, a corner per AngleSearch.clocks") {
    val d = config.descriptor
    val f = d.tanFracBits
    val r = rng("angle-search")
    // b = ceil(a T_j / 2^F) is the smallest b that counts boundary j, b - 1 the largest that does not
    val boundaries = for {
      j <- d.boundaryTangents.indices
      _ <- 0 until 6
      a = 1L + r.nextInt(1 << (OrientationUnit.momentWidth - 1))
      t = d.boundaryTangents(j)
      b0 = (BigInt(a) * t + (BigInt(1) << f) - 1) / (BigInt(1) << f)
      b <- Seq(b0, b0 - 1) if b >= 0 && b <= a
    } yield (a, b.toLong)
    // a a multiple of 2^F: b = a T_j / 2^F exactly (the product has no fraction)
    val exact = for {
      j <- d.boundaryTangents.indices by 7
      k <- 1 until (1 << (OrientationUnit.momentWidth - 1 - f))
      a = k.toLong << f
      b <- Seq(k * d.boundaryTangents(j), k * d.boundaryTangents(j) - 1)
    } yield (a, b)
    val top = 1 << (OrientationUnit.momentWidth - 1)
    val random = Seq.fill(400)((r.nextInt(top).toLong, r.nextInt(top).toLong)) ++
      Seq((0L, 0L), (1L, 0L), (0L, 1L), (1L, 1L), (top - 1L, top - 1L))
    val pairs = (boundaries ++ exact ++ random.map { case (a, b) => (a max b, a min b) }).flatMap { case (a, b) =>
      val signs = Seq((1, 1), (-1, 1), (-1, -1), (1, -1))
      signs.flatMap { case (sx, sy) => Seq((sx * a, sy * b), (sx * b, sy * a)) }
    }
    val expected = pairs.zipWithIndex.map { case ((m10, m01), i) => (i & 0xffff, OrbModel.angleBin(m10, m01, d)) }
    val got = scala.collection.mutable.ArrayBuffer[(Int, Int)]()
    var steadyClocks = 0L
    search.doSim("angle-search", seed.toInt) { dut =>
      val in = dut.io.input
      in.valid #= false
      in.item #= 0
      in.m10 #= 0
      in.m01 #= 0
      dut.io.output.ready #= false
      dut.clockDomain.forkStimulus(10)
      dut.clockDomain.waitSampling(4)
      var clocks = 0L
      var pressure = true
      dut.clockDomain.onSamplings {
        clocks += 1
        val o = dut.io.output
        if (o.valid.toBoolean && o.ready.toBoolean) got += ((o.item.toInt, o.bin.toInt))
        // the consumer waits now and then
        o.ready #= !pressure || r.nextInt(4) != 0
      }
      def offer(i: Int): Unit = {
        val (m10, m01) = pairs(i)
        in.valid #= true
        in.item #= i & 0xffff
        in.m10 #= m10
        in.m01 #= m01
        dut.clockDomain.waitSamplingWhere(in.ready.toBoolean)
        in.valid #= false
      }
      // a corner offered now and then, under back-pressure
      for (i <- pairs.indices.drop(16)) {
        offer(i)
        if (r.nextInt(5) == 0) dut.clockDomain.waitSampling(r.nextInt(40) + 1)
      }
      dut.clockDomain.waitSampling(100)
      // the first 16 back to back with the consumer always ready: a corner per AngleSearch.clocks
      pressure = false
      dut.clockDomain.waitSampling(2)
      val from = clocks
      for (i <- 0 until 16) offer(i)
      dut.clockDomain.waitSamplingWhere(got.size == pairs.size)
      steadyClocks = clocks - from
    }
    val order = pairs.indices.drop(16) ++ (0 until 16)
    val diffs = order.map(expected).zipAll(got, null, null).filter { case (a, b) => a != b }
    if (diffs.nonEmpty)
      fail(s"${diffs.size} of ${expected.size} differ (tag, bin); first ${diffs.take(3).mkString("; ")}")
    val per = AngleSearch.clocks(d)
    assert(
      steadyClocks >= 16L * per - per && steadyClocks <= 16L * per + 2,
      s"16 corners back to back took $steadyClocks clocks, not about 16 x $per"
    )
    val atBoundaries = boundaries.size + exact.size
    println(
      s"[orb] angle search: ${got.size} moment pairs ($atBoundaries at or beside a boundary, all 8 octants) == model"
    )
  }

  test("moments == model, in raster order, none lost") {
    check("orient-boxes", Patterns.boxes(120, 90, rng("orient"), n = 20), Blanking.random)
    check("orient-graf1", image("graf1.png").crop(100, 100, 320, 200), Blanking.camera)
  }
  test("full-size photographs: every selected corner oriented, none dropped (aero1 640x480, no blanking)") {
    check("orient-aero1", image("aero1.png"), Blanking.none)
  }
  test("every Harris corner of a flood, no budget in front: any number of corners within 31 px, none dropped") {
    // rows of dots 3 px apart: Harris maxima (no segment test) every 3 px
    val p = cornerParams.copy(segmentThreshold = None)
    val img = GrayImage.tabulate(160, 72)((x, y) => if (y % 8 == 4 && x % 3 == 0) 255 else 0)
    val corners = CoreModel.run(config, Beat.frame(img) ++ Beat.frame(img), p).corners
    // the case a slot-based unit could not serve: more than 8 corners of a row within 31 columns
    val crowded = corners.groupBy(_.y).values.map(_.map(_.x).sorted).map { xs =>
      xs.indices.map(i => xs.drop(i).takeWhile(_ <= xs(i) + 30).size).maxOption.getOrElse(0)
    }.max
    assert(crowded > 8, s"the flood should crowd a row (at most $crowded corners within 31 px)")
    check("orient-flood", img, Blanking.none, all = true, p = p)
  }
}
