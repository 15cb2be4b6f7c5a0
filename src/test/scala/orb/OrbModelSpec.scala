package orb

import orb.model._
import org.scalatest.funsuite.AnyFunSuite
import scala.util.Random

/** The descriptor model's integer steps against their definitions. */
class OrbModelSpec extends AnyFunSuite {
  val cfg: OrbDescriptorConfig = OrbDescriptorConfig()

  test("the blur keeps a flat image flat and its kernel sums to 256") {
    assert(OrbDescriptorConfig.blurKernel.sum == 256)
    val flat = GrayImage.tabulate(20, 20)((_, _) => 173)
    val s = OrbModel.smooth(flat)
    assert((3 until 17).forall(y => (3 until 17).forall(x => s(x, y) == 173)))
  }

  test("the orientation patch is OpenCV's: 15 px radius, umax half widths") {
    assert(OrbModel.disc.size == OrbDescriptorConfig.umax.map(2 * _ + 1).sum * 2 - 31)
    assert(OrbModel.disc.contains((15, 0)) && OrbModel.disc.contains((3, 15)) && !OrbModel.disc.contains((4, 15)))
  }

  test("angle bins: the nearest bin to atan2 on random vectors, exact on the axes and diagonals") {
    val n = cfg.angleBins
    assert(OrbModel.angleBin(0, 0, cfg) == 0)
    assert(OrbModel.angleBin(100, 0, cfg) == 0 && OrbModel.angleBin(0, 100, cfg) == n / 4)
    assert(OrbModel.angleBin(-100, 0, cfg) == n / 2 && OrbModel.angleBin(0, -100, cfg) == 3 * n / 4)
    assert(OrbModel.angleBin(77, 77, cfg) == n / 8 && OrbModel.angleBin(-77, -77, cfg) == 5 * n / 8)
    val rng = new Random(TestSupport.seed)
    for (_ <- 0 until 20000) {
      val (x, y) = (rng.nextInt(4000001) - 2000000L, rng.nextInt(4000001) - 2000000L)
      val deg = (math.toDegrees(math.atan2(y.toDouble, x.toDouble)) + 360) % 360
      val e = (OrbModel.binDegrees(OrbModel.angleBin(x, y, cfg), cfg) - deg) % 360
      assert(math.min(e.abs, 360 - e.abs) <= cfg.binDegrees / 2 + 1e-4, s"($x, $y)")
    }
  }

  test("pattern rotation: cvRound semantics (half to even) and exact quarter turns") {
    assert(
      OrbModel.roundHalfEven(5L << 15, 16) == 2 && OrbModel.roundHalfEven(3L << 15, 16) == 2 && OrbModel.roundHalfEven(
        7L << 15,
        16
      ) == 4
    )
    assert(OrbModel.roundHalfEven(-(1L << 15), 16) == 0 && OrbModel.roundHalfEven(-(3L << 15), 16) == -2)
    val quarter = OrbModel.rotatedTests(cfg.angleBins / 4, cfg)
    assert(quarter.zip(Pattern.tests).forall { case ((x1, y1, x2, y2), t) =>
      (x1, y1, x2, y2) == (-t.y1, t.x1, -t.y2, t.x2)
    })
    assert(OrbModel.rotatedTests(0, cfg).forall { case (x1, y1, x2, y2) =>
      Seq(x1, y1, x2, y2).forall(_.abs <= OrbDescriptorConfig.sampleReach)
    })
  }

  test("a flat patch gives an all-zero descriptor; a left-to-right ramp gives the tests with x1 < x2") {
    val flat = GrayImage.tabulate(60, 60)((_, _) => 90)
    assert(OrbModel.descriptor(OrbModel.smooth(flat), 30, 30, 0, cfg).forall(_ == 0))
    val ramp = GrayImage.tabulate(60, 60)((x, _) => 4 * x)
    val f = Feature(30, 30, 0, 0, OrbModel.descriptor(OrbModel.smooth(ramp), 30, 30, 0, cfg))
    assert((0 until 256).forall(i => f.bit(i) == (if (Pattern.tests(i).x1 < Pattern.tests(i).x2) 1 else 0)))
  }
}
