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
      .map { case (x, y) => Corner(x, y, score(x, y)) }.sortBy(c => (-c.score, c.y, c.x)).take(n).sortBy(c =>
        (c.y, c.x)
      )
  }

  /** Each Harris maximum moved to the candidate with the highest score within `r` px (dropped if none). */
  def moved(img: GrayImage, maxima: Seq[Corner], t: Int, r: Int): Seq[Corner] = {
    val score = HarrisModel.score(HarrisModel.responseMap(img, cfg.harris), cfg.harris)
    val pass = HarrisModel.segmentTest(img, t, cfg.harris.segment.fold(9)(_.arc))
    maxima.flatMap { c =>
      (for (dy <- -r to r; dx <- -r to r if pass(c.x + dx, c.y + dy))
        yield Corner(c.x + dx, c.y + dy, score(c.x + dx, c.y + dy)))
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
      row(
        s"default: Harris over segment-test candidates, threshold $threshold",
        key,
        live,
        h,
        HarrisModel.corners(key, cfg.harris, CornerParams(threshold, Some(t))),
        HarrisModel.corners(live, cfg.harris, CornerParams(threshold, Some(t)))
      ),
      row(
        "OpenCV FAST corners ranked by our Harris score, as many as the maxima",
        key,
        live,
        h,
        fastRanked(key, km.size, t),
        fastRanked(live, lm.size, t)
      ),
      row(
        "Harris maxima that pass the segment test",
        key,
        live,
        h,
        km.filter(c => kp(c.x, c.y)),
        lm.filter(c => lp(c.x, c.y))
      ),
      row(
        "Harris maxima moved to the best candidate within 1 px",
        key,
        live,
        h,
        moved(key, km, t, 1),
        moved(live, lm, t, 1)
      )
    )
  }

  val usage = s"usage: $app [--key A.png --live B.png --homography H.txt] [--threshold T]"

  final case class Options(
      key: String = "data/graf1.png",
      live: String = "data/graf3.png",
      homography: String = "data/graf_1to3.H.txt",
      /** the detector study predates the feature budget: it compares detectors by threshold */
      threshold: Long = 1L << 14
  )

  private val options: Seq[CommandLine.Opt[Options]] = Seq(
    CommandLine.valued("--key")((o, v) => o.copy(key = v)),
    CommandLine.valued("--live")((o, v) => o.copy(live = v)),
    CommandLine.valued("--homography")((o, v) => o.copy(homography = v)),
    CommandLine.valued("--threshold")((o, v) =>
      o.copy(threshold = CommandLine.whole("--threshold", v, 2, Long.MaxValue))
    )
  )

  def main(args: Array[String]): Unit = Cli.main(app, usage, args.toSeq) {
    val o = CommandLine.parse(args.toSeq, Options(), options)
    val key = Match.loadImage(o.key, "--key", cfg)
    val live = Match.loadImage(o.live, "--live", cfg)
    val h =
      try Homography.load(o.homography)
      catch { case e: Exception => CommandLine.fail(s"--homography: ${e.getMessage}") }
    println(f"${"corner points"}%-72s ${"key"}%5s ${"live"}%5s ${"n"}%4s ${"ours"}%6s ${"OpenCV"}%6s")
    for (r <- study(key, live, h, o.threshold))
      println(
        f"${r.name}%-72s ${r.keyCount}%5d ${r.liveCount}%5d ${r.n}%4d ${r.ours * 100}%5.1f%% ${r.openCv * 100}%5.1f%%"
      )
  }
}
