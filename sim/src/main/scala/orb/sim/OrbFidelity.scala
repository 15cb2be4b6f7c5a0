package orb.sim

import orb.{OrbConfig, OrbDescriptorConfig}
import orb.model._
import org.bytedeco.javacpp.indexer.UByteIndexer
import org.bytedeco.opencv.global.opencv_core._
import org.bytedeco.opencv.global.opencv_imgproc._
import org.bytedeco.opencv.opencv_core.{KeyPoint, KeyPointVector, Mat, Rect, Size}
import org.bytedeco.opencv.opencv_features2d.ORB

/** How close the integer ORB model comes to OpenCV's ORB (single scale) on the model's own Harris corners. */
object OrbFidelity {
  final case class Figures(
      image: String,
      corners: Int,
      compared: Int,
      blurExact: Double,
      blurWithin1: Double,
      /** OpenCV compute() given our corners and our quantised angle */
      hammingEngine: Double,
      /** OpenCV's own angle (IC_Angle) and descriptor at our corners */
      hammingEndToEnd: Double,
      /** |our bin angle - OpenCV's angle| <= half a bin */
      angleWithinHalfBin: Double,
      maxAngleErrDeg: Double
  )

  /** OpenCV's blur exactly as ORB applies it: in place on the image inside a reflect-101 padded copy. */
  def openCvOrbBlur(img: GrayImage, border: Int): GrayImage = {
    val padded = new Mat()
    copyMakeBorder(OpenCv.toMat(img), padded, border, border, border, border, BORDER_REFLECT_101)
    val roi = new Mat(padded, new Rect(border, border, img.width, img.height))
    GaussianBlur(roi, roi, new Size(7, 7), 2.0, 2.0, BORDER_REFLECT_101, ALGO_HINT_DEFAULT)
    OpenCv.toGray(roi)
  }

  /** OpenCV ORB descriptors at the given points and angles (degrees); None where OpenCV dropped the point. */
  def openCvDescriptors(img: GrayImage, points: Seq[(Int, Int, Float)], edge: Int): Seq[Option[Vector[Int]]] = {
    val orb = ORB.create(points.size max 1, 1.2f, 1, edge, 0, 2, ORB.HARRIS_SCORE, 31, 20)
    val kps =
      new KeyPointVector(points.map { case (x, y, a) => new KeyPoint(x.toFloat, y.toFloat, 31f, a, 0f, 0, -1) }: _*)
    val desc = new Mat()
    orb.compute(OpenCv.toMat(img), kps, desc)
    val idx = if (desc.rows() > 0) desc.createIndexer[UByteIndexer]() else null
    val byPoint = (0 until kps.size().toInt).map { i =>
      val k = kps.get(i.toLong)
      (math.round(k.pt().x()), math.round(k.pt().y())) -> Vector.tabulate(32)(b => idx.get(i.toLong, b.toLong))
    }.toMap
    points.map { case (x, y, _) => byPoint.get((x, y)) }
  }

  def hamming(a: Vector[Int], b: Vector[Int]): Int = a.zip(b).map { case (p, q) => Integer.bitCount(p ^ q) }.sum

  def measure(name: String, img: GrayImage, cfg: OrbConfig, threshold: Long): Figures = {
    val d = cfg.descriptor
    val border = cfg.harris.border
    val corners = HarrisModel.corners(img, cfg.harris, cfg.harris.params(threshold))
    val ours = OrbModel.features(img, corners, d)

    val cvBlur = openCvOrbBlur(img, 32)
    val mine = OrbModel.smooth(img)
    val px = for (y <- 3 until img.height - 3; x <- 3 until img.width - 3) yield (mine(x, y) - cvBlur(x, y)).abs
    val blurExact = px.count(_ == 0).toDouble / px.size; val blurWithin1 = px.count(_ <= 1).toDouble / px.size

    val engine = openCvDescriptors(img, ours.map(f => (f.x, f.y, OrbModel.binDegrees(f.bin, d).toFloat)), border)
    val cvAngles = corners.map { c =>
      val (m10, m01) = OrbModel.moments(img, c.x, c.y); fastAtan2(m01.toFloat, m10.toFloat)
    }
    val endToEnd = openCvDescriptors(img, corners.zip(cvAngles).map { case (c, a) => (c.x, c.y, a) }, border)
    val pairs = ours.indices.filter(i => engine(i).isDefined && endToEnd(i).isDefined)
    def mean(xs: Seq[Int]) = if (xs.isEmpty) 0.0 else xs.sum.toDouble / xs.size
    val errs = ours.zip(cvAngles).map { case (f, a) =>
      val e = (OrbModel.binDegrees(f.bin, d) - a) % 360.0; math.min(e.abs, 360 - e.abs)
    }
    Figures(
      name,
      corners.size,
      pairs.size,
      blurExact,
      blurWithin1,
      mean(pairs.map(i => hamming(ours(i).descriptor, engine(i).get))),
      mean(pairs.map(i => hamming(ours(i).descriptor, endToEnd(i).get))),
      if (errs.isEmpty) 1.0 else errs.count(_ <= d.binDegrees / 2 + 1e-9).toDouble / errs.size,
      if (errs.isEmpty) 0.0 else errs.max
    )
  }

  def header: String =
    f"${"image"}%-18s ${"bins"}%5s ${"corners"}%7s ${"compared"}%8s ${"blur =="}%8s ${"blur +-1"}%8s ${"engine"}%7s ${"end2end"}%7s ${"angle<=half"}%11s ${"max err"}%8s"
  def row(f: Figures, bins: Int): String =
    f"${f.image}%-18s $bins%5d ${f.corners}%7d ${f.compared}%8d ${f.blurExact * 100}%7.2f%% ${f.blurWithin1 * 100}%7.2f%% ${f.hammingEngine}%7.3f ${f.hammingEndToEnd}%7.3f ${f.angleWithinHalfBin * 100}%10.2f%% ${f.maxAngleErrDeg}%7.3f°"

  val usage = "usage: orb.sim.OrbFidelity [--threshold T] [--bins N[,N...]] [IMAGE ...]   (default: every PNG in data/)"

  def main(args: Array[String]): Unit = {
    val base = OrbConfig.default
    Cli.main("orb.sim.OrbFidelity", usage, args.toSeq) {
      val o = Cli.fidelity(args.toSeq, base.harris.defaultThreshold, base.descriptor.angleBins, withBins = true)
      println(s"ORB model vs OpenCV ORB (nlevels 1) at the model's Harris corners, threshold ${o.threshold}")
      println("engine: OpenCV given our angle; end2end: OpenCV's own angle; Hamming bits of 256, mean")
      println(header)
      for (f <- o.images; n <- o.bins) {
        val cfg = base.copy(descriptor = OrbDescriptorConfig(angleBins = n))
        println(row(measure(new java.io.File(f).getName, Cli.load(f), cfg, o.threshold), n))
      }
    }
  }
}
