package orb.sim

import orb.OrbConfig
import orb.model._
import org.scalatest.funsuite.AnyFunSuite

/** Match quality on graf1 -> graf3 against its ground-truth homography: the core's default output (Hamming
  * threshold 64, cross-check, the 512 strongest keyframe features) against OpenCV ORB with one level and as many
  * features per image (BFMatcher cross-check), at the same number of matches, best first by distance. */
class MatchQualitySpec extends AnyFunSuite {
  val cfg: OrbConfig = OrbConfig.default
  lazy val (ours, openCv, h) = {
    val key = GrayImage.load("data/graf1.png"); val live = GrayImage.load("data/graf3.png")
    val h = Homography.load("data/graf_1to3.H.txt")
    val p = MatchParams(cfg.matcher.defaultHammingThreshold, None, cfg.matcher.defaultCrossCheck)
    val r = SystemModel.run(cfg, SystemModel.pairBeats(key, live), cfg.harris.defaultThreshold, p)
    val liveCount = SystemModel.keyAndLive(r.matches)._2.size
    val mine = Evaluate.Series("ours", r.correspondences.map(c => (c.distance, Homography.error(h, c))).sortBy(_._1))
    (mine, Evaluate.openCv("OpenCV 1 level", key, live, h, r.matches.store.features.size, liveCount, 1), h)
  }
  lazy val n: Int = ours.matches.size min openCv.matches.size
  lazy val (q, qcv) = (ours.inliers(ours.bestN(n)), openCv.inliers(openCv.bestN(n)))

  test("inliers within 3 px: at least 80 % of OpenCV single-scale ORB's at the same number of matches (regression guard)") {
    println(f"[orb] graf1 -> graf3, best $n matches: ours ${q * 100}%.1f %% within 3 px, OpenCV ORB 1 level ${qcv * 100}%.1f %%")
    assert(n >= 100, s"only $n matches")
    assert(q >= 0.8 * qcv, f"ours ${q * 100}%.1f %% vs OpenCV ${qcv * 100}%.1f %%")
  }

  test("inliers within 3 px: at least OpenCV single-scale ORB's (the issue's goal; not met yet, see the README)") {
    pendingUntilFixed { assert(q >= qcv, f"ours ${q * 100}%.1f %% vs OpenCV ${qcv * 100}%.1f %%") }
  }
}
