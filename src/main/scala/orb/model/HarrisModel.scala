package orb.model

import orb.{CornerParams, HarrisConfig, SegmentTestConfig}

/** A corner as the hardware emits it. */
final case class Corner(x: Int, y: Int, score: Long)

/** Bit-exact model of `orb.HarrisDetector`, one function per hardware stage. Maps are full-image arrays;
  * entries whose filter support leaves the image are 0 and never reach a corner (see `HarrisConfig.border`). */
object HarrisModel {
  final class Plane[T](val width: Int, val height: Int, val data: Array[T]) {
    def apply(x: Int, y: Int): T = data(y * width + x)
  }
  private def plane(w: Int, h: Int)(f: (Int, Int) => Long): Plane[Long] =
    new Plane(w, h, Array.tabulate(w * h)(i => f(i % w, i / w)))
  private def inside(w: Int, h: Int, x: Int, y: Int, r: Int) = x >= r && y >= r && x < w - r && y < h - r

  /** v / 2^n rounded half up (add half, then floor). */
  def roundShift(v: Long, n: Int): Long = if (n == 0) v else (v + (1L << (n - 1))) >> n

  /** OpenCV's 3x3 Sobel: gx = right - left, gy = bottom - top, rows/columns weighted 1 2 1. */
  def sobel(img: GrayImage): (Plane[Long], Plane[Long]) = {
    val (w, h) = (img.width, img.height)
    def gx(x: Int, y: Int) = (-1 to 1).map(d => (2 - d.abs) * (img(x + 1, y + d) - img(x - 1, y + d))).sum
    def gy(x: Int, y: Int) = (-1 to 1).map(d => (2 - d.abs) * (img(x + d, y + 1) - img(x + d, y - 1))).sum
    (
      plane(w, h)((x, y) => if (inside(w, h, x, y, 1)) gx(x, y) else 0),
      plane(w, h)((x, y) => if (inside(w, h, x, y, 1)) gy(x, y) else 0)
    )
  }

  /** gx^2, gy^2, gx*gy, exact. */
  def products(gx: Plane[Long], gy: Plane[Long]): (Plane[Long], Plane[Long], Plane[Long]) = {
    val (w, h) = (gx.width, gx.height)
    (
      plane(w, h)((x, y) => gx(x, y) * gx(x, y)),
      plane(w, h)((x, y) => gy(x, y) * gy(x, y)),
      plane(w, h)((x, y) => gx(x, y) * gy(x, y))
    )
  }

  /** 7x7 binomial window: exact column sums, exact row sums of those, then `>> windowShift` rounded half up. */
  def window(p: Plane[Long], cfg: HarrisConfig): Plane[Long] = {
    val (w, h) = (p.width, p.height)
    val wts = HarrisConfig.binomial
    val column =
      plane(w, h)((x, y) => if (y >= 3 && y < h - 3) wts.indices.map(i => wts(i) * p(x, y + i - 3)).sum else 0)
    plane(w, h) { (x, y) =>
      if (inside(w, h, x, y, 4)) roundShift(wts.indices.map(i => wts(i) * column(x + i - 3, y)).sum, cfg.windowShift)
      else 0
    }
  }

  /** R = det - ((kNum * tr^2) >> kShift). */
  def response(sxx: Plane[Long], syy: Plane[Long], sxy: Plane[Long], cfg: HarrisConfig): Plane[Long] =
    plane(sxx.width, sxx.height) { (x, y) =>
      val det = sxx(x, y) * syy(x, y) - sxy(x, y) * sxy(x, y)
      val tr = sxx(x, y) + syy(x, y)
      det - ((tr * tr * cfg.kNum) >> cfg.kShift)
    }

  /** score = max(0, R >> scoreShift): what the suppression stage stores and compares. */
  def score(r: Plane[Long], cfg: HarrisConfig): Plane[Long] =
    plane(r.width, r.height)((x, y) => (r(x, y) >> cfg.scoreShift) max 0L)

  /** Harris response map (R, before the score shift). */
  def responseMap(img: GrayImage, cfg: HarrisConfig): Plane[Long] = {
    val (gx, gy) = sobel(img)
    val (xx, yy, xy) = products(gx, gy)
    response(window(xx, cfg), window(yy, cfg), window(xy, cfg), cfg)
  }

  /** OpenCV's FAST segment test at every pixel at least 3 from the edges (false elsewhere): `arc` contiguous circle
    * pixels all > centre + t, or all < centre - t. */
  def segmentTest(img: GrayImage, t: Int, arc: Int): Plane[Boolean] = {
    val (w, h) = (img.width, img.height)
    val ring = SegmentTestConfig.circle
    def run(hit: IndexedSeq[Boolean]) = ring.indices.exists(s => (0 until arc).forall(k => hit((s + k) % ring.size)))
    new Plane(
      w,
      h,
      Array.tabulate(w * h) { i =>
        val (x, y) = (i % w, i / w)
        inside(w, h, x, y, SegmentTestConfig.radius) && {
          val c = img(x, y); val p = ring.map { case (dx, dy) => img(x + dx, y + dy) }.toIndexedSeq
          run(p.map(_ > c + t)) || run(p.map(_ < c - t))
        }
      }
    )
  }

  /** The scores the suppression sees: a pixel that fails the segment test scores 0 (it can neither be a corner nor
    * suppress a neighbour). */
  def candidateScores(s: Plane[Long], passes: Option[Plane[Boolean]]): Plane[Long] = passes.fold(s) { m =>
    new Plane(s.width, s.height, Array.tabulate(s.data.length)(i => if (m.data(i)) s.data(i) else 0L))
  }

  /** A pixel is a corner when its score exceeds the threshold, it lies `border` or more from every edge, and it
    * wins the 3x3 suppression: strictly greater than the 4 neighbours before it in raster order (left and the
    * row above), greater or equal to the 4 after it. A plateau of equal scores thus keeps exactly its first pixel
    * in raster order; a pure "strictly greater than all 8" rule would erase such a corner altogether. */
  def suppress(s: Plane[Long], threshold: Long, border: Int): Seq[Corner] = {
    val (w, h) = (s.width, s.height)
    val earlier = Seq((-1, -1), (0, -1), (1, -1), (-1, 0))
    val later = Seq((1, 0), (-1, 1), (0, 1), (1, 1))
    for {
      y <- border until h - border
      x <- border until w - border
      c = s(x, y)
      if c > threshold
      if earlier.forall { case (dx, dy) => c > s(x + dx, y + dy) }
      if later.forall { case (dx, dy) => c >= s(x + dx, y + dy) }
    } yield Corner(x, y, c)
  }

  def corners(img: GrayImage, cfg: HarrisConfig, p: CornerParams): Seq[Corner] = {
    require(p.segmentThreshold.isEmpty || cfg.segment.isDefined, "this configuration has no segment test")
    val passes = for (t <- p.segmentThreshold; seg <- cfg.segment) yield segmentTest(img, t, seg.arc)
    suppress(candidateScores(score(responseMap(img, cfg), cfg), passes), p.threshold, cfg.border)
  }
}
