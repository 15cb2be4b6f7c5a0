package orb.model

import orb.MatcherConfig

/** A correspondence as the core will stream it: live (x, y) -> keyframe (x, y), Hamming distance. */
final case class Correspondence(liveX: Int, liveY: Int, keyX: Int, keyY: Int, distance: Int)

/** Run-time matching parameters.
  * @param hammingThreshold accept a best match at this distance or less (0..256)
  * @param ratio            ratio test factor scaled 2^ratioFracBits: accept when best * 2^F < ratio * second;
  *                         None disables the test
  * @param crossCheck       keep only mutual nearest neighbours (OpenCV's BFMatcher crossCheck = true)
  * The hardware's values after reset are `MatcherConfig.defaultParams`. */
final case class MatchParams(hammingThreshold: Int, ratio: Option[Int], crossCheck: Boolean)

/** Model of the keyframe store and the brute-force Hamming matcher (the specification the hardware will follow).
  *
  *  - Store: a keyframe's strongest `storeCapacity` features (see `store`); every feature beyond the capacity is
  *    counted as overflow.
  *  - For each live feature: the best store entry (smallest distance, the first in store order on ties) and the
  *    second-best distance (the smallest over every other entry, so equal to the best on a tie; 257 when the store
  *    has one entry). Accepted when best <= threshold and, if enabled, best * 2^F < ratio * second.
  *  - Cross-check: a store entry's best live feature over the whole frame (smallest distance, the first live
  *    feature on ties); an accepted match i -> j is kept iff that is i. So cross-checked correspondences are only
  *    known at the end of the live frame; they come then, in store (keyframe) order. Without cross-check they come
  *    in live-feature order.
  *  - A stream of frames (`run`): a keyframe's features replace the store (also when there are none) and get no
  *    correspondences; every other frame is matched against the store. The parameters are the same for all. */
object MatcherModel {
  final case class Store(features: IndexedSeq[Feature], overflow: Int)

  /** A score's rank, what the store's replacement compares: its level (`BudgetModel.levelOf`) with
    * `MatcherConfig.rankFracBits` bits after the leading one. It orders as the score does, but for scores within
    * about 2^-8 of each other, which tie. */
  def rank(score: Long): Int = BudgetModel.levelOf(score, MatcherConfig.rankFracBits)

  /** The keyframe's features in arrival order until the store is full; then each feature of a higher rank (`rank`)
    * than the weakest entry (the lowest rank, the first on ties) takes that entry's place. So the store ends with
    * the strongest features of the whole keyframe, spread over the image rather than its first rows. */
  def store(keyframe: Seq[Feature], cfg: MatcherConfig): Store = {
    val kept = scala.collection.mutable.ArrayBuffer[Feature]()
    for (f <- keyframe) {
      if (kept.size < cfg.storeCapacity) kept += f
      else {
        val weakest = kept.indices.minBy(i => (rank(kept(i).score), i))
        if (rank(f.score) > rank(kept(weakest).score)) kept(weakest) = f
      }
    }
    Store(kept.toIndexedSeq, (keyframe.size - cfg.storeCapacity) max 0)
  }

  def distance(a: Feature, b: Feature): Int = a.descriptor.zip(b.descriptor).map { case (p, q) =>
    Integer.bitCount(p ^ q)
  }.sum

  /** (best index, best distance, second distance) of a live feature against the store; None for an empty store. */
  def nearest(live: Feature, s: Store): Option[(Int, Int, Int)] =
    if (s.features.isEmpty) None
    else {
      val d = s.features.map(distance(live, _))
      val best = d.indices.minBy(i => (d(i), i))
      val second = d.indices.filter(_ != best).map(d).minOption.getOrElse(257)
      Some((best, d(best), second))
    }

  def accepted(best: Int, second: Int, p: MatchParams, cfg: MatcherConfig): Boolean =
    best <= p.hammingThreshold && p.ratio.forall(r => best.toLong * (1L << cfg.ratioFracBits) < r.toLong * second)

  def matchFrame(s: Store, live: Seq[Feature], p: MatchParams, cfg: MatcherConfig): Seq[Correspondence] = {
    val candidates = live.zipWithIndex.flatMap { case (q, i) =>
      nearest(q, s).filter { case (_, b, sec) => accepted(b, sec, p, cfg) }.map { case (j, b, _) => (i, j, b) }
    }
    val kept = if (!p.crossCheck) candidates
    else {
      val bestLive = s.features.indices.map { j =>
        if (live.isEmpty) -1 else live.indices.minBy(i => (distance(live(i), s.features(j)), i))
      }
      candidates.filter { case (i, j, _) => bestLive(j) == i }.sortBy(_._2)
    }
    kept.map { case (i, j, b) => Correspondence(live(i).x, live(i).y, s.features(j).x, s.features(j).y, b) }
  }

  /** One frame of a feature stream: its features, how it ended, and what the matcher emitted for it. */
  final case class FrameMatches(features: Seq[Feature], end: FrameEnd, correspondences: Seq[Correspondence]) {
    def keyframe: Boolean = end.keyframe
  }
  final case class Run(frames: Seq[FrameMatches], store: Store, overflow: Long) {
    def correspondences: Seq[Correspondence] = frames.flatMap(_.correspondences)
  }

  /** The matcher over a feature stream (`CoreResult.featureStream`): each frame's features, then its end. */
  def run(stream: Seq[Either[FrameEnd, Feature]], p: MatchParams, cfg: MatcherConfig): Run = {
    var s = Store(Vector.empty, 0)
    var overflow = 0L
    val frames = Vector.newBuilder[FrameMatches]
    var pending = Vector.newBuilder[Feature]
    stream.foreach {
      case Right(f) => pending += f
      case Left(end) =>
        val fs = pending.result(); pending = Vector.newBuilder[Feature]
        if (end.keyframe) {
          s = store(fs, cfg); overflow += s.overflow
          frames += FrameMatches(fs, end, Nil)
        } else frames += FrameMatches(fs, end, matchFrame(s, fs, p, cfg))
    }
    Run(frames.result(), s, overflow)
  }
}
