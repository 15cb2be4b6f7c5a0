package orb

import orb.model._
import org.scalatest.funsuite.AnyFunSuite

/** The feature budget's rule in the model (`BudgetModel`), and the configuration's service bound. */
class BudgetModelSpec extends AnyFunSuite {
  import TestSupport._
  val b: BudgetConfig = config.budget

  test("score levels: each octave of the score in four equal parts") {
    assert(BudgetModel.level(0, b) == 0 && BudgetModel.level(1, b) == 0)
    assert(BudgetModel.level(256, b) == 32 && BudgetModel.level(256 + 63, b) == 32 && BudgetModel.level(
      256 + 64,
      b
    ) == 33)
    assert(BudgetModel.level(511, b) == 35 && BudgetModel.level(512, b) == 36)
    val top = (1L << config.harris.scoreWidth) - 1
    assert(BudgetModel.level(top, b) == b.levels(config.harris.scoreWidth) - 1)
    val r = rng("levels")
    for (_ <- 0 until 1000) {
      val s = 1 + (r.nextLong() & 0x3ffffffL)
      val e = 63 - java.lang.Long.numberOfLeadingZeros(s)
      assert(BudgetModel.level(s, b) == 4 * e + math.floor(4 * (s.toDouble / (1L << e) - 1)).toInt, s"score $s")
      assert(BudgetModel.level(s + 1, b) >= BudgetModel.level(s, b), "levels grow with the score")
      assert(BudgetModel.rank(s, b) == 16 * e + math.floor(16 * (s.toDouble / (1L << e) - 1)).toInt, s"score $s")
    }
  }

  test("cells keep their k highest ranked, the first in raster order on ties") {
    val cs =
      Seq(Corner(10, 1, 5), Corner(20, 1, 9), Corner(30, 2, 5), Corner(40, 3, 7), Corner(300, 0, 1), Corner(12, 4, 3))
    assert(BudgetModel.cellWinners(cs, 2, b) == Seq(
      Corner(20, 1, 9),
      Corner(40, 3, 7),
      Corner(300, 0, 1),
      Corner(12, 4, 3)
    ))
    assert(BudgetModel.cellWinners(cs, 3, b) == Seq(
      Corner(10, 1, 5),
      Corner(20, 1, 9),
      Corner(40, 3, 7),
      Corner(300, 0, 1),
      Corner(12, 4, 3)
    ))
    assert(BudgetModel.cellWinners(cs, 0, b).isEmpty)
    // ranked in sixteenths of an octave: 1000 and 1010 share one (both in 31/16 of 2^9), so the first one stays
    val close = Seq(Corner(10, 1, 1000), Corner(20, 1, 1010), Corner(30, 1, 900))
    assert(BudgetModel.rank(1000, b) == BudgetModel.rank(1010, b) && BudgetModel.rank(900, b) < BudgetModel.rank(
      1000,
      b
    ))
    assert(BudgetModel.cellWinners(close, 1, b) == Seq(Corner(10, 1, 1000)))
    assert(BudgetModel.cellWinners(close, 2, b) == Seq(Corner(10, 1, 1000), Corner(20, 1, 1010)))
  }

  test("the cut gives exactly the target on the frame it was learnt from, for any histogram") {
    val r = rng("cut")
    for (_ <- 0 until 300) {
      val scores = Seq.fill(r.nextInt(400))(1L + r.nextInt(1 << (1 + r.nextInt(20))))
      val winners = scores.zipWithIndex.map { case (s, i) => Corner(i % 700, i / 700, s) }
      val target = r.nextInt(450)
      val first = BudgetModel.select(winners, BudgetModel.noHistory, target, b, config.harris.scoreWidth)
      assert(first.selected == winners.take(target), "no history: the first `target` in raster order")
      val cut = BudgetModel.nextCut(first.histogram, target)
      val again = BudgetModel.select(winners, cut, target, b, config.harris.scoreWidth)
      assert(again.selected.size == (target min winners.size))
      // strongest first: every selected winner's level is at least every deselected one's
      val lv = (c: Corner) => BudgetModel.level(c.score, b)
      val out = winners.diff(again.selected)
      if (again.selected.nonEmpty && out.nonEmpty) assert(again.selected.map(lv).min >= out.map(lv).max)
    }
  }

  test("the service bound holds for every line length of the default configuration, and fails where it should") {
    val steps = config.perCellSteps
    // full density from lines of two cells on (the engine serves 8 corners a band only from about 310 px: 3 a cell
    // just above one cell's width, see sim/docs/feature-budget.md)
    assert(steps.last == (steps.last._1, b.perCell) && steps.last._1 <= 2 * config.harris.border + 2 * b.cellWidth)
    for (w <- steps.last._1 to config.maxWidth) assert(config.budgetService(w, b.perCell).isEmpty, s"W = $w")
    // what the bound guards against: more corners per cell than the engines can serve in 1024-px lines
    assert(config.budgetService(config.maxWidth, 4 * b.perCell).isDefined)
    val tooDense = intercept[IllegalArgumentException](config.copy(budget = b.copy(cellWidth = 64)))
    assert(tooDense.getMessage.contains("cannot serve"))
  }

  test("features per frame on every photograph in data/: min(target, cell winners) from the second processed frame") {
    val photos =
      new java.io.File("data").listFiles().map(_.getName).filter(n => n.endsWith(".png") && !n.contains("disp")).sorted
    val lines = for (name <- photos.toSeq) yield {
      val img = image(name)
      val core = CoreModel.run(config, Seq.fill(3)(Beat.frame(img)).flatten, cornerParams)
      val (_, second) = core.budget.last
      val cellWinners = BudgetModel.cellWinners(
        HarrisModel.corners(img, config.harris, cornerParams),
        config.perCellFor(img.width),
        b
      ).size
      assert(
        second.selected.size == (b.defaultTarget min cellWinners),
        s"$name: ${second.selected.size} features, $cellWinners winners"
      )
      f"$name ${img.width}x${img.height}: ${core.cornerCount / 2} corners, $cellWinners winners, ${second.selected.size} features"
    }
    println(lines.mkString("[orb] budget: ", "\n[orb] budget: ", ""))
  }

  test("video: the next frame, with the cut of the one before, stays near the target") {
    for ((a, c) <- Seq("basketball1.png" -> "basketball2.png", "rubberwhale1.png" -> "rubberwhale2.png")) {
      val (f1, f2) = (image(a), image(c))
      val core = CoreModel.run(config, (Beat.frame(f1) ++ Beat.frame(f1) ++ Beat.frame(f2)), cornerParams)
      val n = core.budget.last._2.selected.size
      val winners = BudgetModel.cellWinners(
        HarrisModel.corners(f2, config.harris, cornerParams),
        config.perCellFor(f2.width),
        b
      ).size
      println(s"[orb] budget: $c after $a's cut: $n features ($winners winners)")
      assert(n <= b.defaultTarget && n >= 0.9 * (b.defaultTarget min winners), s"$c: $n features")
    }
  }
}
