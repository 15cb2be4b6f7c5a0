package orb

import orb.model._
import org.scalatest.funsuite.AnyFunSuite

/** The matcher model's semantics on hand-made descriptors. */
class MatcherModelSpec extends AnyFunSuite {
  val cfg: MatcherConfig = MatcherConfig(storeCapacity = 3, comparators = 1)

  /** A feature whose descriptor has its first `ones` bits set. */
  def feat(x: Int, ones: Int, score: Long = 0): Feature =
    Feature(x, 0, 0, score, Vector.tabulate(32)(b => ((0 until 8).filter(i => b * 8 + i < ones).map(1 << _)).sum))

  test("store keeps the strongest N of the keyframe (the earliest of equal scores) and counts the rest") {
    val s = MatcherModel.store(
      Seq(feat(1, 0, 5), feat(2, 10, 9), feat(3, 20, 5), feat(4, 30, 7), feat(5, 0, 5), feat(6, 0, 6)),
      cfg
    )
    // 4 (score 7) replaces 1, the first of the two weakest (5); 5 (score 5) is not stronger; 6 (score 6) replaces 3
    assert(s.features.map(_.x) == Seq(4, 2, 6) && s.overflow == 3)
  }
  test("a score's rank: its leading one's place above the 8 bits after it; it orders as the score does") {
    import MatcherModel.rank
    assert(rank(256) == (8 << 8) && rank(511) == (8 << 8 | 255) && rank(512) == (9 << 8) && rank(513) == (9 << 8))
    val top = (1L << HarrisConfig().scoreWidth) - 1
    assert(rank(top) == ((HarrisConfig().scoreWidth - 1) << 8 | 255))
    assert(rank(top) < (1 << MatcherConfig.rankWidth(HarrisConfig())), "the rank fits its width")
    val rng = new scala.util.Random(7)
    val scores = Seq.fill(2000)(rng.nextLong(top + 1)).sorted
    assert(scores.zip(scores.tail).forall { case (a, b) => rank(a) <= rank(b) }, "monotonic")
    // equal ranks only within 2^-8 of each other: 100,100 and 100,300 tie, 100,100 and 100,400 do not
    assert(rank(100100) == rank(100300) && rank(100100) < rank(100400))
  }
  test("the store compares ranks: scores that tie in rank keep the earliest") {
    // 1 and 3 tie in rank (100,300 and 100,100): 4 replaces 1, the first of them, though 3 is weaker by score
    val s = MatcherModel.store(Seq(feat(1, 0, 100300), feat(2, 0, 900000), feat(3, 0, 100100), feat(4, 0, 200000)), cfg)
    assert(s.features.map(_.x) == Seq(4, 2, 3))
  }
  test("best, first on ties; second equals best on a tie; threshold and ratio") {
    val s = MatcherModel.store(Seq(feat(1, 10), feat(2, 10), feat(3, 40)), cfg)
    assert(MatcherModel.nearest(feat(9, 12), s).contains((0, 2, 2)))
    assert(MatcherModel.nearest(feat(9, 38), s).contains((2, 2, 28)))
    val p = MatchParams(hammingThreshold = 5, ratio = Some(128), crossCheck = false) // r = 0.5
    assert(MatcherModel.matchFrame(s, Seq(feat(9, 12)), p, cfg).isEmpty, "a tie fails the ratio test")
    assert(MatcherModel.matchFrame(s, Seq(feat(9, 38)), p, cfg) == Seq(Correspondence(9, 0, 3, 0, 2)))
    assert(MatcherModel.matchFrame(s, Seq(feat(9, 38)), p.copy(hammingThreshold = 1), cfg).isEmpty)
    assert(
      MatcherModel.matchFrame(s, Seq(feat(9, 38)), p.copy(ratio = Some(18)), cfg).isEmpty,
      "2 * 256 < 18 * 28 fails"
    )
  }
  test("cross-check keeps mutual nearest neighbours only") {
    val s = MatcherModel.store(Seq(feat(1, 10), feat(2, 100)), cfg)
    val live = Seq(feat(7, 11), feat(8, 12), feat(9, 99))
    val p = MatchParams(hammingThreshold = 256, crossCheck = true, ratio = None)
    // live 8 prefers entry 1 but entry 1 prefers live 7
    assert(MatcherModel.matchFrame(s, live, p, cfg) == Seq(
      Correspondence(7, 0, 1, 0, 1),
      Correspondence(9, 0, 2, 0, 1)
    ))
    assert(MatcherModel.matchFrame(s, live, p.copy(crossCheck = false), cfg).size == 3)
  }
}
