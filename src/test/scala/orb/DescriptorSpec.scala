package orb

import orb.model._
import orb.testbench._
import org.scalatest.funsuite.AnyFunSuite

/** The whole feature path of `OrbCore` (Harris, orientation, smoother, descriptors) against the model, on the shared
  * compiled core: every field of every feature, and no corner without its descriptor. */
class DescriptorSpec extends AnyFunSuite {
  import TestSupport._

  def show(f: Feature): String = if (f == null) "-" else s"(${f.x},${f.y}) bin ${f.bin} score ${f.score} ${f.hex}"

  def check(name: String, img: GrayImage, blanking: Blanking, thr: Long = threshold): Seq[Feature] = {
    val expected = OrbModel.features(img, HarrisModel.corners(img, config.harris, thr), config.descriptor)
    var rtl: RtlResult = null
    core.doSim(name, seed.toInt) { dut => rtl = CoreSim.run(dut, Beat.frame(img) ++ Beat.frame(img), thr, blanking, rng(name).nextLong()) }
    val got = rtl.features
    val diffs = expected.zipAll(got, null, null).zipWithIndex.filter { case ((a, b), _) => a != b }
    assert(diffs.isEmpty, s"$name: ${diffs.size} differ (model ${expected.size}, RTL ${got.size}, drops ${rtl.featureDrops}); first " +
      diffs.take(2).map { case ((a, b), i) => s"#$i model ${show(a)} RTL ${show(b)}" }.mkString("; "))
    assert(rtl.featureDrops == 0, s"$name: ${rtl.featureDrops} dropped")
    println(s"[orb] descriptors $name: ${got.size} features equal to the model, none dropped")
    got
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
