package orb.sim

import orb._
import orb.model._
import org.bytedeco.opencv.global.opencv_core.NORM_HAMMING
import org.bytedeco.opencv.opencv_core.{DMatchVector, KeyPointVector, Mat}
import org.bytedeco.opencv.opencv_features2d.{BFMatcher, ORB}
import org.knowm.xchart.{BitmapEncoder, XYChartBuilder}
import org.knowm.xchart.BitmapEncoder.BitmapFormat

import java.io.File

/** `sim/runMain orb.sim.Evaluate --key A.png --live B.png --homography H.txt --out DIR`: the paper's Figure 9 for
  * this core against OpenCV ORB: the proportion of inliers (within 3 px of the ground truth) against the Hamming
  * threshold, and against the number of matches (best first by distance). */
object Evaluate {
  val app = "orb.sim.Evaluate"
  val usage: String =
    s"""usage: $app --key KEY.png --live LIVE.png --homography H.txt --out DIR [--features N] [--harris-threshold T]
       |       [--segment-threshold T | --no-segment-test]   the feature budget's target and the corner detector's
       |       run-time parameters (see Match --help); the images go through the core as Match sends them
       |  Our core (golden model; the RTL is bit-exact with it) with the default store, cross-check, and with the
       |  ratio test 0.8 too; OpenCV ORB with as many features per image as ours (keyframe: our store), 1 and 8 levels,
       |  BFMatcher(NORM_HAMMING, crossCheck = true). Writes figure9_threshold.{csv,png}, figure9_count.{csv,png}.""".stripMargin

  /** A method's matches: Hamming distance and reprojection error, sorted by distance (stable). */
  final case class Series(name: String, matches: Seq[(Int, Double)]) {
    def upTo(t: Int): Seq[(Int, Double)] = matches.filter(_._1 <= t)
    def inliers(ms: Seq[(Int, Double)], px: Double = 3): Double =
      if (ms.isEmpty) Double.NaN else ms.count(_._2 <= px).toDouble / ms.size
    def bestN(n: Int): Seq[(Int, Double)] = matches.take(n)
  }

  /** Our matches, and the number of features in the store and in the live frame. */
  def ours(
      name: String,
      key: GrayImage,
      live: GrayImage,
      h: Array[Double],
      cfg: OrbConfig,
      corners: CornerParams,
      p: MatchParams
  ): (Series, Int, Int) = {
    val r = SystemModel.run(cfg, SystemModel.pairBeats(key, live), corners, p.copy(hammingThreshold = 256))
    val liveCount = SystemModel.keyAndLive(r.matches)._2.size
    (
      Series(name, r.lastLive.map(c => (c.distance, Homography.error(h, c))).sortBy(_._1)),
      r.matches.store.features.size,
      liveCount
    )
  }

  /** OpenCV ORB with `keyFeatures` / `liveFeatures` features (its best by Harris score), BFMatcher cross-check. */
  def openCv(
      name: String,
      key: GrayImage,
      live: GrayImage,
      h: Array[Double],
      keyFeatures: Int,
      liveFeatures: Int,
      levels: Int
  ): Series = {
    def orb(n: Int) = ORB.create(n max 1, 1.2f, levels, 31, 0, 2, ORB.HARRIS_SCORE, 31, 20)
    val (kk, kd, lk, ld) = (new KeyPointVector(), new Mat(), new KeyPointVector(), new Mat())
    orb(keyFeatures).detectAndCompute(OpenCv.toMat(key), new Mat(), kk, kd)
    orb(liveFeatures).detectAndCompute(OpenCv.toMat(live), new Mat(), lk, ld)
    val out = new DMatchVector()
    new BFMatcher(NORM_HAMMING, true).`match`(ld, kd, out)
    Series(
      name,
      (0 until out.size().toInt).map(i => out.get(i.toLong)).map { m =>
        val k = kk.get(m.trainIdx().toLong).pt(); val l = lk.get(m.queryIdx().toLong).pt()
        (m.distance().round, Homography.error(h, k.x(), k.y(), l.x(), l.y()))
      }.sortBy(_._1)
    )
  }

  def evaluate(
      key: GrayImage,
      live: GrayImage,
      h: Array[Double],
      cfg: OrbConfig,
      corners: CornerParams
  ): Seq[Series] = {
    val ratio = math.round(0.8 * (1 << cfg.matcher.ratioFracBits)).toInt
    val (cross, keyCount, liveCount) =
      ours("ours, cross-check", key, live, h, cfg, corners, MatchParams(256, None, crossCheck = true))
    val (both, _, _) = ours(
      "ours, cross-check + ratio 0.8",
      key,
      live,
      h,
      cfg,
      corners,
      MatchParams(256, Some(ratio), crossCheck = true)
    )
    Seq(
      cross,
      both,
      openCv("OpenCV ORB, 1 level", key, live, h, keyCount, liveCount, 1),
      openCv("OpenCV ORB, 8 levels", key, live, h, keyCount, liveCount, 8)
    )
  }

  def write(dir: File, series: Seq[Series]): Unit = {
    val thresholds = 0 to 256 by 2
    Match.write(new File(dir, "figure9_threshold.csv")) { w =>
      w.println(("threshold" +: series.flatMap(s => Seq(s"${key(s)}_matches", s"${key(s)}_inliers_3px"))).mkString(","))
      for (t <- thresholds)
        w.println((t.toString +: series.flatMap { s =>
          val m = s.upTo(t); Seq(m.size.toString, fmt(s.inliers(m)))
        }).mkString(","))
    }
    val maxN = series.map(_.matches.size).max
    Match.write(new File(dir, "figure9_count.csv")) { w =>
      w.println(("matches" +: series.map(s => s"${key(s)}_inliers_3px")).mkString(","))
      for (n <- 1 to maxN) w.println((n.toString +: series.map(s =>
        if (n <= s.matches.size) fmt(s.inliers(s.bestN(n))) else ""
      )).mkString(","))
    }
    plot(
      new File(dir, "figure9_threshold.png"),
      "Inliers against the Hamming threshold",
      "Hamming threshold",
      series.map(s => (s.name, thresholds.filter(t => s.upTo(t).nonEmpty).map(t => (t.toDouble, s.inliers(s.upTo(t))))))
    )
    plot(
      new File(dir, "figure9_count.png"),
      "Inliers against the number of matches (best first)",
      "matches",
      series.map(s => (s.name, (1 to s.matches.size).map(n => (n.toDouble, s.inliers(s.bestN(n))))))
    )
  }

  private def key(s: Series): String = s.name.toLowerCase.replaceAll("[^a-z0-9]+", "_").stripSuffix("_")
  private def fmt(d: Double): String = if (d.isNaN) "" else f"$d%.4f"

  def plot(file: File, title: String, xTitle: String, lines: Seq[(String, Seq[(Double, Double)])]): Unit = {
    val chart = new XYChartBuilder().width(900).height(560).title(title).xAxisTitle(xTitle).yAxisTitle(
      "proportion of inliers (3 px)"
    ).build()
    chart.getStyler.setYAxisMin(0.0).setYAxisMax(1.0)
    chart.getStyler.setMarkerSize(0)
    for ((name, pts) <- lines if pts.nonEmpty)
      chart.addSeries(name, pts.map(_._1).toArray, pts.map(_._2).toArray)
    BitmapEncoder.saveBitmap(chart, file.getPath.stripSuffix(".png"), BitmapFormat.PNG)
  }

  final case class Options(
      key: Option[String] = None,
      live: Option[String] = None,
      homography: Option[String] = None,
      out: Option[String] = None,
      threshold: Option[Long] = None,
      /** None: the configuration's default; Some(None): no segment test */
      segment: Option[Option[Int]] = None,
      features: Option[Int] = None
  )

  private val options: Seq[CommandLine.Opt[Options]] = {
    import CommandLine.{flag, valued, whole}
    def segment(o: Options, s: Option[Int]): Options =
      if (o.segment.exists(_.isDefined != s.isDefined))
        CommandLine.fail("--segment-threshold and --no-segment-test contradict each other")
      else o.copy(segment = Some(s))
    Seq(
      valued("--key")((o, v) => o.copy(key = Some(v))),
      valued("--live")((o, v) => o.copy(live = Some(v))),
      valued("--homography")((o, v) => o.copy(homography = Some(v))),
      valued("--out")((o, v) => o.copy(out = Some(v))),
      valued("--harris-threshold")((o, v) => o.copy(threshold = Some(whole("--harris-threshold", v, 0, 0xffffffffL)))),
      valued("--segment-threshold")((o, v) => segment(o, Some(whole("--segment-threshold", v, 0, 255).toInt))),
      flag("--no-segment-test")(o => segment(o, None)),
      valued("--features")((o, v) => o.copy(features = Some(whole("--features", v, 0, BudgetConfig.targetMax).toInt)))
    )
  }

  def main(args: Array[String]): Unit = Cli.main(app, usage, args.toSeq) {
    val o = CommandLine.parse(args.toSeq, Options(), options)
    def required(v: Option[String], name: String): String =
      v.getOrElse(CommandLine.fail(s"$name is required (see --help)"))
    val (keyPath, livePath) = (required(o.key, "--key"), required(o.live, "--live"))
    val (hPath, out) = (required(o.homography, "--homography"), required(o.out, "--out"))
    val cfg = OrbConfig.default
    val defaults = cfg.defaultParams
    val corners = CornerParams(
      o.threshold.getOrElse(defaults.threshold),
      o.segment.getOrElse(defaults.segmentThreshold),
      o.features.getOrElse(defaults.target)
    )
    val key = Match.loadImage(keyPath, "--key", cfg)
    val live = Match.loadImage(livePath, "--live", cfg)
    val h =
      try Homography.load(hPath)
      catch { case e: Exception => CommandLine.fail(s"--homography: ${e.getMessage}") }
    val dir = new File(out)
    dir.mkdirs()
    val series = evaluate(key, live, h, cfg, corners)
    write(dir, series)
    val n = series.map(_.matches.size).min
    println(s"$app: inliers within 3 px (all matches | the best $n of each, the smallest common count)")
    for (s <- series)
      println(
        f"  ${s.name}%-32s ${s.matches.size}%5d matches: ${s.inliers(s.matches) * 100}%5.1f%% | ${s.inliers(s.bestN(n)) * 100}%5.1f%%"
      )
    println(s"$app: wrote ${dir.getPath}/figure9_threshold.{csv,png} and figure9_count.{csv,png}")
  }
}
