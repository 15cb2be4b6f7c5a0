package orb.sim

import orb._
import orb.model._
import org.bytedeco.opencv.global.opencv_calib3d.{RANSAC, findHomography}
import org.bytedeco.opencv.global.opencv_core.{CV_32FC2, NORM_HAMMING}
import org.bytedeco.opencv.opencv_core.{DMatchVector, KeyPointVector, Mat}
import org.bytedeco.opencv.opencv_features2d.{BFMatcher, ORB}
import org.bytedeco.javacpp.indexer.FloatIndexer

/** `sim/runMain orb.sim.Quality [--target N] [PAIR ...]`: the feature budget's quality goals on image pairs with a
  * reference, our core (golden model; the RTL is bit-exact with it) against OpenCV ORB run here (JavaCV 1.5.13,
  * OpenCV 4.13):
  *  - features per frame against the target, and their spread: the share of the 16 x 12 grid cells that hold a
  *    feature, ours against OpenCV's out-of-the-box ORB;
  *  - inlier correspondences (3 px) against OpenCV's out-of-the-box ORB (`ORB_create()`: 500 features, 8 levels;
  *    `BFMatcher(NORM_HAMMING, crossCheck = true)`);
  *  - the inlier ratio against OpenCV single-scale ORB given our feature counts, at the same number of matches
  *    (the best by distance).
  * A pair is KEY,LIVE,REFERENCE where REFERENCE is a homography file, `disparity:FILE` (a rectified stereo pair's
  * left disparity, 0 = unknown) or `ransac` (a RANSAC homography fitted to OpenCV ORB's matches of 5,000
  * features: for consecutive video frames). Without pairs: the pairs in data/ that have a reference. */
object Quality {
  val app = "orb.sim.Quality"

  /** A reference: the error of a correspondence in pixels, or None where the truth is unknown. */
  trait Truth { def error(kx: Double, ky: Double, lx: Double, ly: Double): Option[Double] }
  final case class HomographyTruth(h: Array[Double]) extends Truth {
    def error(kx: Double, ky: Double, lx: Double, ly: Double): Option[Double] =
      Some(Homography.error(h, kx, ky, lx, ly))
  }

  /** Left (key) pixel (x, y) is right (live) pixel (x - d, y). */
  final case class DisparityTruth(d: GrayImage) extends Truth {
    def error(kx: Double, ky: Double, lx: Double, ly: Double): Option[Double] = {
      val (x, y) = (math.round(kx).toInt, math.round(ky).toInt)
      if (x < 0 || y < 0 || x >= d.width || y >= d.height || d(x, y) == 0) None
      else Some(math.hypot(kx - d(x, y) - lx, ky - ly))
    }
  }

  final case class Pair(name: String, key: GrayImage, live: GrayImage, truth: Truth)

  /** Matches of one method: (Hamming distance, error), the unknown ones left out, sorted by distance. */
  final case class Result(
      keyFeatures: Int,
      liveFeatures: Int,
      matches: Seq[(Int, Double)],
      keyPoints: Seq[(Double, Double)],
      livePoints: Seq[(Double, Double)]
  ) {
    def inliers(px: Double = 3): Int = matches.count(_._2 <= px)
    def ratio(n: Int = matches.size): Double =
      if (n == 0) Double.NaN else matches.take(n).count(_._2 <= 3).toDouble / (n min matches.size)
  }

  /** Share of the cells of a 16 x 12 grid over the image that hold at least one point. */
  def spread(points: Seq[(Double, Double)], w: Int, h: Int): Double = {
    val cells = points.map { case (x, y) => ((x * 16 / w).toInt min 15, (y * 12 / h).toInt min 11) }.distinct
    cells.size / 192.0
  }

  def ours(p: Pair, cfg: OrbConfig, corners: CornerParams, hamming: Int): Result = {
    val r = SystemModel.run(
      cfg,
      SystemModel.pairBeats(p.key, p.live),
      corners,
      MatchParams(hamming, None, cfg.matcher.defaultCrossCheck)
    )
    val (kf, lf) = SystemModel.keyAndLive(r.matches)
    val ms =
      r.lastLive.flatMap(c => p.truth.error(c.keyX, c.keyY, c.liveX, c.liveY).map(e => (c.distance, e))).sortBy(_._1)
    Result(kf.size, lf.size, ms, kf.map(f => (f.x.toDouble, f.y.toDouble)), lf.map(f => (f.x.toDouble, f.y.toDouble)))
  }

  /** OpenCV ORB (`levels` levels, its best `keyN` / `liveN` features by Harris score), BFMatcher cross-check. */
  def openCv(p: Pair, keyN: Int, liveN: Int, levels: Int): Result = {
    val (kk, kd, lk, ld, ms) = detectAndMatch(p, keyN, liveN, levels)
    val matches = ms.flatMap { case (ki, li, d) =>
      val k = kk(ki); val l = lk(li)
      p.truth.error(k._1, k._2, l._1, l._2).map(e => (d, e))
    }.sortBy(_._1)
    Result(kk.size, lk.size, matches, kk, lk)
  }

  def detectAndMatch(
      p: Pair,
      keyN: Int,
      liveN: Int,
      levels: Int
  ): (IndexedSeq[(Double, Double)], Mat, IndexedSeq[(Double, Double)], Mat, Seq[(Int, Int, Int)]) = {
    def orb(n: Int) = ORB.create(n max 1, 1.2f, levels, 31, 0, 2, ORB.HARRIS_SCORE, 31, 20)
    val (kk, kd, lk, ld) = (new KeyPointVector(), new Mat(), new KeyPointVector(), new Mat())
    orb(keyN).detectAndCompute(OpenCv.toMat(p.key), new Mat(), kk, kd)
    orb(liveN).detectAndCompute(OpenCv.toMat(p.live), new Mat(), lk, ld)
    val out = new DMatchVector()
    new BFMatcher(NORM_HAMMING, true).`match`(ld, kd, out)
    def points(v: KeyPointVector) = (0 until v.size.toInt).map { i =>
      val q = v.get(i.toLong).pt(); (q.x.toDouble, q.y.toDouble)
    }
    val ms =
      (0 until out.size().toInt).map(i => out.get(i.toLong)).map(m => (m.trainIdx(), m.queryIdx(), m.distance().round))
    (points(kk), kd, points(lk), ld, ms)
  }

  /** A homography fitted with RANSAC (3 px) to OpenCV ORB's cross-checked matches of 5,000 features, 8 levels. */
  def ransacTruth(key: GrayImage, live: GrayImage): Truth = {
    val dummy = Pair("", key, live, null)
    val (kk, _, lk, _, ms) = detectAndMatch(dummy, 5000, 5000, 8)
    val (src, dst) = (new Mat(ms.size, 1, CV_32FC2), new Mat(ms.size, 1, CV_32FC2))
    val (si, di) = (src.createIndexer[FloatIndexer](), dst.createIndexer[FloatIndexer]())
    for (((ki, li, _), i) <- ms.zipWithIndex) {
      si.put(i.toLong, 0L, 0L, kk(ki)._1.toFloat); si.put(i.toLong, 0L, 1L, kk(ki)._2.toFloat)
      di.put(i.toLong, 0L, 0L, lk(li)._1.toFloat); di.put(i.toLong, 0L, 1L, lk(li)._2.toFloat)
    }
    si.release(); di.release()
    val h = findHomography(src, dst, RANSAC, 3.0, new Mat(), 2000, 0.995)
    HomographyTruth(OpenCv.doubles(h))
  }

  def load(path: String): GrayImage = GrayImage.load(path)

  def defaultPairs: Seq[Pair] = Seq(
    Pair(
      "graf1 -> graf3",
      load("data/graf1.png"),
      load("data/graf3.png"),
      HomographyTruth(Homography.load("data/graf_1to3.H.txt"))
    ),
    Pair(
      "aloe L -> R (1024 crop)",
      load("data/aloeL_crop1024.png"),
      load("data/aloeR_crop1024.png"),
      DisparityTruth(load("data/aloe_dispL_crop1024.png"))
    ), {
      val (k, l) = (load("data/basketball1.png"), load("data/basketball2.png"));
      Pair("basketball 1 -> 2", k, l, ransacTruth(k, l))
    }, {
      val (k, l) = (load("data/rubberwhale1.png"), load("data/rubberwhale2.png"));
      Pair("rubberwhale 1 -> 2", k, l, ransacTruth(k, l))
    }
  )

  final case class Row(pair: Pair, ours: Result, cvDefault: Result, cvSingle: Result) {
    def n: Int = ours.matches.size

    /** the same number of matches for both, the best of each by distance */
    def common: Int = ours.matches.size min cvSingle.matches.size
  }

  def measure(p: Pair, cfg: OrbConfig, corners: CornerParams, hamming: Int): Row = {
    val o = ours(p, cfg, corners, hamming)
    Row(p, o, openCv(p, 500, 500, 8), openCv(p, o.keyFeatures, o.liveFeatures, 1))
  }

  val usage = s"usage: $app [--target N] [--harris-threshold T] [--segment-threshold T] [--hamming N] [--cell WxHxK] " +
    "[KEY,LIVE,REFERENCE ...]  (REFERENCE: H.txt | disparity:D.png | ransac)"

  final case class Options(
      cfg: OrbConfig,
      target: Int,
      segment: Option[Int],
      threshold: Long,
      hamming: Int,
      pairs: Seq[String] = Nil
  )

  private val options: Seq[CommandLine.Opt[Options]] = {
    import CommandLine.{valued, whole}
    Seq(
      valued("--target")((o, v) => o.copy(target = whole("--target", v, 0, BudgetConfig.targetMax).toInt)),
      valued("--segment-threshold")((o, v) => o.copy(segment = Some(whole("--segment-threshold", v, 0, 255).toInt))),
      valued("--harris-threshold")((o, v) => o.copy(threshold = whole("--harris-threshold", v, 0, 0xffffffffL))),
      valued("--hamming")((o, v) => o.copy(hamming = whole("--hamming", v, 0, 256).toInt)),
      valued("--cell") { (o, v) =>
        v.split("x").map(_.toIntOption) match {
          case Array(Some(w), Some(h), Some(k)) =>
            try o.copy(cfg = o.cfg.copy(budget = o.cfg.budget.copy(cellWidth = w, cellHeight = h, perCell = k)))
            catch { case e: IllegalArgumentException => CommandLine.fail(e.getMessage) }
          case _ => CommandLine.fail(s"--cell takes WxHxK (cell width, height, corners per cell), not '$v'")
        }
      }
    )
  }

  def main(args: Array[String]): Unit = Cli.main(app, usage, args.toSeq) {
    val defaults = OrbConfig.default
    val init = Options(
      defaults,
      defaults.budget.defaultTarget,
      defaults.harris.defaultParams.segmentThreshold,
      defaults.harris.defaultThreshold,
      defaults.matcher.defaultHammingThreshold
    )
    val o = CommandLine.parse(
      args.toSeq,
      init,
      options,
      positional = Some((o: Options, p: String) => o.copy(pairs = o.pairs :+ p))
    )
    val (cfg, target, segment, threshold, hamming) = (o.cfg, o.target, o.segment, o.threshold, o.hamming)
    val pairs =
      try {
        if (o.pairs.isEmpty) defaultPairs
        else o.pairs.map { s =>
          s.split(",") match {
            case Array(k, l, ref) =>
              val (key, live) = (load(k), load(l))
              val truth = if (ref == "ransac") ransacTruth(key, live)
              else if (ref.startsWith("disparity:")) DisparityTruth(load(ref.stripPrefix("disparity:")))
              else HomographyTruth(Homography.load(ref))
              Pair(s"$k -> $l", key, live, truth)
            case _ => CommandLine.fail(s"a pair is KEY,LIVE,REFERENCE, not '$s'")
          }
        }
      } catch { case e: IllegalArgumentException => CommandLine.fail(e.getMessage) }
    val corners = CornerParams(threshold, segment, target)
    println(
      s"$app: target $target features per frame, cells ${cfg.budget.cellWidth} x ${cfg.budget.cellHeight} px keeping " +
        s"${cfg.budget.perCell} (by line length: ${cfg.perCellSteps.map { case (w, k) => s"$k from $w px" }.mkString(", ")}); " +
        "inliers within 3 px; spread = share of 16 x 12 grid cells with a feature"
    )
    for (p <- pairs) {
      val r = measure(p, cfg, corners, hamming)
      val (o, d, s) = (r.ours, r.cvDefault, r.cvSingle)
      def pct(v: Double) = if (v.isNaN) "  -  " else f"${v * 100}%5.1f%%"
      println(s"${p.name}:")
      println(
        f"  ours             features ${o.keyFeatures}%5d / ${o.liveFeatures}%5d  spread ${pct(spread(o.keyPoints, p.key.width, p.key.height))} / " +
          f"${pct(spread(o.livePoints, p.live.width, p.live.height))}  matches ${o.matches.size}%5d  inliers ${o.inliers()}%5d (${pct(o.ratio())})"
      )
      println(
        f"  OpenCV default   features ${d.keyFeatures}%5d / ${d.liveFeatures}%5d  spread ${pct(spread(d.keyPoints, p.key.width, p.key.height))} / " +
          f"${pct(spread(d.livePoints, p.live.width, p.live.height))}  matches ${d.matches.size}%5d  inliers ${d.inliers()}%5d (${pct(d.ratio())})"
      )
      println(
        f"  OpenCV 1 level, our feature counts, ${s.matches.size} matches; the best ${r.common} of each: OpenCV ${pct(s.ratio(r.common))}, ours ${pct(o.ratio(r.common))}"
      )
    }
  }
}
