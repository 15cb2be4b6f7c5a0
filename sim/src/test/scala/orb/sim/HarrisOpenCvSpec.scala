package orb.sim

import orb.OrbConfig
import orb.model.{GrayImage, HarrisModel}
import org.scalatest.funsuite.AnyFunSuite

/** The fixed-point model against the same Harris definition in floating point (OpenCV primitives), on real
  * photographs. Bounds:
  *  - Pearson correlation of the response maps (pixels `border` or more from the edges) >= 0.9999;
  *  - relative error of R <= 2 % on every pixel whose float response is above the corner threshold;
  *  - >= 98 % of the model's corners have a float-reference corner within 1 px, and the other way round.
  * The overlap with cv::cornerHarris (box window) is printed as information only. */
class HarrisOpenCvSpec extends AnyFunSuite {
  val cfg: OrbConfig = OrbConfig.default
  // the threshold the README's fidelity figures were measured at (the default before the feature budget)
  val threshold: Long = 1L << 14
  val images = Seq("graf1.png", "graf3.png", "box.png", "box_in_scene.png", "aero1.png", "leuvenA.png")

  test("fixed-point Harris follows the float definition on real photographs") {
    println(s"[orb] ${HarrisFidelity.header}")
    val figures = images.map { name =>
      val f = HarrisFidelity.measure(name, GrayImage.load(new java.io.File("data", name)), cfg, threshold)
      println(s"[orb] ${HarrisFidelity.row(f)}")
      f
    }
    for (f <- figures) {
      assert(f.corners > 50, s"${f.image}: too few corners to judge")
      assert(f.correlation >= 0.9999, s"${f.image}: correlation ${f.correlation}")
      assert(f.maxRelErrStrong <= 0.02, s"${f.image}: max relative error ${f.maxRelErrStrong}")
      assert(
        f.matchedWithin1 >= 0.98,
        s"${f.image}: ${f.matchedWithin1} of the corners have a float corner within 1 px"
      )
      assert(
        f.recallWithin1 >= 0.98,
        s"${f.image}: ${f.recallWithin1} of the float corners have a model corner within 1 px"
      )
    }
  }

  test(
    "the segment test is OpenCV's FAST-9 test on every pixel (FAST without its suppression), thresholds 10, 20, 40"
  ) {
    for (name <- Seq("graf1.png", "box.png"); t <- Seq(10, 20, 40)) {
      val img = GrayImage.load(new java.io.File("data", name))
      val ours = HarrisModel.segmentTest(img, t, 9)
      val mine = (for (y <- 0 until img.height; x <- 0 until img.width if ours(x, y)) yield (x, y)).toSet
      val theirs = OpenCv.fast(img, t, suppress = false).toSet
      println(s"[orb] segment test $name t=$t: ${mine.size} pixels pass, OpenCV FAST ${theirs.size}")
      assert(
        mine.size > 500 && mine == theirs,
        s"$name t=$t: ${(mine -- theirs).take(3)} only ours, ${(theirs -- mine).take(3)} only OpenCV's"
      )
    }
  }
}
