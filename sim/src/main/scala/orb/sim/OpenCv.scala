package orb.sim

import orb.model.GrayImage
import org.bytedeco.javacpp.indexer.{DoubleIndexer, UByteIndexer}
import org.bytedeco.opencv.global.opencv_core._
import org.bytedeco.opencv.global.opencv_imgproc._
import org.bytedeco.opencv.opencv_core.{KeyPointVector, Mat, Point}
import org.bytedeco.opencv.opencv_features2d.FastFeatureDetector

/** Small bridges between our images and OpenCV matrices. */
object OpenCv {
  def toMat(img: GrayImage): Mat = {
    val m = new Mat(img.height, img.width, CV_8UC1)
    val idx = m.createIndexer[UByteIndexer]()
    for (y <- 0 until img.height; x <- 0 until img.width) idx.put(y.toLong, x.toLong, img(x, y))
    idx.release()
    m
  }

  def toGray(m: Mat): GrayImage = {
    require(m.depth() == CV_8U && m.channels() == 1)
    val idx = m.createIndexer[UByteIndexer]()
    val img = GrayImage(
      m.cols(),
      m.rows(),
      Array.tabulate(m.rows() * m.cols())(i => idx.get((i / m.cols()).toLong, (i % m.cols()).toLong))
    )
    idx.release()
    img
  }

  /** A CV_64F matrix as a row-major array. */
  def doubles(m: Mat): Array[Double] = {
    require(m.depth() == CV_64F && m.channels() == 1)
    val idx = m.createIndexer[DoubleIndexer]()
    val out = Array.tabulate(m.rows() * m.cols())(i => idx.get((i / m.cols()).toLong, (i % m.cols()).toLong))
    idx.release()
    out
  }

  def row(values: Seq[Double]): Mat = {
    val m = new Mat(1, values.size, CV_64F)
    val idx = m.createIndexer[DoubleIndexer]()
    values.zipWithIndex.foreach { case (v, i) => idx.put(0L, i.toLong, v) }
    idx.release()
    m
  }

  def sobel(src: Mat, dx: Int, dy: Int): Mat = {
    val d = new Mat(); Sobel(src, d, CV_64F, dx, dy, 3, 1.0, 0.0, BORDER_DEFAULT); d
  }
  def mul(a: Mat, b: Mat): Mat = { val d = new Mat(); multiply(a, b, d); d }

  /** Separable filter, same kernel both ways, not normalised. */
  def separable(src: Mat, kernel: Seq[Double]): Mat = {
    val d = new Mat(); val k = row(kernel)
    sepFilter2D(src, d, CV_64F, k, k, new Point(-1, -1), 0.0, BORDER_DEFAULT); d
  }

  /** OpenCV's FAST-9 corners at threshold t, with or without its suppression on the FAST score. */
  def fast(img: GrayImage, t: Int, suppress: Boolean): Seq[(Int, Int)] = {
    val kp = new KeyPointVector()
    FastFeatureDetector.create(t, suppress, FastFeatureDetector.TYPE_9_16).detect(toMat(img), kp)
    (0 until kp.size.toInt).map { i =>
      val p = kp.get(i.toLong).pt(); (math.round(p.x), math.round(p.y))
    }
  }

  /** OpenCV's own Harris (box window of `block` pixels); response in its own units. */
  def cornerHarrisMap(src: Mat, block: Int, k: Double): Array[Double] = {
    val d = new Mat(); cornerHarris(src, d, block, 3, k, BORDER_DEFAULT)
    val d64 = new Mat(); d.convertTo(d64, CV_64F)
    doubles(d64)
  }
}
