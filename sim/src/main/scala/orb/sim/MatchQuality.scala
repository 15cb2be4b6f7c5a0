package orb.sim

import orb.{MatcherConfig, OrbConfig}
import orb.model._
import org.bytedeco.opencv.global.opencv_core._
import org.bytedeco.opencv.opencv_core.{DMatchVector, KeyPointVector, Mat}
import org.bytedeco.opencv.opencv_features2d.{BFMatcher, ORB}

/** Match quality against a ground-truth homography: our model's cross-checked matches and OpenCV ORB's
  * (single scale, BFMatcher cross-check), each taken best-first, compared at the same number of matches. */
object MatchQuality {
  final case class Quality(matches: Int, inliers3: Double, inliers8: Double)

  def homography(path: String): Array[Double] = {
    val v = scala.io.Source.fromFile(path).getLines().flatMap(_.trim.split("\\s+")).filter(_.nonEmpty).map(_.toDouble).toArray
    require(v.length == 9, s"$path: a homography has 9 numbers, found ${v.length}")
    v
  }
  def project(h: Array[Double], x: Double, y: Double): (Double, Double) = {
    val w = h(6) * x + h(7) * y + h(8)
    ((h(0) * x + h(1) * y + h(2)) / w, (h(3) * x + h(4) * y + h(5)) / w)
  }
  /** pairs (keyframe x, y, live x, y), best first */
  def quality(pairs: Seq[(Double, Double, Double, Double)], h: Array[Double]): Quality = {
    val errs = pairs.map { case (kx, ky, lx, ly) => val (px, py) = project(h, kx, ky); math.hypot(px - lx, py - ly) }
    def frac(t: Double) = if (errs.isEmpty) 0.0 else errs.count(_ <= t).toDouble / errs.size
    Quality(pairs.size, frac(3), frac(8))
  }

  def ours(key: GrayImage, live: GrayImage, cfg: OrbConfig, params: MatchParams): Seq[(Double, Double, Double, Double)] = {
    def feats(img: GrayImage) = OrbModel.features(img, HarrisModel.corners(img, cfg.harris, cfg.harris.defaultThreshold), cfg.descriptor)
    val store = MatcherModel.store(feats(key), cfg.matcher)
    MatcherModel.matchFrame(store, feats(live), params, cfg.matcher)
      .sortBy(_.distance).map(c => (c.keyX.toDouble, c.keyY.toDouble, c.liveX.toDouble, c.liveY.toDouble))
  }

  def openCv(key: GrayImage, live: GrayImage, nfeatures: Int, levels: Int): Seq[(Double, Double, Double, Double)] = {
    val orb = ORB.create(nfeatures, 1.2f, levels, 31, 0, 2, ORB.HARRIS_SCORE, 31, 20)
    val (kk, kd, lk, ld) = (new KeyPointVector(), new Mat(), new KeyPointVector(), new Mat())
    orb.detectAndCompute(OpenCv.toMat(key), new Mat(), kk, kd)
    orb.detectAndCompute(OpenCv.toMat(live), new Mat(), lk, ld)
    val out = new DMatchVector()
    new BFMatcher(NORM_HAMMING, true).`match`(ld, kd, out)
    (0 until out.size().toInt).map(i => out.get(i.toLong)).sortBy(_.distance()).map { m =>
      val k = kk.get(m.trainIdx().toLong).pt(); val l = lk.get(m.queryIdx().toLong).pt()
      (k.x().toDouble, k.y().toDouble, l.x().toDouble, l.y().toDouble)
    }
  }

  /** `sim/runMain orb.sim.MatchQuality [KEY LIVE H]` (default: graf1, graf3 and their homography). */
  def main(args: Array[String]): Unit = {
    val Array(k, l, hp) = if (args.length == 3) args else Array("data/graf1.png", "data/graf3.png", "data/graf_1to3.H.txt")
    val cli = new Cli("orb.sim.MatchQuality", "usage: orb.sim.MatchQuality [KEY.png LIVE.png H.txt]", withBins = false)
    if (args.nonEmpty && args.length != 3) cli.fail("give the keyframe image, the live image and the homography, or nothing")
    val (key, live) = (cli.load(k), cli.load(l))
    val h = try homography(hp) catch { case e: Exception => cli.fail(s"cannot read the homography $hp: ${e.getMessage}") }
    val cfg = OrbConfig.default.copy(matcher = MatcherConfig(storeCapacity = 1 << 16))
    val cv = openCv(key, live, nfeatures = 1000, levels = 1)
    println(s"model (store unbounded here) vs OpenCV ORB, 1 level, 1000 features, BFMatcher cross-check; best n of each by distance")
    for ((name, p) <- Seq("cross-check" -> MatchParams(256, None, crossCheck = true),
                          "cross-check + ratio 0.8" -> MatchParams(256, Some(205), crossCheck = true))) {
      val mine = ours(key, live, cfg, p)
      val n = mine.size min cv.size
      val (q1, q2) = (quality(mine.take(n), h), quality(cv.take(n), h))
      println(f"$name%-24s n = $n%4d: ours ${q1.inliers3 * 100}%5.1f%% within 3 px, ${q1.inliers8 * 100}%5.1f%% within 8 px; " +
        f"OpenCV ${q2.inliers3 * 100}%5.1f%% / ${q2.inliers8 * 100}%5.1f%%")
    }
  }
}
