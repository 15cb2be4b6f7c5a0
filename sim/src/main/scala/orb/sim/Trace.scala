package orb.sim

import orb._
import orb.model._
import orb.testbench.TopResult

/** `Match --trace X,Y`: every stage's values for the live feature nearest (X, Y), computed afresh by the golden
  * model's stage functions and, with the rtl engine, as recorded from the RTL's internal streams. */
object Trace {
  def report(
      at: (Int, Int),
      cfg: OrbConfig,
      key: GrayImage,
      live: GrayImage,
      o: Match.Options,
      run: MatcherModel.Run,
      rtl: Option[TopResult]
  ): String = {
    val (keyFeatures, liveFeatures) = SystemModel.keyAndLive(run)
    if (liveFeatures.isEmpty) return s"trace: the live image has no feature\n"
    val f = liveFeatures.minBy(q => (math.hypot(q.x - at._1, q.y - at._2), q.y, q.x))
    val (x, y) = (f.x, f.y)
    // The model, stage by stage, from the image.
    val response = HarrisModel.responseMap(live, cfg.harris)(x, y)
    val score = (response >> cfg.harris.scoreShift) max 0L
    val segment = for (t <- o.corners.segmentThreshold; seg <- cfg.harris.segment)
      yield HarrisModel.segmentTest(live, t, seg.arc)(x, y)
    val scoreName = s"score max(0, R >> ${cfg.harris.scoreShift})"
    val (m10, m01) = OrbModel.moments(live, x, y)
    val bin = OrbModel.angleBin(m10, m01, cfg.descriptor)
    val desc = Feature(x, y, bin, score, OrbModel.descriptor(OrbModel.smooth(live), x, y, bin, cfg.descriptor))
    val store = MatcherModel.store(keyFeatures, cfg.matcher)
    val nearest = MatcherModel.nearest(desc, store)
    val accepted = nearest.exists { case (_, b, s) => MatcherModel.accepted(b, s, o.params, cfg.matcher) }
    val lastLive = run.frames.filterNot(_.keyframe).lastOption.map(_.correspondences).getOrElse(Nil)
    val emitted = lastLive.find(c => c.liveX == x && c.liveY == y)
    def deg(b: Int) = f"${OrbModel.binDegrees(b, cfg.descriptor)}%.3f"
    def keyAt(j: Int) = s"#$j (${store.features(j).x}, ${store.features(j).y})"
    val model = Seq(
      "Harris response R" -> response.toString,
      "segment test" -> segment.fold("off")(p => if (p) "passes" else "fails"),
      scoreName -> score.toString,
      "budget rank in its cell (octave, sixteenth)" -> BudgetModel.rank(score, cfg.budget).toString,
      "budget level (octave, quarter)" -> BudgetModel.level(score, cfg.budget).toString,
      "moment m10" -> m10.toString,
      "moment m01" -> m01.toString,
      "angle bin" -> bin.toString,
      "angle (deg)" -> deg(bin),
      "descriptor" -> desc.hex,
      "best entry" -> nearest.fold("(empty store)")(n => keyAt(n._1)),
      "best distance" -> nearest.fold("-")(_._2.toString),
      "second distance" -> nearest.fold("-")(n => if (n._3 == MatcherConfig.none) "none" else n._3.toString),
      "accepted (threshold, ratio)" -> accepted.toString,
      "emitted" -> emitted.fold("no")(c => s"-> (${c.keyX}, ${c.keyY}) at ${c.distance}")
    )
    val rtlValues: Map[String, String] = rtl.fold(Map.empty[String, String]) { r =>
      val corner = r.corners.reverse.find(c => c.x == x && c.y == y)
      val ori = r.oriented.reverse.find(q => q.x == x && q.y == y)
      val feat = r.features.reverse.find(q => q.x == x && q.y == y)
      val scan = r.scans.reverse.find(s => s.liveX == x && s.liveY == y)
      val out = r.correspondences.reverse.find(c => c.liveX == x && c.liveY == y)
      Map(
        scoreName -> corner.fold("-")(_.score.toString),
        "moment m10" -> ori.fold("-")(_.m10.toString),
        "moment m01" -> ori.fold("-")(_.m01.toString),
        "angle bin" -> feat.fold("-")(_.bin.toString),
        "angle (deg)" -> feat.fold("-")(q => deg(q.bin)),
        "descriptor" -> feat.fold("-")(_.hex),
        "best entry" -> scan.fold("-")(s => s"#${s.bestIndex} (${s.keyX}, ${s.keyY})"),
        "best distance" -> scan.fold("-")(_.best.toString),
        "second distance" -> scan.fold("-")(s => if (s.second == MatcherConfig.none) "none" else s.second.toString),
        "emitted" -> out.fold("no")(c => s"-> (${c.keyX}, ${c.keyY}) at ${c.distance}")
      )
    }
    val sb = new StringBuilder
    sb ++= s"trace: live feature ($x, $y), the nearest to (${at._1}, ${at._2}); engine ${o.engine}\n"
    sb ++= f"${"stage"}%-28s ${"model"}%-66s ${if (rtl.isDefined) "rtl" else ""}\n"
    for ((name, mv) <- model) {
      val rv = rtlValues.get(name)
      val flag = rv.fold("")(v => if (v == mv) "" else if (v == "-") "" else "   <-- differs")
      sb ++= f"$name%-28s $mv%-66s ${rv.getOrElse("")}$flag\n"
    }
    sb.toString
  }
}
