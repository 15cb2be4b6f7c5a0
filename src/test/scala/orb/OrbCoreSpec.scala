package orb

import orb.model._
import orb.testbench._
import org.scalatest.funsuite.AnyFunSuite
import spinal.core.sim._

/** RTL (Verilator) against the bit-exact model: corners, scores, order, frame ends and counters. */
class OrbCoreSpec extends AnyFunSuite {
  import TestSupport._

  /** The first frame only teaches the core the geometry; the following ones are processed. */
  def stream(frames: Seq[GrayImage]): Seq[Beat] = frames.flatMap(Beat.frame(_))

  /** RTL == model on everything the core emits: corners, frame ends, the feature stream (the feature budget makes it
    * independent of timing: no drop unless a fault cuts a corner's rows, which the model has too) and the counters. */
  def check(
      name: String,
      frames: Seq[GrayImage],
      blanking: Blanking,
      p: CornerParams = cornerParams
  ): (CoreResult, RtlResult) = {
    val beats = stream(frames)
    val model = CoreModel.run(config, beats, p)
    var rtl: RtlResult = null
    core.doSim(name, seed.toInt) { dut => rtl = CoreSim.run(dut, beats, p, blanking, rng(name).nextLong()) }
    Scoreboard.compare(name, CoreEvents.of(model), rtl.events, frames.lastOption).foreach(msg => fail(msg))
    assert(rtl.counters == model.counters, s"$name: counters")
    assert(rtl.cornerCount == model.cornerCount, s"$name: corner counter")
    Scoreboard.compareFeatureStreams(name, model.featureStream, rtl.featureStream, frames.lastOption).foreach(msg =>
      fail(msg)
    )
    assert(
      rtl.featureDrops == model.featureDrops,
      s"$name: ${rtl.featureDrops} corners got no descriptor, the model says ${model.featureDrops}"
    )
    assert(rtl.deselected == model.deselected, s"$name: deselected corners")
    assert(rtl.featureCount == rtl.features.size)
    assert(
      rtl.features.size + rtl.featureDrops + rtl.deselected == rtl.corners.size,
      s"$name: every corner is a feature, deselected or a counted drop"
    )
    assert(rtl.holdBreaks.isEmpty, s"$name: the matcher's input contract: ${rtl.holdBreaks.take(5).mkString("; ")}")
    println(f"[orb] $name%-32s ${frames.size} frames ${frames.head.width}x${frames.head.height}: " +
      s"${rtl.corners.size} corners, ${rtl.deselected} deselected, ${rtl.features.size} features, ${rtl.frameEnds.size} frame ends, ${rtl.cycles} clocks")
    (model, rtl)
  }

  val w = 96; val h = 80
  test("synthetic: blank frames give no corner") {
    val (_, rtl) = check("blank", Seq.fill(3)(Patterns.blank(w, h)), Blanking.random)
    assert(rtl.corners.isEmpty)
    assert(rtl.frameEnds == Seq.fill(2)(FrameEnd(ok = true, keyframe = false)))
  }
  test("synthetic: a step edge corner") {
    val (_, rtl) = check("edges", Seq.fill(2)(Patterns.edges(w, h)), Blanking.none)
    assert(rtl.corners.map(c => (c.x, c.y)).exists { case (x, y) => (x - w / 2).abs <= 2 && (y - h / 3).abs <= 2 })
  }
  test(
    "synthetic: checkerboard, every inner crossing, ties included (Harris maxima: a crossing fails the segment test)"
  ) {
    val (_, rtl) = check("checkerboard", Seq.fill(2)(Patterns.checkerboard(w, h, 8)), Blanking.random, harrisOnly)
    assert(rtl.corners.size >= 9, "a checkerboard has crossings inside the border")
  }
  test("synthetic: noise and boxes, back to back without blanking (noise floods the detector: the budget deselects)") {
    val r = rng("noise")
    val frames = Seq(Patterns.noise(w, h, r), Patterns.boxes(w, h, r), Patterns.noise(w, h, r), Patterns.boxes(w, h, r))
    check("noise-boxes", frames, Blanking.none, harrisOnly)
    check("noise-boxes-segment", frames, Blanking.none)
  }
  test("synthetic: zero threshold (every local maximum), with and without the segment test") {
    val img = Patterns.boxes(w, h, rng("zero"))
    val (_, plain) = check("boxes-threshold0", Seq.fill(2)(img), Blanking.random, harrisOnly.copy(threshold = 0))
    val (_, seg) =
      check("boxes-threshold0-segment", Seq.fill(2)(img), Blanking.random, cornerParams.copy(threshold = 0))
    assert(seg.corners.nonEmpty && seg.corners != plain.corners, "the segment test changes which maxima are corners")
  }
  test("segment test thresholds: 0, 255 (nothing passes), and off, on a photograph crop") {
    val img = image("graf1.png").crop(300, 200, 128, 96)
    val (_, t0) = check("segment-t0", Seq.fill(2)(img), Blanking.random, cornerParams.copy(segmentThreshold = Some(0)))
    val (_, t255) =
      check("segment-t255", Seq.fill(2)(img), Blanking.random, cornerParams.copy(segmentThreshold = Some(255)))
    val (_, off) = check("segment-off", Seq.fill(2)(img), Blanking.random, harrisOnly)
    assert(
      t0.corners.nonEmpty && off.corners.nonEmpty && t255.corners.isEmpty,
      "t = 255: no pixel is 255 levels brighter or darker"
    )
  }
  test("a flood of corners: the budget deselects, every selected corner gets its feature, the next frames complete") {
    val flood = Patterns.checkerboard(240, 120, 4)
    val calm = Patterns.boxes(240, 120, rng("calm"))
    val (model, rtl) = check("flood", Seq(flood, flood, calm, calm), Blanking.none, harrisOnly)
    assert(
      rtl.corners.size > 500 && rtl.deselected > rtl.features.size,
      s"a flood: ${rtl.corners.size} corners, ${rtl.deselected} deselected"
    )
    assert(rtl.featureDrops == 0 && model.features.nonEmpty)
  }
  test("a consumer that pushes back half of the time: features unchanged, in order, none dropped") {
    val img = image("graf1.png").crop(200, 150, 320, 200)
    val beats = stream(Seq(img, img))
    val model = CoreModel.run(config, beats, cornerParams)
    var rtl: RtlResult = null
    core.doSim("backpressure", seed.toInt) { dut =>
      val r = rng("backpressure")
      val monitor = CoreSim.start(dut, cornerParams)
      dut.clockDomain.onSamplings { dut.io.features.ready #= r.nextBoolean() }
      CoreSim.drive(dut, beats, Blanking.random, r)
      CoreSim.drain(dut)
      rtl = CoreSim.result(dut, monitor)
    }
    assert(model.features.nonEmpty && rtl.featureStream == model.featureStream && rtl.featureDrops == 0)
    assert(rtl.holdBreaks.isEmpty, rtl.holdBreaks.take(5).mkString("; "))
    println(s"[orb] backpressure: ${rtl.features.size} features through a consumer ready half of the time")
  }
  test("a consumer that stops reading for two frames: the camera never stalls, drops are counted, then it recovers") {
    val img = image("graf1.png").crop(200, 150, 320, 200)
    val stalled = stream(Seq(img, img, img)); val after = Beat.frame(img)
    val model = CoreModel.run(config, stalled ++ after, cornerParams)
    var rtl: RtlResult = null
    core.doSim("stalled-consumer", seed.toInt) { dut =>
      val monitor = CoreSim.start(dut, cornerParams)
      dut.io.features.ready #= false
      CoreSim.drive(dut, stalled, Blanking.none, rng("stalled"))
      dut.io.features.ready #= true
      CoreSim.drive(dut, after, Blanking.none, rng("stalled"))
      CoreSim.drain(dut)
      rtl = CoreSim.result(dut, monitor)
    }
    assert(rtl.events == CoreEvents.of(model), "corners and frame ends are not affected")
    val perFrame = model.features.size / 3
    assert(rtl.featureDrops >= perFrame, s"a stalled consumer costs features: ${rtl.featureDrops} dropped")
    assert(rtl.deselected == model.deselected, "the budget's choice does not depend on the consumer")
    assert(
      rtl.features.size + rtl.featureDrops + rtl.deselected == rtl.corners.size,
      "every corner is a feature, deselected or a counted drop"
    )
    assert(
      rtl.features.takeRight(perFrame) == model.features.takeRight(perFrame),
      "the frame after the stall is complete"
    )
  }
  test("keyframe flags reach the frame ends") {
    val img = Patterns.boxes(w, h, rng("key"))
    val beats = Beat.frame(img) ++ Beat.frame(img, keyframe = true) ++ Beat.frame(img)
    val model = CoreModel.run(config, beats, cornerParams)
    var rtl: RtlResult = null
    core.doSim("keyframe", seed.toInt) { dut => rtl = CoreSim.run(dut, beats, cornerParams, Blanking.random, seed) }
    Scoreboard.compare("keyframe", CoreEvents.of(model), rtl.events, Some(img)).foreach(msg => fail(msg))
    assert(rtl.frameEnds == Seq(FrameEnd(ok = true, keyframe = true), FrameEnd(ok = true, keyframe = false)))
  }
  test(s"latency: a corner leaves ${OrbCore.latency()} clocks after the pixel (x + 5, y + 5) enters") {
    val img = Patterns.checkerboard(w, h, 8)
    val beats = stream(Seq(img, img))
    var clocks: Seq[Long] = Nil
    var corners: Seq[Corner] = Nil
    core.doSim("latency", seed.toInt) { dut =>
      val monitor = CoreSim.start(dut, harrisOnly) // checkerboard crossings
      CoreSim.drive(dut, beats, Blanking.none, rng("latency")) // beat i is sampled at monitor clock i + 1
      CoreSim.drain(dut)
      clocks = monitor.cornerClocks.toSeq; corners = monitor.events.collect { case CornerEvent(c) => c }.toSeq
    }
    assert(corners.nonEmpty)
    for ((c, clk) <- corners.zip(clocks)) {
      val beat = img.width * img.height + (c.y + HarrisConfig.reach) * img.width + (c.x + HarrisConfig.reach)
      assert(clk - (beat + 1) == OrbCore.latency(), s"corner $c")
    }
  }
  test("real photographs: crops, several blankings") {
    val graf = image("graf1.png")
    check(
      "graf1-crop",
      Seq(graf.crop(300, 200, 160, 120), graf.crop(300, 200, 160, 120), graf.crop(320, 210, 160, 120)),
      Blanking.random
    )
    val box = image("box.png")
    check("box", Seq(box, box), Blanking.camera, harrisOnly)
    // 324-px lines of dense texture (printed text), no blanking: the budget keeps what the engines can serve
    check("box-segment", Seq(box, box, box), Blanking.none)
    val leuven = image("leuvenA.png").crop(100, 100, 256, 160)
    check("leuven-crop", Seq(leuven, leuven), Blanking.none)
  }
  test("real photograph at full size: graf1 800x640, random blanking") {
    val graf = image("graf1.png")
    val (_, rtl) = check("graf1-full", Seq(graf, graf), Blanking.random)
    assert(rtl.corners.size > 100)
  }
}
