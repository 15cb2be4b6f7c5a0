package orb

import orb.model._
import org.scalatest.funsuite.AnyFunSuite

/** The golden model's stages against hand-computed values (no simulator involved). */
class HarrisModelSpec extends AnyFunSuite {
  val cfg: HarrisConfig = HarrisConfig()

  test("Sobel: OpenCV's kernel, gx = right - left, gy = bottom - top") {
    val ramp = GrayImage.tabulate(12, 10)((x, y) => 3 * x + 5 * y)
    val (gx, gy) = HarrisModel.sobel(ramp)
    for (y <- 1 until 9; x <- 1 until 11) { assert(gx(x, y) == 4 * 2 * 3); assert(gy(x, y) == 4 * 2 * 5) }
    assert(gx(0, 4) == 0 && gy(5, 0) == 0, "no gradient where the kernel leaves the image")
  }

  test("window: binomial weights summing to 4096, then a rounded shift") {
    def const(v: Long) = new HarrisModel.Plane[Long](20, 20, Array.fill(400)(v))
    // 4 * 4096 = 2^14 is exactly half a unit after >> 15: rounds up to 1; 3 * 4096 rounds down to 0.
    assert(HarrisModel.window(const(4), cfg)(10, 10) == 1)
    assert(HarrisModel.window(const(3), cfg)(10, 10) == 0)
    assert(HarrisModel.window(const(1000), cfg)(10, 10) == 125)
    val impulse = new HarrisModel.Plane[Long](20, 20, Array.tabulate(400)(i => if (i == 10 * 20 + 10) 1L << 15 else 0L))
    assert(HarrisModel.window(impulse, cfg)(10, 10) == 400, "centre weight 20 * 20")
    assert(HarrisModel.window(impulse, cfg)(13, 10) == 20, "edge weight 1 * 20")
  }

  test("response: det - ((41 * tr^2) >> 10)") {
    def p(v: Long) = new HarrisModel.Plane[Long](1, 1, Array(v))
    assert(HarrisModel.response(p(100), p(80), p(10), cfg)(0, 0) == 100 * 80 - 100 - ((180L * 180 * 41) >> 10))
    assert(HarrisModel.score(p(-5), cfg)(0, 0) == 0)
    assert(cfg.scoreShift == 7)
    assert(HarrisModel.score(p(1027 * 32 + 31), cfg)(0, 0) == 256) // (32895 >> 7) = 256, the floor
  }

  test("suppression: a plateau keeps its first pixel in raster order, and only that") {
    val s = Array.fill(30 * 30)(0L)
    def set(x: Int, y: Int, v: Long) = s(y * 30 + x) = v
    set(12, 12, 50); set(13, 12, 50); set(12, 13, 50); set(13, 13, 50) // 2x2 plateau
    set(20, 20, 70); set(19, 21, 70) // anti-diagonal tie
    set(8, 20, 40); set(9, 20, 41) // a stronger neighbour wins
    val corners = HarrisModel.suppress(new HarrisModel.Plane(30, 30, s), threshold = 10, border = 5)
    assert(corners == Seq(Corner(12, 12, 50), Corner(9, 20, 41), Corner(20, 20, 70)))
    assert(
      HarrisModel.suppress(new HarrisModel.Plane(30, 30, s), threshold = 50, border = 5) == Seq(Corner(20, 20, 70)),
      "the threshold is strict"
    )
    assert(
      HarrisModel.suppress(new HarrisModel.Plane(30, 30, s), threshold = 10, border = 13).isEmpty,
      "nothing closer than the border"
    )
  }

  test("an ideal corner is found where it is, and its score grows with the 4th power of the contrast") {
    def corner(c: Int) = GrayImage.tabulate(64, 64)((x, y) => if (x >= 32 && y >= 32) c else 0)
    for (p <- Seq(CornerParams(0, None), cfg.params(0))) {
      val strong = HarrisModel.corners(corner(64), cfg, p)
      assert(strong.size == 1 && (strong.head.x - 32).abs <= 1 && (strong.head.y - 32).abs <= 1, s"$p: $strong")
      val weak = HarrisModel.corners(corner(32), cfg, p).head.score
      assert(strong.head.score.toDouble / weak > 14 && strong.head.score.toDouble / weak < 18)
    }
  }

  test("segment test: 9 contiguous circle pixels strictly beyond centre +- t, around the wrap of the circle") {
    val ring = SegmentTestConfig.circle

    /** A 9x9 image with centre 100 and circle pixel i set to level(i). */
    def probe(level: Int => Int): GrayImage = {
      val px = Array.fill(81)(100)
      ring.zipWithIndex.foreach { case ((dx, dy), i) => px((4 + dy) * 9 + 4 + dx) = level(i) }
      GrayImage(9, 9, px)
    }
    def passes(img: GrayImage, t: Int, arc: Int = 9) = HarrisModel.segmentTest(img, t, arc)(4, 4)
    for (start <- Seq(0, 5, 12)) { // 12: the arc wraps from pixel 15 to pixel 0
      def arc(n: Int, v: Int) = probe(i => if ((i - start + 16) % 16 < n) v else 100)
      assert(passes(arc(9, 121), 20) && passes(arc(9, 79), 20), s"start $start: 9 brighter / darker pass")
      assert(!passes(arc(8, 121), 20) && !passes(arc(8, 79), 20), s"start $start: 8 do not")
      assert(!passes(arc(9, 120), 20) && !passes(arc(9, 80), 20), s"start $start: exactly centre +- t is not beyond it")
      assert(passes(arc(12, 200), 20, arc = 12) && !passes(arc(11, 200), 20, arc = 12), "FAST-12")
    }
    assert(!passes(probe(i => if (i % 2 == 0) 200 else 0), 20), "alternating pixels: no arc")
    assert(!passes(probe(_ => 255), 255) && !passes(probe(_ => 0), 255), "t = 255: nothing is beyond")
    assert(!HarrisModel.segmentTest(probe(_ => 200), 20, 9)(3, 4), "no test within 3 px of an edge")
  }

  test("a pixel that fails the segment test scores 0: it is no corner and suppresses no neighbour") {
    val s = Array.fill(30 * 30)(0L); s(20 * 30 + 20) = 90; s(20 * 30 + 21) = 70
    val all = new HarrisModel.Plane(30, 30, Array.fill(900)(true))
    val masked = new HarrisModel.Plane(30, 30, Array.tabulate(900)(_ != 20 * 30 + 20))
    val plane = new HarrisModel.Plane(30, 30, s)
    assert(HarrisModel.suppress(HarrisModel.candidateScores(plane, Some(all)), 10, 5) == Seq(Corner(20, 20, 90)))
    assert(HarrisModel.suppress(HarrisModel.candidateScores(plane, Some(masked)), 10, 5) == Seq(Corner(21, 20, 70)))
  }

  test("frame tracker: geometry from the first frame, processing from the second") {
    val img = GrayImage.tabulate(20, 6)((x, y) => x + y)
    val t = new FrameTrackerModel(FrameConfig())
    val first = Beat.frame(img).flatMap(t.step)
    assert(first.size == 120 && first.forall(!_.active))
    val second = Beat.frame(img).flatMap(t.step)
    assert(second.forall(_.active) && second.map(b => (b.x, b.y)) == (for (y <- 0 until 6; x <- 0 until 20)
      yield (x, y)))
    assert(second.count(_.end.isDefined) == 1 && second.last.end.exists(_.ok))
    assert(t.stats == FrameCounters(frames = 2))
  }
}
