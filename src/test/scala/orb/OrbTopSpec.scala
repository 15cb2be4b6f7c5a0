package orb

import orb.model._
import orb.testbench._
import org.scalatest.funsuite.AnyFunSuite
import spinal.core.sim._

import java.io.{File, PrintWriter}

/** The complete core (`OrbTop`: pixels -> correspondences, Avalon-MM registers) against `SystemModel`, end to end
  * on real image pairs, with random blanking and a consumer that is not always ready. */
class OrbTopSpec extends AnyFunSuite {
  import TestSupport._
  lazy val top: SimCompiled[OrbTop] = {
    println(s"[orb] compiling the Verilator model of OrbTop (default config); seed = $seed (override with ORB_SEED)")
    TopSim.compile(config, workspace = "simWorkspace/top")
  }

  def check(
      name: String,
      key: GrayImage,
      live: GrayImage,
      p: MatchParams,
      blanking: Blanking,
      ready: Double,
      corners: CornerParams = cornerParams
  ): (SystemModel.Result, TopResult) = {
    val beats = SystemModel.pairBeats(key, live)
    val model = SystemModel.run(config, beats, corners, p)
    var rtl: TopResult = null
    top.doSim(name, seed.toInt) { dut =>
      rtl = TopSim.run(dut, config, beats, corners, p, blanking, ready, rng(name).nextLong())
    }
    Scoreboard.describe(name, "feature stream items", model.core.featureStream, rtl.featureStream).foreach(msg =>
      fail(msg)
    )
    Scoreboard.compareCorrespondences(name, model.correspondences, rtl.correspondences).foreach(msg => fail(msg))
    val r = rtl.registers
    val c = model.core
    assert(
      r("frames") == c.counters.frames && r("bad_frames") == c.counters.badFrames && r("bad_lines") == c.counters.badLines
    )
    assert(r("corners") == c.cornerCount && r("features") == c.features.size && r("feature_drops") == 0 && r(
      "deselected"
    ) == c.deselected)
    assert(r("stored") == model.matches.store.features.size && r("store_overflow") == model.matches.overflow)
    assert(r("matches") == model.correspondences.size && r("match_drops") == 0)
    println(
      f"[orb] $name%-40s ${c.cornerCount} corners, ${c.deselected} deselected, ${c.features.size} features, ${model.matches.store.features.size} stored " +
        f"(${model.matches.overflow} over), ${rtl.correspondences.size} correspondences, ${rtl.cycles} clocks"
    )
    (model, rtl)
  }

  test("graf1 -> graf3 at full size (800x640): random blanking, consumer ready 30% of clocks, cross-check") {
    val (model, _) = check(
      "graf1-graf3 full",
      image("graf1.png"),
      image("graf3.png"),
      MatchParams(hammingThreshold = config.matcher.defaultHammingThreshold, crossCheck = true, ratio = None),
      Blanking.random,
      ready = 0.3
    )
    assert(
      model.matches.overflow == 0 && model.matches.store.features.size == config.budget.defaultTarget,
      "the budget's target fits the store: the keyframe is stored whole"
    )
    assert(model.lastLive.size > 50)
  }

  test("dense real textures at full size, no blanking at all: baboon, starry_night (the matcher in the loop)") {
    val p = MatchParams(hammingThreshold = config.matcher.defaultHammingThreshold, crossCheck = true, ratio = None)
    for (name <- Seq("baboon.png", "starry_night.png")) {
      val img = image(name)
      val (model, _) = check(s"dense $name", img, img, p, Blanking.none, ready = 1.0)
      assert(model.core.deselected > model.core.features.size && model.lastLive.size > 100)
    }
  }

  test("a flood with no frame target, no blanking: the cells alone keep the matcher and the engines in time") {
    // 4-px checkerboard crossings (pure Harris maxima): every cell full in every band; without cross-check every
    // live feature is scanned and answered at once
    val unbounded = harrisOnly.copy(target = BudgetConfig.targetMax)
    for (w <- Seq(100, 1024)) {
      val flood = Patterns.checkerboard(w, 120, 4)
      val (model, _) = check(
        s"flood $w",
        flood,
        flood,
        MatchParams(hammingThreshold = 256, ratio = None, crossCheck = false),
        Blanking.none,
        ready = 1.0,
        corners = unbounded
      )
      assert(model.core.features.size > 100)
    }
  }

  test("crops of different sizes: the geometry is relearnt; ratio test without cross-check, blanking of a camera") {
    val key = image("graf1.png").crop(200, 150, 320, 256)
    val live = image("graf3.png").crop(180, 160, 288, 240)
    val (model, rtl) = check(
      "crops ratio",
      key,
      live,
      MatchParams(hammingThreshold = 80, ratio = Some(205), crossCheck = false),
      Blanking.camera,
      ready = 0.5
    )
    assert(rtl.registers("bad_frames") == 1, "the first frame of the new size is a counted fault")
    val last = model.matches.frames.last
    assert(last.end.ok && !last.keyframe && last.features.nonEmpty && model.correspondences.nonEmpty)
  }

  test("registers: ID, read back of every parameter") {
    import RegisterMap._
    top.doSim("registers", seed.toInt) { dut =>
      val (bus, _) = TopSim.start(
        dut,
        CornerParams(12345, Some(37), 321),
        MatchParams(hammingThreshold = 77, ratio = Some(200), crossCheck = true),
        1.0,
        rng("regs")
      )
      assert(bus.read(ID) == RegisterMap.id.toLong)
      assert(
        bus.read(HARRIS_THRESHOLD) == 12345 && bus.read(SEGMENT_THRESHOLD) == 37 && bus.read(HAMMING_THRESHOLD) == 77 &&
          bus.read(RATIO) == 200 && bus.read(CONTROL) == 7 && bus.read(TARGET) == 321 && bus.read(DESELECTED) == 0
      )
      bus.write(CONTROL, 0)
      assert(bus.read(CONTROL) == 0 && bus.read(FRAMES) == 0 && bus.read(STORED) == 0)
    }
  }
}
