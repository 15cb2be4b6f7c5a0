package orb

import orb.model._
import orb.testbench._
import org.scalatest.funsuite.AnyFunSuite
import spinal.core._
import spinal.core.sim._
import spinal.lib._

/** The whole feature path: tracker, shared 31-row line buffer, Harris, smoother, orientation, descriptors. */
class FeatureHarness(c: OrbConfig) extends Component {
  val rows = 2 * OrbDescriptorConfig.patchRadius + 1
  val io = new Bundle {
    val pixels = slave Flow (PixelBeat())
    val threshold = in UInt (32 bits)
    val features = master Stream (OrbFeature(c.frame, c.harris, c.descriptor))
    val orientationDrops, descriptorDrops = out UInt (32 bits)
  }
  val tracker = new FrameTracker(c.frame)
  val lines = new LineBuffer(c.frame, rows)
  val harris = new HarrisDetector(c.frame, c.harris, rows)
  val smoother = new Smoother(c.frame, rows)
  val orientation = new OrientationUnit(c.frame, c.harris, c.descriptor, rows)
  val descriptors = new DescriptorUnit(c.frame, c.harris, c.descriptor)
  tracker.io.pixels << io.pixels
  lines.io.pixels << tracker.io.tracked
  harris.io.columns << lines.io.columns
  harris.io.geometry := tracker.io.geometry
  harris.io.threshold := io.threshold
  smoother.io.columns << lines.io.columns
  orientation.io.columns << lines.io.columns
  orientation.io.corners << harris.io.corners
  descriptors.io.smoothed << smoother.io.smoothed
  descriptors.io.corners << orientation.io.oriented
  io.features << descriptors.io.features
  io.orientationDrops := orientation.io.dropped
  io.descriptorDrops := descriptors.io.dropped
}

class DescriptorSpec extends AnyFunSuite {
  import TestSupport._
  lazy val harness = {
    println(s"[orb] compiling the feature harness; seed = $seed")
    CoreSim.simConfig("simWorkspace/test").compile(new FeatureHarness(config))
  }

  def show(f: Feature): String = if (f == null) "-" else s"(${f.x},${f.y}) bin ${f.bin} score ${f.score} ${f.hex}"

  def check(name: String, img: GrayImage, blanking: Blanking, thr: Long = threshold): Seq[Feature] = {
    val expected = OrbModel.features(img, HarrisModel.corners(img, config.harris, thr), config.descriptor)
    val got = scala.collection.mutable.ArrayBuffer[Feature]()
    var drops = (0L, 0L)
    harness.doSim(name, seed.toInt) { dut =>
      CoreSim.idlePixels(dut.io.pixels)
      dut.io.threshold #= thr
      dut.io.features.ready #= true
      CoreSim.startClock(dut.clockDomain)
      dut.clockDomain.onSamplings {
        val o = dut.io.features
        if (o.valid.toBoolean && o.ready.toBoolean && !o.frameEnd.toBoolean) {
          val bits = o.descriptor.toBigInt
          got += Feature(o.x.toInt, o.y.toInt, o.bin.toInt, o.score.toLong, Vector.tabulate(32)(b => ((bits >> (8 * b)) & 0xff).toInt))
        }
      }
      CoreSim.drivePixels(dut.io.pixels, dut.clockDomain, Beat.frame(img) ++ Beat.frame(img), blanking, rng(name))
      dut.clockDomain.waitSampling(3000)
      drops = (dut.io.orientationDrops.toLong, dut.io.descriptorDrops.toLong)
    }
    val diffs = expected.zipAll(got, null, null).zipWithIndex.filter { case ((a, b), _) => a != b }
    assert(diffs.isEmpty, s"$name: ${diffs.size} differ (model ${expected.size}, RTL ${got.size}, drops $drops); first " +
      diffs.take(2).map { case ((a, b), i) => s"#$i model ${show(a)} RTL ${show(b)}" }.mkString("; "))
    assert(drops == (0L, 0L), s"$name: drops $drops")
    println(s"[orb] descriptors $name: ${got.size} features equal to the model, none dropped")
    got.toSeq
  }

  test("features == model: boxes with gaps, a graf1 crop with camera blanking") {
    check("feat-boxes", Patterns.boxes(120, 90, rng("feat"), n = 20), Blanking.random)
    check("feat-graf1", image("graf1.png").crop(100, 100, 320, 200), Blanking.camera)
  }
  test("every photograph in data/, full size, no blanking at all: every corner gets its descriptor") {
    val photos = Option(new java.io.File("data").listFiles()).toSeq.flatten.map(_.getName).filter(_.endsWith(".png")).sorted
    assert(photos.size >= 8)
    for (name <- photos) check(s"feat-$name", image(name), Blanking.none)
  }
  test("a 1024-px-wide photograph with over 3000 corners, no blanking: every corner gets its descriptor") {
    val got = check("feat-aloe-3000", image("aloeL_crop1024.png"), Blanking.none, thr = threshold / 2)
    assert(got.size >= 3000, s"${got.size} corners: lower the threshold of this test")
  }
}
