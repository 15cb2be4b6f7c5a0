package orb

import orb.model._
import orb.testbench._
import org.scalatest.funsuite.AnyFunSuite
import spinal.core._
import spinal.core.sim._

import java.io.{File, PrintWriter}
import scala.collection.mutable.ArrayBuffer
import scala.util.Random

/** What the matcher harness saw: correspondences taken by the consumer, and the status counters at the end. */
final case class RtlMatches(
    correspondences: Seq[Correspondence],
    stored: Long,
    overflow: Long,
    matches: Long,
    drops: Long
)

/** The matcher alone (a 16-entry store, 4 comparators, the shortest output FIFO the sweep allows) against `MatcherModel`, on
  * hand-made feature streams: store overflow, thresholds, ratio test, cross-check, ties, empty stores, a slow
  * consumer (nothing lost) and a stalled one (drops after the 200-clock timeout, counted); and a second model with a
  * store of one group, its frames back to back. */
class MatcherSpec extends AnyFunSuite {
  import TestSupport._
  val m: MatcherConfig = MatcherConfig(
    storeCapacity = 16,
    comparators = 4,
    outputDepth = MatcherConfig.pushLatency + 2,
    outputTimeout = 200
  )
  val f: FrameConfig = FrameConfig(maxWidth = 128, maxHeight = 128)
  lazy val matcher: SimCompiled[Matcher] = {
    println(s"[orb] compiling the Verilator model of Matcher (16 entries); seed = $seed")
    compiled("simWorkspace/matcher", m)
  }

  /** a Verilator model of the matcher with `config` */
  def compiled(workspace: String, config: MatcherConfig): SimCompiled[Matcher] =
    CoreSim.simConfig(workspace).compile(new Matcher(f, HarrisConfig(), OrbDescriptorConfig(), config))

  /** a store of one group (as many entries as comparators): a scan is a single read */
  val mOneGroup: MatcherConfig = m.copy(storeCapacity = m.comparators)
  lazy val oneGroup: SimCompiled[Matcher] = {
    println(s"[orb] compiling the Verilator model of Matcher (one group); seed = $seed")
    compiled("simWorkspace/matcher1", mOneGroup)
  }

  /** Drives `stream` (features and frame ends) with random gaps (or none: each item as soon as the last is taken);
    * the consumer is ready with probability `ready` (1: always) and, if `stallFor` > 0, not at all for that many
    * clocks after the first frame end. With a consumer always ready, checks on the matcher's own item handshake
    * that no item holds it longer than its configuration says (`clocksPerFeature` for a feature, live or keyframe,
    * replacing or not; `frameEndClocks` for a frame end), whenever the next item was waiting: the feature budget's
    * service bound counts on it. */
  def runRtl(
      name: String,
      stream: Seq[Either[FrameEnd, Feature]],
      p: MatchParams,
      ready: Double,
      stallFor: Int = 0,
      gaps: Boolean = true,
      sim: SimCompiled[Matcher] = matcher,
      m: MatcherConfig = m
  ): RtlMatches = {
    var out: RtlMatches = null
    sim.doSim(name, seed.toInt) { dut =>
      val r0 = rng(name)
      val in = dut.io.features
      in.valid #= false; in.x #= 0; in.y #= 0; in.bin #= 0; in.score #= 0; in.rank #= 0; in.descriptor #= 0
      in.keyframe #= false; in.end.now #= false; in.end.info.ok #= true; in.end.info.keyframe #= false
      dut.io.params.hammingThreshold #= p.hammingThreshold
      dut.io.params.ratio #= p.ratio.getOrElse(0).toLong
      dut.io.params.ratioTest #= p.ratio.isDefined
      dut.io.params.crossCheck #= p.crossCheck
      dut.io.correspondences.ready #= true
      CoreSim.startClock(dut.clockDomain)
      val got = ArrayBuffer[Correspondence]()
      var stallLeft = -1
      // the clock of every item's take by the matcher, and of the first clock it waited there
      var clocks = 0L
      val taken = ArrayBuffer[Long]()
      val waiting = ArrayBuffer[Long]()
      dut.clockDomain.onSamplings {
        clocks += 1
        if (in.valid.toBoolean && waiting.size == taken.size) waiting += clocks
        if (in.valid.toBoolean && in.ready.toBoolean) taken += clocks
        val c = dut.io.correspondences
        if (c.valid.toBoolean && c.ready.toBoolean)
          got += Correspondence(c.liveX.toInt, c.liveY.toInt, c.keyX.toInt, c.keyY.toInt, c.distance.toInt)
        val r = if (stallLeft > 0) { stallLeft -= 1; false }
        else ready >= 1 || r0.nextDouble() < ready
        c.ready #= r
      }
      val keyFlags =
        stream.indices.map(i => stream.drop(i).collectFirst { case Left(e) => e.keyframe }.getOrElse(false))
      for ((item, i) <- stream.zipWithIndex) {
        while (gaps && r0.nextInt(4) == 0) dut.clockDomain.waitSampling()
        in.valid #= true
        item match {
          case Right(ft) =>
            in.end.now #= false; in.x #= ft.x; in.y #= ft.y; in.bin #= ft.bin; in.score #= ft.score;
            in.rank #= MatcherModel.rank(ft.score)
            in.descriptor #= ft.descriptorBits
            in.keyframe #= keyFlags(i)
          case Left(e) =>
            in.end.now #= true; in.end.info.ok #= e.ok; in.end.info.keyframe #= e.keyframe; in.keyframe #= e.keyframe
            if (stallFor > 0 && stallLeft < 0) stallLeft = stallFor
        }
        dut.clockDomain.waitSamplingWhere(in.ready.toBoolean)
        // the input's contract (the descriptor unit's output register keeps it): the taken item stays, unoffered,
        // for the clock after its take, and its descriptor, unoffered, for the clock after that
        in.valid #= false
        dut.clockDomain.waitSampling(2)
      }
      // Drain: until every correspondence counted by the matcher has arrived and nothing has been pushed or taken
      // for longer than a scan, a sweep of the store and a full FIFO's pushes in flight take (a bound, so that a lost
      // correspondence fails the comparison instead of hanging the test).
      val s = dut.io.status
      val quietNeeded = m.clocksPerFeature + m.storeCapacity + 4 * m.outputDepth + stallFor
      val bound = 200 * (m.clocksPerFeature + m.storeCapacity + 4 * m.outputDepth) + stallFor
      var waited = 0
      var quiet = 0
      var seen = (-1L, -1)
      while (waited < bound && quiet < quietNeeded) {
        dut.clockDomain.waitSampling()
        waited += 1
        val now = (s.matches.toLong, got.size)
        quiet = if (now == seen && now._1 == now._2) quiet + 1 else 0
        seen = now
      }
      out = RtlMatches(got.toSeq, s.stored.toLong, s.storeOverflow.toLong, s.matches.toLong, s.matchDrops.toLong)
      if (ready >= 1 && stallFor == 0) {
        // item k was waiting when item k - 1 was taken (it is offered three clocks after a take at the earliest: the
        // input's contract): the clocks between the takes are k - 1's hold
        val holds =
          (1 until taken.size).filter(k => waiting(k) <= taken(k - 1) + 3).map(k => (k - 1, taken(k) - taken(k - 1)))
        val over = holds.filter { case (k, h) => h > (if (stream(k).isRight) m.clocksPerFeature else m.frameEndClocks) }
        val longest = holds.filter(h => stream(h._1).isRight).map(_._2).maxOption.getOrElse(0L)
        // a keyframe feature's hold apart (a replacement's rescan is not a scan: it has its own latency)
        val longestKey = holds.filter(h => stream(h._1).isRight && keyFlags(h._1)).map(_._2).maxOption.getOrElse(0L)
        println(
          s"[orb] $name: longest hold by a feature $longest clocks, by a keyframe feature $longestKey " +
            s"(at most ${m.clocksPerFeature})"
        )
        assert(over.isEmpty, s"$name: items held the matcher too long (item, clocks): ${over.take(5).mkString(", ")}")
      }
    }
    out
  }

  /** A keyframe of `nKey` random descriptors (a quarter of them repeated: ties between entries), then live
    * frames mixing noisy copies (0..40 bits flipped), exact copies (ties between live features) and unrelated ones. */
  def scenario(
      rng: Random,
      nKey: Int,
      liveFrames: Int,
      nLive: Int,
      keyAgainAt: Int = -1
  ): Seq[Either[FrameEnd, Feature]] = {
    def randomDesc = Vector.fill(32)(rng.nextInt(256))
    def feature(d: Vector[Int]) =
      Feature(rng.nextInt(128), rng.nextInt(128), rng.nextInt(512), 1000L * rng.nextInt(8), d) // scores tie often
    val out = ArrayBuffer[Either[FrameEnd, Feature]]()
    // A quarter of the keyframe repeats earlier descriptors: ties between entries.
    def keyframe(n: Int) = {
      val base = Vector.fill(n - n / 4)(randomDesc); base ++ Vector.fill(n / 4)(base(rng.nextInt(base.size)))
    }
    var key = keyframe(nKey)
    out ++= key.map(d => Right(feature(d))); out += Left(FrameEnd(ok = true, keyframe = true))
    for (frame <- 0 until liveFrames) {
      if (frame == keyAgainAt) {
        key = keyframe(nKey / 2)
        out ++= key.map(d => Right(feature(d))); out += Left(FrameEnd(ok = rng.nextBoolean(), keyframe = true))
      }
      for (_ <- 0 until nLive) {
        val d = if (key.nonEmpty && rng.nextInt(5) != 0) {
          val k = key(rng.nextInt(key.size))
          val flips = if (rng.nextInt(4) == 0) 0 else rng.nextInt(40)
          (0 until flips).foldLeft(k) { (v, _) =>
            val b = rng.nextInt(256); v.updated(b / 8, v(b / 8) ^ (1 << (b % 8)))
          }
        } else randomDesc
        out += Right(feature(d))
      }
      out += Left(FrameEnd(ok = true, keyframe = false))
    }
    out.toSeq
  }

  def check(
      name: String,
      stream: Seq[Either[FrameEnd, Feature]],
      p: MatchParams,
      ready: Double = 1.0,
      stallFor: Int = 0,
      gaps: Boolean = true,
      sim: SimCompiled[Matcher] = matcher,
      m: MatcherConfig = m
  ): (MatcherModel.Run, RtlMatches) = {
    val model = MatcherModel.run(stream, p, m)
    val rtl = runRtl(name, stream, p, ready, stallFor, gaps, sim, m)
    val expected = model.correspondences
    assert(rtl.stored == model.store.features.size, s"$name: stored")
    assert(rtl.overflow == model.overflow, s"$name: overflow count")
    assert(rtl.matches == rtl.correspondences.size, s"$name: match counter")
    if (rtl.drops == 0) {
      Scoreboard.compareCorrespondences(name, expected, rtl.correspondences).foreach(msg => fail(msg))
    } else {
      // Drops: what arrived is the model's sequence with some left out, and every one left out is counted.
      Scoreboard.notAnOrderedSubset(expected, rtl.correspondences).foreach(c =>
        fail(s"$name: $c is not the model's next")
      )
      assert(rtl.drops == expected.size - rtl.correspondences.size, s"$name: drops counted")
    }
    println(f"[orb] $name%-36s ${expected.size} expected, ${rtl.correspondences.size} received, ${rtl.drops} dropped")
    (model, rtl)
  }

  val plain = MatchParams(hammingThreshold = 64, ratio = None, crossCheck = false)
  test("threshold only: live order, first entry on ties") {
    val (model, _) = check("threshold", scenario(rng("threshold"), 13, 3, 20), plain, ready = 0.7)
    assert(model.correspondences.nonEmpty)
  }
  test("ratio test, against the brute-force model") {
    val (model, _) = check(
      "ratio",
      scenario(rng("ratio"), 16, 3, 20),
      MatchParams(hammingThreshold = 128, ratio = Some(205), crossCheck = false)
    )
    assert(model.correspondences.nonEmpty)
  }
  test("cross-check: mutual pairs at the frame end, in keyframe order") {
    val stream = scenario(rng("cross"), 16, 3, 24)
    val (model, _) = check("cross-check", stream, MatchParams(hammingThreshold = 100, crossCheck = true, ratio = None))
    val plainCount =
      MatcherModel.run(stream, MatchParams(hammingThreshold = 100, ratio = None, crossCheck = false), m).correspondences.size
    assert(
      model.correspondences.nonEmpty && model.correspondences.size < plainCount,
      "the scenario exercises the check"
    )
  }
  test("cross-check with the ratio test and a threshold of 0 and 256") {
    val stream = scenario(rng("both"), 12, 2, 16)
    check("cross+ratio", stream, MatchParams(hammingThreshold = 256, ratio = Some(230), crossCheck = true))
    check("threshold 0", stream, MatchParams(hammingThreshold = 0, crossCheck = true, ratio = None))
  }
  test(
    "store overflow: the strongest 16 are kept (the earliest of equal scores), the rest counted; a new keyframe replaces the store"
  ) {
    // Cross-check emits in store order, so the content and the order of the store are both visible.
    val stream = scenario(rng("overflow"), 40, 3, 24, keyAgainAt = 1)
    val (model, _) = check("overflow", stream, MatchParams(hammingThreshold = 100, crossCheck = true, ratio = None))
    assert(model.overflow == 24 + 4 && model.correspondences.size > 10)
    check("overflow, threshold only", stream, plain)
  }
  test("replacement picks the weakest entry, the first of equal ranks, wherever it lies in a group") {
    val r = rng("replace")
    def desc = Vector.fill(32)(r.nextInt(256))
    // Scores: four tied weakest entries, in lanes 0..3 of one group, then in the last group, then spread; then
    // stronger ones.
    // The last case: the weakest differ in score, not in rank (the later the weaker by score): the first goes.
    val cases = Seq(
      (0 until 4, "group 0", (_: Int) => 1L),
      (12 until 16, "last group", (_: Int) => 1L),
      (Seq(2, 7, 9, 13), "spread", (_: Int) => 1L),
      (Seq(1, 5, 10, 14), "tied by rank", (i: Int) => 100300L - 10 * i)
    )
    for ((weakAt, name, weakScore) <- cases) {
      val key = (0 until 16).map(i => Feature(i, 0, 0, if (weakAt.contains(i)) weakScore(i) else 150000, desc)) ++
        (16 until 19).map(i => Feature(i, 0, 0, 200000, desc))
      val live = key.map(k => k.copy(x = k.x + 100, y = 5))
      val stream = key.map(Right(_)) ++ Seq(Left(FrameEnd(ok = true, keyframe = true))) ++ live.map(Right(_)) ++
        Seq(Left(FrameEnd(ok = true, keyframe = false)))
      val (model, _) = check(
        s"replacement, weakest in $name",
        stream,
        MatchParams(hammingThreshold = 10, crossCheck = true, ratio = None)
      )
      assert(model.store.features.map(_.x) == (0 until 16).map(i =>
        if (weakAt.take(3).contains(i)) 16 + weakAt.indexOf(i) else i
      ))
    }
  }
  test("empty store: no correspondence, no hang; a single entry has no second best") {
    val rng0 = rng("empty")
    check(
      "single entry",
      scenario(rng0, 1, 2, 6),
      MatchParams(hammingThreshold = 256, ratio = Some(511), crossCheck = false)
    )
    val noKey = scenario(rng0, 0, 2, 6)
    val (model, _) = check("empty store", noKey, plain)
    assert(model.correspondences.isEmpty)
  }
  test("a slow consumer loses nothing; a stalled one gets counted drops after the timeout, and no hang") {
    val stream = scenario(rng("stall"), 16, 4, 30)
    for (cross <- Seq(false, true)) {
      val (_, slow) = check(
        s"slow consumer, cross-check $cross",
        stream,
        MatchParams(hammingThreshold = 100, crossCheck = cross, ratio = None),
        ready = 0.1
      )
      assert(slow.drops == 0)
      val (_, stalled) = check(
        s"stalled consumer, cross-check $cross",
        stream,
        MatchParams(hammingThreshold = 100, crossCheck = cross, ratio = None),
        stallFor = 3000
      )
      assert(stalled.drops > 0, "a 3000-clock stall must outlast the timeout")
    }
  }

  test("a store of one group: an empty keyframe, then at once a live frame and a keyframe, items back to back") {
    val r = rng("one group")
    def feature(): Either[FrameEnd, Feature] =
      Right(Feature(
        r.nextInt(128),
        r.nextInt(128),
        r.nextInt(512),
        1000L * r.nextInt(8),
        Vector.fill(32)(r.nextInt(256))
      ))
    def frame(n: Int, key: Boolean) = Seq.fill(n)(feature()) :+ Left(FrameEnd(ok = true, keyframe = key))
    val stream = frame(4, key = true) ++ frame(3, key = false) ++ frame(0, key = true) ++ frame(1, key = false) ++
      frame(0, key = false) ++ frame(3, key = true) ++ frame(3, key = false) ++ frame(6, key = true) ++
      frame(2, key = false)
    for (cross <- Seq(false, true)) {
      val p = MatchParams(hammingThreshold = 256, ratio = None, crossCheck = cross)
      check(s"one group, cross-check $cross", stream, p, gaps = false, sim = oneGroup, m = mOneGroup)
    }
  }
}
