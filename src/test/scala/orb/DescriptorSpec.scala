package orb

import orb.model._
import orb.testbench._
import org.scalatest.funsuite.AnyFunSuite

/** The whole feature path of `OrbCore` (Harris, orientation, smoother, descriptors) against the model, on the shared
  * compiled core: every field of every feature, and no corner without its descriptor. */
class DescriptorSpec extends AnyFunSuite {
  import TestSupport._

  def show(f: Feature): String = if (f == null) "-" else s"(${f.x},${f.y}) bin ${f.bin} score ${f.score} ${f.hex}"

  /** With `allowDrops`, the RTL's features must be the model's for a subset of the corners, in order, every missing
    * one counted (dense texture beyond the engines' rate); otherwise every corner must get its feature. */
  def check(name: String, img: GrayImage, blanking: Blanking, p: CornerParams = cornerParams, allowDrops: Boolean = false): RtlResult = {
    val expected = OrbModel.features(img, HarrisModel.corners(img, config.harris, p), config.descriptor)
    var rtl: RtlResult = null
    core.doSim(name, seed.toInt) { dut => rtl = CoreSim.run(dut, Beat.frame(img) ++ Beat.frame(img), p, blanking, rng(name).nextLong()) }
    val got = rtl.features
    if (!allowDrops || rtl.featureDrops == 0) {
      val diffs = expected.zipAll(got, null, null).zipWithIndex.filter { case ((a, b), _) => a != b }
      assert(diffs.isEmpty, s"$name: ${diffs.size} differ (model ${expected.size}, RTL ${got.size}, drops ${rtl.featureDrops}); first " +
        diffs.take(2).map { case ((a, b), i) => s"#$i model ${show(a)} RTL ${show(b)}" }.mkString("; "))
    } else {
      Scoreboard.notAnOrderedSubset(expected, got).foreach(f => fail(s"$name: RTL feature ${show(f)} is not one of the model's (or out of order)"))
      assert(rtl.featureDrops == expected.size - got.size, s"$name: every missing feature is counted")
    }
    println(f"[orb] descriptors $name%-34s ${if (p.segmentThreshold.isEmpty) "Harris maxima" else "segment test "} " +
      f"${img.width}x${img.height}: ${expected.size}%5d corners, ${got.size}%5d features equal to the model, ${rtl.featureDrops}%4d dropped")
    rtl
  }

  test("features == model: boxes with gaps, a graf1 crop with camera blanking") {
    check("feat-boxes", Patterns.boxes(120, 90, rng("feat"), n = 20), Blanking.random)
    check("feat-graf1", image("graf1.png").crop(100, 100, 320, 200), Blanking.camera)
  }
  lazy val photos: Seq[String] = Option(new java.io.File("data").listFiles()).toSeq.flatten.map(_.getName).filter(_.endsWith(".png")).sorted
  test("every photograph in data/, full size, no blanking at all, Harris maxima: every corner gets its descriptor") {
    assert(photos.size >= 8)
    for (name <- photos) check(s"feat-$name", image(name), Blanking.none, harrisOnly)
  }
  test("every photograph in data/, full size, camera blanking, default (segment test): survivors exact, drops counted") {
    val drops = photos.map(name => name -> check(s"feat-seg-$name", image(name), Blanking.camera, allowDrops = true).featureDrops)
    val wide = drops.filter { case (name, _) => image(name).width >= 512 }
    assert(wide.size >= 7 && wide.forall(_._2 == 0), s"lines of 512 px or more lose no corner: $wide")
  }
  test("a 1024-px-wide photograph with over 3000 corners, no blanking: every corner gets its descriptor") {
    val got = check("feat-aloe-3000", image("aloeL_crop1024.png"), Blanking.none, cornerParams.copy(threshold = threshold / 4)).features
    assert(got.size >= 3000, s"${got.size} corners: lower the threshold of this test")
  }
}
