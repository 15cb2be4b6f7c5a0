package orb.sim

import orb.OrbConfig
import orb.model.GrayImage
import org.scalatest.funsuite.AnyFunSuite

/** The descriptor model against OpenCV's ORB (nlevels 1) on real photographs, at the model's Harris corners:
  *  1. engine alone (OpenCV given our quantised angle): mean Hamming distance <= 1.0 bit of 256;
  *  2. end to end (OpenCV's own IC_Angle and descriptor): mean <= 3.0 bits;
  *  3. our bin within half a bin of OpenCV's angle for >= 99 % of the corners;
  *  and the fixed-point blur within +-1 of OpenCV's (as ORB applies it) on >= 99.9 % of the pixels. */
class OrbOpenCvSpec extends AnyFunSuite {
  val cfg: OrbConfig = OrbConfig.default
  val images = Seq("graf1.png", "box.png", "aero1.png", "leuvenA.png")

  test(s"descriptor model follows OpenCV ORB (${cfg.descriptor.angleBins} orientation bins)") {
    println(s"[orb] ${OrbFidelity.header}")
    val figures = images.map { name =>
      // at the threshold of the README's figures (the default before the feature budget)
      val f = OrbFidelity.measure(name, GrayImage.load(new java.io.File("data", name)), cfg, 1L << 14)
      println(s"[orb] ${OrbFidelity.row(f, cfg.descriptor.angleBins)}")
      f
    }
    for (f <- figures) {
      assert(f.corners > 50 && f.compared == f.corners, s"${f.image}: OpenCV dropped some of our corners")
      assert(f.blurWithin1 >= 0.999, s"${f.image}: blur within +-1 on ${f.blurWithin1}")
      assert(f.hammingEngine <= 1.0, s"${f.image}: engine alone ${f.hammingEngine} bits")
      assert(f.hammingEndToEnd <= 3.0, s"${f.image}: end to end ${f.hammingEndToEnd} bits")
      assert(f.angleWithinHalfBin >= 0.99, s"${f.image}: ${f.angleWithinHalfBin} within half a bin")
    }
  }
}
