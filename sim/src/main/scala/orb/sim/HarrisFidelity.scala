package orb.sim

import orb.{CornerParams, HarrisConfig, OrbConfig}
import orb.model._

/** How closely the fixed-point Harris model follows the same definition computed in floating point with OpenCV
  * (Sobel, sepFilter2D with the binomial kernel, det - k tr^2 in doubles), and how its corners compare with
  * OpenCV's cornerHarris (box window). */
object HarrisFidelity {
  final case class Figures(
      image: String,
      width: Int,
      height: Int,
      corners: Int,
      floatCorners: Int,
      correlation: Double,
      strongPixels: Int,
      maxRelErrStrong: Double,
      /** model corners with a float-reference corner within 1 px */
      matchedWithin1: Double,
      /** float corners with a model corner within 1 px */
      recallWithin1: Double,
      /** model corners with a cornerHarris corner (same count, strongest first) within 1 / 2 px */
      cornerHarrisWithin1: Double,
      cornerHarrisWithin2: Double
  )

  /** The float reference response R (same units as the model's R: window sums divided by 2^windowShift). */
  def floatResponse(img: GrayImage, cfg: HarrisConfig): Array[Double] = {
    val src = OpenCv.toMat(img)
    val gx = OpenCv.sobel(src, 1, 0); val gy = OpenCv.sobel(src, 0, 1)
    val kernel = HarrisConfig.binomial.map(_.toDouble)
    val scale = math.pow(2, cfg.windowShift)
    val sxx = OpenCv.doubles(OpenCv.separable(OpenCv.mul(gx, gx), kernel)).map(_ / scale)
    val syy = OpenCv.doubles(OpenCv.separable(OpenCv.mul(gy, gy), kernel)).map(_ / scale)
    val sxy = OpenCv.doubles(OpenCv.separable(OpenCv.mul(gx, gy), kernel)).map(_ / scale)
    Array.tabulate(sxx.length) { i =>
      val tr = sxx(i) + syy(i)
      sxx(i) * syy(i) - sxy(i) * sxy(i) - cfg.k * tr * tr
    }
  }

  /** Same suppression rule as the hardware, on a real-valued map. */
  def suppress(w: Int, h: Int, s: Array[Double], threshold: Double, border: Int): Seq[(Int, Int)] = {
    val earlier = Seq((-1, -1), (0, -1), (1, -1), (-1, 0)); val later = Seq((1, 0), (-1, 1), (0, 1), (1, 1))
    for {
      y <- border until h - border; x <- border until w - border
      c = s(y * w + x) if c > threshold
      if earlier.forall { case (dx, dy) => c > s((y + dy) * w + x + dx) }
      if later.forall { case (dx, dy) => c >= s((y + dy) * w + x + dx) }
    } yield (x, y)
  }

  private def within(p: (Int, Int), set: Set[(Int, Int)], r: Int): Boolean =
    (-r to r).exists(dy => (-r to r).exists(dx => set.contains((p._1 + dx, p._2 + dy))))

  def measure(name: String, img: GrayImage, cfg: OrbConfig, threshold: Long): Figures = {
    val h = cfg.harris
    val (w, ht) = (img.width, img.height)
    val model = HarrisModel.responseMap(img, h)
    val ref = floatResponse(img, h)
    val inner = for (y <- h.border until ht - h.border; x <- h.border until w - h.border) yield y * w + x
    val (mx, rx) = (inner.map(i => model.data(i).toDouble), inner.map(ref))
    val correlation = pearson(mx, rx)
    // "Strong": a float response above the corner threshold (in R units, before the score shift).
    val strongLevel = threshold.toDouble * (1L << h.scoreShift)
    val strong = inner.filter(i => ref(i) > strongLevel)
    val maxRel = if (strong.isEmpty) 0.0 else strong.map(i => math.abs(model.data(i) - ref(i)) / ref(i)).max

    val corners =
      HarrisModel.corners(img, h, CornerParams(threshold, None)).map(c =>
        (c.x, c.y)
      ) // Harris maxima: what cornerHarris gives
    val floatScore = ref.map(r => math.max(0.0, r / (1L << h.scoreShift)))
    val floatCorners = suppress(w, ht, floatScore, threshold.toDouble, h.border)
    val fset = floatCorners.toSet; val mset = corners.toSet
    val matched = frac(corners.count(within(_, fset, 1)), corners.size)
    val recall = frac(floatCorners.count(within(_, mset, 1)), floatCorners.size)

    // cornerHarris with a 7x7 box window: its units differ, so compare the same number of strongest maxima.
    val box = OpenCv.cornerHarrisMap(OpenCv.toMat(img), 7, h.k)
    val boxCorners =
      suppress(w, ht, box, 0.0, h.border).sortBy { case (x, y) => -box(y * w + x) }.take(corners.size).toSet
    Figures(
      name,
      w,
      ht,
      corners.size,
      floatCorners.size,
      correlation,
      strong.size,
      maxRel,
      matched,
      recall,
      frac(corners.count(within(_, boxCorners, 1)), corners.size),
      frac(corners.count(within(_, boxCorners, 2)), corners.size)
    )
  }

  private def frac(a: Int, b: Int): Double = if (b == 0) 1.0 else a.toDouble / b
  private def pearson(a: Seq[Double], b: Seq[Double]): Double = {
    val n = a.size; val ma = a.sum / n; val mb = b.sum / n
    var sab, saa, sbb = 0.0
    for (i <- 0 until n) { val da = a(i) - ma; val db = b(i) - mb; sab += da * db; saa += da * da; sbb += db * db }
    sab / math.sqrt(saa * sbb)
  }

  def header: String =
    f"${"image"}%-18s ${"size"}%9s ${"corners"}%7s ${"float"}%6s ${"corr"}%9s ${"strong px"}%9s ${"max rel err"}%11s ${"<=1px"}%7s ${"recall"}%7s ${"cH<=1px"}%7s ${"cH<=2px"}%7s"
  def row(f: Figures): String =
    f"${f.image}%-18s ${s"${f.width}x${f.height}"}%9s ${f.corners}%7d ${f.floatCorners}%6d ${f.correlation}%9.7f ${f.strongPixels}%9d ${f.maxRelErrStrong * 100}%10.3f%% ${f.matchedWithin1 * 100}%6.1f%% ${f.recallWithin1 * 100}%6.1f%% ${f.cornerHarrisWithin1 * 100}%6.1f%% ${f.cornerHarrisWithin2 * 100}%6.1f%%"

  val usage = "usage: orb.sim.HarrisFidelity [--threshold T] [IMAGE ...]   (default: every PNG in data/)"

  def main(args: Array[String]): Unit = {
    val cfg = OrbConfig.default
    Cli.main("orb.sim.HarrisFidelity", usage, args.toSeq) {
      val o = Cli.fidelity(args.toSeq, cfg.harris.defaultThreshold, cfg.descriptor.angleBins, withBins = false)
      println(
        s"Harris model vs float reference (OpenCV Sobel + sepFilter2D, doubles), threshold ${o.threshold}, border ${cfg.harris.border}"
      )
      println(header)
      for (f <- o.images) println(row(measure(new java.io.File(f).getName, Cli.load(f), cfg, o.threshold)))
    }
  }
}
