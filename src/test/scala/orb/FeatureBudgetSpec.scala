package orb

import orb.model._
import orb.testbench._
import org.scalatest.funsuite.AnyFunSuite
import spinal.core.sim._

/** The feature budget (RTL == model, and the rule itself): every selected corner gets its feature on any input, with
  * no blanking at all; deselection counted; the frame target met exactly on a still scene. */
class FeatureBudgetSpec extends AnyFunSuite {
  import TestSupport._

  /** RTL against the model over a run of frames: corners, feature stream, counters; no drop of any kind. The beats
    * are the frames' unless given (`frames` then names the images for the pictures and the summary). */
  def check(
      name: String,
      frames: Seq[GrayImage],
      p: CornerParams = cornerParams,
      blanking: Blanking = Blanking.none,
      stream: Seq[Beat] = Nil
  ): (CoreResult, RtlResult) = {
    val beats = if (stream.nonEmpty) stream else frames.flatMap(Beat.frame(_))
    val model = CoreModel.run(config, beats, p)
    var rtl: RtlResult = null
    core.doSim(name, seed.toInt) { dut => rtl = CoreSim.run(dut, beats, p, blanking, rng(name).nextLong()) }
    Scoreboard.compare(name, CoreEvents.of(model), rtl.events, frames.lastOption).foreach(msg => fail(msg))
    Scoreboard.compareFeatureStreams(name, model.featureStream, rtl.featureStream, frames.lastOption).foreach(msg =>
      fail(msg)
    )
    assert(
      rtl.deselected == model.deselected,
      s"$name: deselected corners (RTL ${rtl.deselected}, model ${model.deselected})"
    )
    assert(
      rtl.featureDrops == 0 && model.featureDrops == 0,
      s"$name: ${rtl.featureDrops} selected corners got no feature"
    )
    assert(rtl.features.size + rtl.deselected == rtl.corners.size, s"$name: every corner is a feature or deselected")
    val off = engineOffSchedule(rtl)
    assert(off.isEmpty, s"$name: the engine's clocks differ from its schedule: ${off.take(3).mkString("; ")}")
    println(
      f"[orb] $name%-30s ${frames.size} frames ${frames.head.width}x${frames.head.height}: ${rtl.corners.size} corners, " +
        s"${rtl.deselected} deselected, ${rtl.features.size} features (${model.budget.map(_._2.selected.size).mkString(", ")} per frame, " +
        s"${rtl.engineRuns.count(_.overlapped)} started behind the one before), ${rtl.cycles} clocks"
    )
    (model, rtl)
  }

  test("a still photograph: exactly the target from its second frame on, RTL == model") {
    val img = image("graf1.png").crop(0, 0, 800, 320)
    val (model, _) = check("budget-graf-target", Seq.fill(4)(img), cornerParams.copy(target = 300))
    val perFrame = model.budget.map(_._2.selected.size)
    assert(perFrame.size == 3 && perFrame.tail == Seq(300, 300), s"features per frame: $perFrame")
    assert(model.budget.head._1 == BudgetModel.noHistory && model.budget(1)._1.history)
  }

  test("targets 0, 1 and above the number of cell winners; corners of the narrowest frames") {
    val img = image("leuvenA.png").crop(100, 100, 400, 160)
    val (zero, _) = check("budget-target0", Seq.fill(3)(img), cornerParams.copy(target = 0))
    assert(zero.features.isEmpty && zero.deselected == zero.cornerCount && zero.cornerCount > 0)
    val (one, _) = check("budget-target1", Seq.fill(3)(img), cornerParams.copy(target = 1))
    assert(one.budget.map(_._2.selected.size) == Seq(1, 1))
    val (all, _) = check("budget-target-max", Seq.fill(3)(img), cornerParams.copy(target = BudgetConfig.targetMax))
    assert(all.budget.forall { case (_, s) => s.deselected == 0 || s.selected.size > 0 })
    // the narrowest frames with a corner column (x = 22) keep as many corners a cell as the engine serves there
    // (none when it cannot serve one: every corner deselected)
    val narrow = config.perCellSteps.head
    assert(narrow._1 == 2 * config.harris.border + 1)
    val noise = Patterns.noise(narrow._1 + 1, 120, rng("narrow"))
    val (n, _) = check("budget-narrow", Seq.fill(3)(noise), harrisOnly)
    assert(n.cornerCount > 0 && n.features.isEmpty == (narrow._2 == 0), s"${narrow._1}-px frames: ${narrow._2} a cell")
  }

  test("a frame end while the last frame's cut is being found (a fault right after it, no blanking): RTL == model") {
    // The fault's frame end comes a few clocks after the good frame's, while the frame end's walk of the histogram
    // looks for that frame's cut: the cut the next processed frame uses must still be the good frame's.
    val a = image("leuvenA.png").crop(100, 100, 400, 160)
    val b = image("graf1.png").crop(100, 100, 400, 160)
    val p = cornerParams.copy(target = 150)
    // the line after the good frame ends after 12 pixels: a line fault, the frame's end
    val faulty = Beat.frame(b).take(12).toVector
    val cutShort = faulty.updated(11, faulty(11).copy(eol = true))
    val beats = Seq(a, a, b).flatMap(Beat.frame(_)) ++ cutShort ++ Seq(a, a, a).flatMap(Beat.frame(_))
    val (model, rtl) = check("budget-walk-fault", Seq(a, a, b, b, a, a, a), p, stream = beats)
    assert(rtl.counters.badFrames == 1, "the cut-short frame is a bad one")
    // processed (after the first frame, which learns the geometry): a, b, the cut-short frame, then (after the
    // re-learning frame) a, a; the cut b's frame end finds is used by the cut-short frame and the next processed one
    val cuts = model.budget.map(_._1)
    assert(cuts.size == 5, s"processed frames: ${cuts.size}")
    assert(cuts(3) == cuts(2) && cuts(3) != cuts(1), s"the frame after re-learning uses b's cut, not a's: $cuts")
  }

  test("a flood of corners in every line length, no blanking: every selected corner gets its feature") {
    // 4-px checkerboard crossings with pure Harris maxima: a corner every 4 px in every 4th row; at the narrowest
    // line of every step of corners per cell (where the service bound is tightest), QVGA's and VGA's
    val widths = (config.perCellSteps.map(_._1) ++ Seq(320, 640)).distinct.sorted
    for (w <- widths) {
      val flood = Patterns.checkerboard(w, 96, 4)
      check(s"budget-flood-$w", Seq(flood, flood, flood), harrisOnly)
    }
  }

  test("dense real textures at full size, no blanking: baboon, starry_night") {
    for (name <- Seq("baboon.png", "starry_night.png")) {
      val img = image(name)
      val (model, _) = check(s"budget-$name", Seq.fill(3)(img))
      assert(model.deselected > model.features.size, s"$name: the budget deselects most corners of a dense texture")
      assert(
        model.budget.last._2.selected.size == config.budget.defaultTarget,
        s"$name: the target in its second frame"
      )
    }
  }
}
