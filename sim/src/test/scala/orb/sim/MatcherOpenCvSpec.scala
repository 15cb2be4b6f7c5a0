package orb.sim

import orb.{MatcherConfig, OrbConfig}
import orb.model._
import org.bytedeco.javacpp.indexer.UByteIndexer
import org.bytedeco.opencv.global.opencv_core._
import org.bytedeco.opencv.opencv_core.{DMatchVector, Mat}
import org.bytedeco.opencv.opencv_features2d.BFMatcher
import org.scalatest.funsuite.AnyFunSuite

/** The matcher model against OpenCV's BFMatcher (NORM_HAMMING) on real features: graf1 as keyframe, graf3 live. */
class MatcherOpenCvSpec extends AnyFunSuite {
  val cfg: OrbConfig = OrbConfig.default
  def features(name: String): Seq[Feature] = {
    val img = GrayImage.load(new java.io.File("data", name))
    // the corners of the detector alone at the threshold that chose the features before the budget: a few hundred
    OrbModel.features(img, HarrisModel.corners(img, cfg.harris, cfg.harris.params(1L << 14)), cfg.descriptor)
  }
  def mat(fs: Seq[Feature]): Mat = {
    val m = new Mat(fs.size, 32, CV_8UC1)
    val idx = m.createIndexer[UByteIndexer]()
    for ((f, i) <- fs.zipWithIndex; b <- 0 until 32) idx.put(i.toLong, b.toLong, f.descriptor(b))
    idx.release(); m
  }
  def cvMatch(live: Seq[Feature], key: Seq[Feature], crossCheck: Boolean): Seq[(Int, Int, Int)] = {
    val out = new DMatchVector()
    new BFMatcher(NORM_HAMMING, crossCheck).`match`(mat(live), mat(key), out)
    (0 until out.size().toInt).map { i =>
      val m = out.get(i.toLong); (m.queryIdx(), m.trainIdx(), m.distance().round)
    }
  }

  test("nearest neighbours and cross-check agree with OpenCV's BFMatcher") {
    val key = features("graf1.png"); val live = features("graf3.png")
    val mcfg =
      MatcherConfig(storeCapacity = key.size, comparators = 1) // the whole keyframe; lanes do not matter to the model
    val store = MatcherModel.store(key, mcfg)
    // Plain nearest neighbour: same distance for every live feature, same partner wherever it is unique.
    val cv = cvMatch(live, key, crossCheck = false)
    assert(cv.size == live.size)
    val ours = live.map(q => MatcherModel.nearest(q, store).get)
    assert(cv.map(_._3) == ours.map(_._2), "best distances")
    val unique = ours.indices.filter(i => ours(i)._2 < ours(i)._3)
    assert(unique.forall(i => cv(i)._2 == ours(i)._1), "partners where the best is unique")
    // Cross-check: the same mutual pairs, up to ties.
    val pos = key.zipWithIndex.map { case (f, j) => (f.x, f.y) -> j }.toMap
    val mine =
      MatcherModel.matchFrame(store, live, MatchParams(hammingThreshold = 256, crossCheck = true, ratio = None), mcfg)
        .map(c => (live.indexWhere(f => f.x == c.liveX && f.y == c.liveY), pos((c.keyX, c.keyY)))).toSet
    val theirs = cvMatch(live, key, crossCheck = true).map(m => (m._1, m._2)).toSet
    val agree = (mine intersect theirs).size.toDouble / (mine union theirs).size
    println(
      f"[orb] matcher vs BFMatcher: ${live.size} live x ${key.size} keyframe features, ${unique.size} unique nearest; " +
        f"cross-check: ours ${mine.size}, OpenCV ${theirs.size}, agreement ${agree * 100}%.2f%%"
    )
    assert(agree >= 0.99, s"cross-check agreement $agree")
  }
}
