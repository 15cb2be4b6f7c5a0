package orb

import orb.model._
import orb.testbench._
import org.scalatest.funsuite.AnyFunSuite
import spinal.core.sim._

/** Malformed camera streams: every fault is counted, the faulty frame emits only corners computed from its good
  * part (each one a corner of the clean image, with the same score), and the core resynchronises: the frame after
  * the re-learning frame gives exactly the clean result. RTL and model agree on all of it. */
class StreamFaultSpec extends AnyFunSuite {
  import TestSupport._

  val a: GrayImage = Patterns.boxes(96, 80, rng("fault-a"), n = 16)
  val w: Int = a.width
  lazy val clean: Seq[Corner] = HarrisModel.corners(a, config.harris, cornerParams)

  def lineStart(line: Int) = line * w

  /** The frame of `a` with its `line` cut to `len` pixels. */
  def shortLine(line: Int, len: Int): Seq[Beat] = {
    val f = Beat.frame(a).toVector
    f.take(lineStart(line) + len - 1) ++ Seq(f(lineStart(line) + len - 1).copy(eol = true)) ++ f.drop(
      lineStart(line + 1)
    )
  }

  /** The frame of `a` with `extra` more pixels before the end of `line`. */
  def longLine(line: Int, extra: Int): Seq[Beat] = {
    val f = Beat.frame(a).toVector
    f.take(lineStart(line) + w - 1) ++ Seq.fill(extra)(Beat(77, sof = false, eol = false)) ++ f.drop(
      lineStart(line) + w - 1
    )
  }
  def missingEol(line: Int): Seq[Beat] = {
    val f = Beat.frame(a).toVector
    f.updated(lineStart(line) + w - 1, f(lineStart(line) + w - 1).copy(eol = false))
  }
  def lines(n: Int): Seq[Beat] = Beat.frame(GrayImage.tabulate(w, n)((x, y) => a(x, y % a.height)))
  def cut(line: Int, px: Int): Seq[Beat] = Beat.frame(a).take(lineStart(line) + px)
  val good: Seq[Beat] = Beat.frame(a)

  /** Events split per frame end (the last group: events after the last frame end). */
  def perFrame(events: Seq[CoreEvent]): Seq[(Seq[Corner], Option[FrameEnd])] = {
    val out = scala.collection.mutable.ArrayBuffer[(Seq[Corner], Option[FrameEnd])]()
    var cur = Vector[Corner]()
    events.foreach {
      case CornerEvent(c) => cur :+= c
      case FrameEndEvent(e) => out += ((cur, Some(e))); cur = Vector()
    }
    if (cur.nonEmpty) out += ((cur, None))
    out.toSeq
  }

  /** Model and RTL on `beats` (frames of `img`): every corner, frame end, counter, feature, drop and deselection
    * equal, and every corner a feature, deselected or a counted drop. */
  def runBoth(
      name: String,
      beats: Seq[Beat],
      img: GrayImage = a,
      params: CornerParams = cornerParams,
      blanking: Blanking = Blanking.random,
      simSeed: Option[Long] = None
  ): (CoreResult, RtlResult) = {
    val model = CoreModel.run(config, beats, params)
    var rtl: RtlResult = null
    core.doSim(name, seed.toInt) { dut =>
      rtl = CoreSim.run(dut, beats, params, blanking, simSeed.getOrElse(rng(name).nextLong()))
    }
    Scoreboard.compare(name, CoreEvents.of(model), rtl.events, Some(img)).foreach(msg => fail(msg))
    assert(rtl.counters == model.counters, s"$name: counters")
    assert(
      rtl.featureStream == model.featureStream,
      s"$name: feature output (model ${model.features.size}, RTL ${rtl.features.size})"
    )
    assert(
      rtl.deselected == model.deselected && rtl.featureDrops == model.featureDrops,
      s"$name: deselected and dropped corners"
    )
    assert(
      rtl.features.size + rtl.featureDrops + rtl.deselected == rtl.corners.size,
      s"$name: every corner is a feature, deselected or a counted drop"
    )
    println(
      s"[orb] $name: ${rtl.counters}, frame ends ${rtl.frameEnds.map(e => if (e.ok) "ok" else "FAULT").mkString(" ")}"
    )
    (model, rtl)
  }

  /** A processed good frame, a faulty one, a re-learning one, a good one. */
  def faultCase(name: String, faulty: Seq[Beat], badLines: Long, faultyEnd: Boolean = true): Unit = {
    val (_, rtl) = runBoth(name, Seq(good, good, faulty, good, good).flatten)
    assert(rtl.counters == FrameCounters(frames = 5, badFrames = 1, badLines = badLines), name)
    val groups = perFrame(rtl.events)
    val expectedEnds = if (faultyEnd) Seq(true, false, true) else Seq(true, true, true)
    assert(groups.map(_._2.map(_.ok)) == expectedEnds.map(Some(_)), s"$name: frame ends")
    assert(groups.head._1 == clean && groups.last._1 == clean, s"$name: clean frames, and the frame after re-learning")
    val faultyCorners = groups(1)._1
    assert(
      faultyCorners.forall(clean.contains),
      s"$name: a corner of the faulty frame that the clean image does not have"
    )
    assert(faultyCorners.size < clean.size || !faultyEnd, s"$name: the fault should have cut the frame short")
  }

  test("a line shorter than the frame's width") { faultCase("short-line", shortLine(40, 60), badLines = 1) }
  test("a line longer than the frame's width") { faultCase("long-line", longLine(40, 7), badLines = 1) }
  test("a line longer than maxWidth") { faultCase("line-over-max", longLine(35, config.maxWidth + 50), badLines = 1) }
  test("a missing end of line") { faultCase("missing-eol", missingEol(30), badLines = 1) }
  test("a frame with fewer lines than the previous one") { faultCase("few-lines", lines(45), badLines = 0) }
  test("a frame with more lines than the previous one (its corners were complete)") {
    faultCase("more-lines", lines(90), badLines = 0, faultyEnd = false)
  }
  test("a start of frame in the middle of a line") { faultCase("sof-mid-frame", cut(50, 17), badLines = 1) }

  /** Pure Harris maxima (checkerboard crossings) of `img` through model and RTL, no blanking. */
  def harrisMaxima(name: String, beats: Seq[Beat], img: GrayImage): (CoreResult, RtlResult) =
    runBoth(name, beats, img, harrisOnly, Blanking.none, Some(seed))

  test(
    "a fault while many corners still wait for a descriptor engine: nothing from after the fault, drops counted and modelled"
  ) {
    val dense = Patterns.checkerboard(240, 120, 6)
    val f = Beat.frame(dense).toVector
    val cut = 70 * 240 + 100 // a short line in row 70: corners of rows 40..48 are queued or in the engines then
    val faulty = f.take(cut) ++ Seq(f(cut).copy(eol = true)) ++ f.drop(71 * 240)
    val beats = f ++ f ++ faulty ++ f ++ f
    val (_, rtl) = harrisMaxima("fault-while-waiting", beats, dense)
    assert(rtl.featureDrops > 0 && rtl.counters.badFrames == 1)
    println(
      s"[orb] fault-while-waiting: ${rtl.corners.size} corners, ${rtl.features.size} features, ${rtl.deselected} deselected, ${rtl.featureDrops} counted drops"
    )
  }

  test("a burst of 2- and 9-pixel lines while corners are in the descriptor engines: RTL == model, drops counted") {
    // after the fault a line starts every few pixels: whatever the engines and their queue hold then must end as the
    // model says (the descriptor unit's ring stands still, so no row of theirs is overwritten)
    val dense = Patterns.checkerboard(240, 120, 6)
    val f = Beat.frame(dense).toVector
    val cut = 70 * 240 + 100
    val burst = (0 until 60).flatMap { i =>
      val len = if (i % 2 == 0) 2 else 9
      (0 until len).map(x => Beat(40 + 150 * (x % 2), sof = false, eol = x == len - 1))
    }
    val faulty = f.take(cut) ++ burst ++ f.drop(71 * 240)
    val (_, rtl) = harrisMaxima("short-line-burst", f ++ f ++ faulty ++ f ++ f, dense)
    assert(rtl.counters.badFrames == 1)
    println(
      s"[orb] short-line-burst: ${rtl.features.size} features, ${rtl.deselected} deselected, ${rtl.featureDrops} counted drops"
    )
  }

  test("a fault a few pixels into a band's emission row: RTL == model, every corner accounted for") {
    // 6-px checkerboard crossings in 1024-px lines: 4 winners in each of the 4 cells of a band with a crossing row,
    // whose emission (a winner every few clocks) still runs when the fault's frame end reaches the budget (which
    // then waits for it). Their descriptors would start 22 rows below them, after the fault: counted drops.
    val dense = Patterns.checkerboard(config.maxWidth, 80, 6)
    val w = dense.width
    val f = Beat.frame(dense).toVector
    val row = (BudgetModel.emitBeat(42, w, config.budget) / w).toInt
    val cut = row * w + 10
    val faulty = f.take(cut) ++ Seq(f(cut).copy(eol = true)) ++ f.drop((row + 1) * w)
    val beats = f ++ faulty ++ f
    val (model, rtl) = harrisMaxima("fault-in-emission", beats, dense)
    val band = (42 >> config.budget.bandShift) << config.budget.bandShift
    val emitted = model.budget.head._2.selected.count(c => c.y >= band && c.y < band + config.budget.cellHeight)
    assert(
      emitted == config.budget.perCell * config.budget.cellsPerRow(w),
      s"the band's winners are selected in the faulty frame: $emitted"
    )
    assert(rtl.featureDrops >= emitted)
    println(
      s"[orb] fault-in-emission: ${rtl.features.size} features, ${rtl.featureDrops} counted drops, $emitted from the band being emitted"
    )
  }

  test("the very first frame, too wide for the line buffer, is never processed") {
    val wide = Beat.frame(GrayImage.tabulate(config.maxWidth + 3, 30)((x, y) => (x * 7 + y * 13) % 256))
    val (_, rtl) = runBoth("first-too-wide", Seq(wide, good, good).flatten)
    assert(rtl.counters == FrameCounters(frames = 3, badFrames = 1, badLines = 30))
    assert(rtl.corners == clean)
  }

  test("pixels before the first start of frame are ignored") {
    val (_, rtl) = runBoth("stray-pixels", Seq(good.drop(100), good, good).flatten)
    assert(rtl.counters == FrameCounters(frames = 2, badFrames = 0, badLines = 0))
    assert(rtl.corners == clean)
  }

  test("reset in the middle of a frame, with the pipeline busy") {
    val before = good ++ good ++ cut(45, 30)
    val after = good.drop(500) ++ good ++ good
    val modelBefore = CoreEvents.of(CoreModel.run(config, before, cornerParams))
    val modelAfter = CoreEvents.of(CoreModel.run(config, after, cornerParams))
    var pre, post: Seq[CoreEvent] = Nil
    var countersAfter: FrameCounters = null
    core.doSim("reset-mid-frame", seed.toInt) { dut =>
      val monitor = CoreSim.start(dut, cornerParams)
      val r = rng("reset")
      CoreSim.drive(dut, before, Blanking.random, r)
      pre = monitor.events.toList
      dut.clockDomain.assertReset()
      dut.clockDomain.waitRisingEdge(3) // no sampling edge happens while reset is asserted
      dut.clockDomain.deassertReset()
      monitor.events.clear()
      CoreSim.drive(dut, after, Blanking.random, r)
      CoreSim.drain(dut)
      post = monitor.events.toList
      countersAfter = CoreSim.counters(dut)
    }
    assert(modelBefore.startsWith(pre), "before the reset: a prefix of what the model emits")
    assert(pre.count(_.isInstanceOf[FrameEndEvent]) == 1, "the first processed frame completed before the reset")
    Scoreboard.compare("reset-after", modelAfter, post, Some(a)).foreach(msg => fail(msg))
    assert(countersAfter == FrameCounters(frames = 2, badFrames = 0, badLines = 0))
    assert(post.collect { case CornerEvent(c) => c } == clean)
  }
}
