package orb.sim

import orb._
import orb.model._

/** `sim/runMain orb.sim.DetectorStudy [--key A.png --live B.png --homography H.txt] [--threshold T]`: which corner
  * points match best on a pair with ground truth. Every variant's points go through the same descriptor model,
  * store and cross-checked matcher (Hamming <= 64); OpenCV ORB (1 level) is given the same feature counts; inliers
  * within 3 px of the best n matches of each, n the smaller match count. The README's segment-test figures. */
object DetectorStudy {
  val app = "orb.sim.DetectorStudy"
  val cfg: OrbConfig = OrbConfig.default

  final case class Row(name: String, keyCount: Int, liveCount: Int, n: Int, ours: Double, openCv: Double)

  def row(name: String, key: GrayImage, live: GrayImage, h: Array[Double], kc: Seq[Corner], lc: Seq[Corner]): Row = {
    val d = cfg.descriptor
    val store = MatcherModel.store(OrbModel.features(key, kc, d), cfg.matcher)
    val p = MatchParams(cfg.matcher.defaultHammingThreshold, None, crossCheck = true)
    val cs = MatcherModel.matchFrame(store, OrbModel.features(live, lc, d), p, cfg.matcher)
    val mine = Evaluate.Series(name, cs.map(c => (c.distance, Homography.error(h, c))).sortBy(_._1))
    val cv = Evaluate.openCv("OpenCV", key, live, h, store.features.size, lc.size, 1)
    val n = mine.matches.size min cv.matches.size
    Row(name, kc.size, lc.size, n, mine.inliers(mine.bestN(n)), cv.inliers(cv.bestN(n)))
  }

  /** OpenCV's FAST-9 corners (its suppression on the FAST score), the `n` with the highest score of ours. */
  def fastRanked(img: GrayImage, n: Int, t: Int): Seq[Corner] = {
    val score = HarrisModel.score(HarrisModel.responseMap(img, cfg.harris), cfg.harris)
    val b = cfg.harris.border
    OpenCv.fast(img, t, suppress = true)
      .filter { case (x, y) => x >= b && y >= b && x < img.width - b && y < img.height - b }
      .map { case (x, y) => Corner(x, y, score(x, y)) }.sortBy(c => (-c.score, c.y, c.x)).take(n).sortBy(c => (c.y, c.x))
  }

  /** Each Harris maximum moved to the candidate with the highest score within `r` px (dropped if none). */
  def moved(img: GrayImage, maxima: Seq[Corner], t: Int, r: Int): Seq[Corner] = {
    val score = HarrisModel.score(HarrisModel.responseMap(img, cfg.harris), cfg.harris)
    val pass = HarrisModel.segmentTest(img, t, cfg.harris.segment.fold(9)(_.arc))
    maxima.flatMap { c =>
      (for (dy <- -r to r; dx <- -r to r if pass(c.x + dx, c.y + dy)) yield Corner(c.x + dx, c.y + dy, score(c.x + dx, c.y + dy)))
        .sortBy(q => (-q.score, q.y, q.x)).headOption
    }.distinct.sortBy(c => (c.y, c.x))
  }

  def study(key: GrayImage, live: GrayImage, h: Array[Double], threshold: Long): Seq[Row] = {
    val t = cfg.harris.segment.fold(20)(_.defaultThreshold)
    val plain = CornerParams(threshold / 2, None) // about the default's corner rate (see HarrisConfig.defaultThreshold)
    val (km, lm) = (HarrisModel.corners(key, cfg.harris, plain), HarrisModel.corners(live, cfg.harris, plain))
    def pass(img: GrayImage) = HarrisModel.segmentTest(img, t, cfg.harris.segment.fold(9)(_.arc))
    val (kp, lp) = (pass(key), pass(live))
    Seq(
      row(s"Harris maxima, threshold ${threshold / 2}", key, live, h, km, lm),
      row(s"default: Harris over segment-test candidates, threshold $threshold", key, live, h,
        HarrisModel.corners(key, cfg.harris, CornerParams(threshold, Some(t))), HarrisModel.corners(live, cfg.harris, CornerParams(threshold, Some(t)))),
      row("OpenCV FAST corners ranked by our Harris score, as many as the maxima", key, live, h, fastRanked(key, km.size, t), fastRanked(live, lm.size, t)),
      row("Harris maxima that pass the segment test", key, live, h, km.filter(c => kp(c.x, c.y)), lm.filter(c => lp(c.x, c.y))),
      row("Harris maxima moved to the best candidate within 1 px", key, live, h, moved(key, km, t, 1), moved(live, lm, t, 1)))
  }

  def main(args: Array[String]): Unit = {
    def fail(msg: String): Nothing = { System.err.println(s"$app: $msg"); sys.exit(2) }
    val known = Set("--key", "--live", "--homography", "--threshold")
    if (args.contains("--help")) { println(s"usage: $app [--key A.png --live B.png --homography H.txt] [--threshold T]"); return }
    if (args.length % 2 != 0) fail("every option takes a value (see --help)")
    val opts = args.grouped(2).map { case Array(k, v) => if (known(k)) k -> v else fail(s"unknown argument '$k' (see --help)") }.toMap
    val threshold = opts.get("--threshold").map(v => v.toLongOption.filter(_ >= 2).getOrElse(fail(s"--threshold takes a whole number >= 2, not '$v'")))
      .getOrElse(1L << 14) // the detector study predates the feature budget: it compares detectors by threshold
    val key = try Match.loadImage(opts.getOrElse("--key", "data/graf1.png"), "--key", cfg) catch { case e: Match.UsageError => fail(e.getMessage) }
    val live = try Match.loadImage(opts.getOrElse("--live", "data/graf3.png"), "--live", cfg) catch { case e: Match.UsageError => fail(e.getMessage) }
    val h = try Homography.load(opts.getOrElse("--homography", "data/graf_1to3.H.txt")) catch { case e: Exception => fail(s"--homography: ${e.getMessage}") }
    println(f"${"corner points"}%-72s ${"key"}%5s ${"live"}%5s ${"n"}%4s ${"ours"}%6s ${"OpenCV"}%6s")
    for (r <- study(key, live, h, threshold))
      println(f"${r.name}%-72s ${r.keyCount}%5d ${r.liveCount}%5d ${r.n}%4d ${r.ours * 100}%5.1f%% ${r.openCv * 100}%5.1f%%")
  }
}
