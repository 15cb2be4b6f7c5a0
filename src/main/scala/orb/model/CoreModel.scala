package orb.model

import orb.{CornerParams, OrbConfig}
import scala.collection.mutable.ArrayBuffer

/** End of a processed frame, as the core reports it. */
final case class FrameEnd(ok: Boolean, keyframe: Boolean)

/** Everything the core emits for a beat sequence, in emission order. */
final case class CoreResult(
    corners: Seq[Corner],
    frameEnds: Seq[FrameEnd],
    counters: FrameCounters,
    cornerCount: Long,
    /** the features of the emitted corners whose descriptor rows came before any fault */
    features: Seq[Feature],
    /** the feature output: each processed frame's features, then its end */
    featureStream: Seq[Either[FrameEnd, Feature]],
    /** per emitted corner / frame end: the index of the beat that carried it */
    cornerBeats: Seq[Int],
    frameEndBeats: Seq[Int],
    /** corners the feature budget did not select (`BudgetModel`) */
    deselected: Long = 0,
    /** per processed frame, in order: the budget's cut it was selected with, and its selection */
    budget: Seq[(BudgetModel.Cut, BudgetModel.FrameSelection)] = Nil
) {

  /** corners that were selected but got no feature: their descriptor rows were cut by a fault */
  def featureDrops: Long = cornerCount - deselected - features.size
}

/** Bit-exact model of the whole core (`orb.OrbCore`): the frame tracker decides which beats are processed, the
  * Harris model computes the corners of each processed frame, and a corner is emitted iff the beat that completes
  * its neighbourhood, (x + reach, y + reach), was processed (i.e. came before any fault of its frame). The feature
  * budget (`BudgetModel`) selects among a frame's corners, with the cut learnt from the last good frame; a
  * selected corner gets its feature iff the first beat of row y + `startRowOffset`, where its descriptor starts,
  * was processed too. Nothing depends on timing: the budget bounds what reaches the engines so that they always
  * keep up (`OrbConfig.budgetService`), as long as the consumer of the core's output keeps up too. */
object CoreModel {
  def run(cfg: OrbConfig, beats: Seq[Beat], p: CornerParams): CoreResult = {
    val tracker = new FrameTrackerModel(cfg.frame)
    val reach = orb.HarrisConfig.reach
    val corners = ArrayBuffer[(Int, Corner)]()
    val features = ArrayBuffer[Feature]()
    val featureStream = ArrayBuffer[Either[FrameEnd, Feature]]()
    var pendingEnd: Option[FrameEnd] = None
    val ends = ArrayBuffer[(Int, FrameEnd)]()
    // The processed frame being collected: geometry, pixels, beat index of each raster position, active prefix.
    var w, h, activeCount = 0
    var pixels: Array[Int] = null
    var beatIndex: Array[Int] = null
    var collecting = false
    var cut = BudgetModel.noHistory
    var deselected = 0L
    val budget = ArrayBuffer[(BudgetModel.Cut, BudgetModel.FrameSelection)]()

    def flush(): Unit = if (collecting) {
      collecting = false
      val img = GrayImage(w, h, pixels)
      val emitted = HarrisModel.corners(img, cfg.harris, p).filter { c =>
        val emit = (c.y + reach) * w + (c.x + reach)
        if (emit < activeCount) corners += beatIndex(emit) -> c
        emit < activeCount
      }
      val selection = BudgetModel.frame(emitted, w, activeCount, cut, p.target, cfg)
      budget += cut -> selection
      deselected += selection.deselected
      if (activeCount == w * h) cut = BudgetModel.nextCut(selection.histogram, p.target)
      val described = selection.selected.filter(c => (c.y + orb.OrbDescriptorConfig.startRowOffset) * w < activeCount)
      val fs = OrbModel.features(img, described, cfg.descriptor)
      features ++= fs
      featureStream ++= fs.map(Right(_))
      featureStream ++= pendingEnd.map(Left(_)); pendingEnd = None
    }

    for ((b, i) <- beats.zipWithIndex) {
      if (b.sof) flush()
      tracker.step(b).foreach { t =>
        if (b.sof && t.active) {
          val (gw, gh) = tracker.geometry
          w = gw; h = gh; activeCount = 0; collecting = true
          pixels = new Array[Int](w * h); beatIndex = new Array[Int](w * h)
        }
        if (t.active) {
          pixels(t.y * w + t.x) = t.luma; beatIndex(t.y * w + t.x) = i; activeCount += 1
        }
        for (e <- t.end) {
          ends += i -> e
          // On a start of frame the end belongs to the frame just flushed; otherwise to the current one.
          if (b.sof) featureStream += Left(e) else pendingEnd = Some(e)
        }
      }
    }
    flush()
    val sortedCorners = corners.sortBy(_._1)
    CoreResult(
      sortedCorners.map(_._2).toSeq,
      ends.map(_._2).toSeq,
      tracker.stats,
      corners.size.toLong,
      features.toSeq,
      featureStream.toSeq,
      sortedCorners.map(_._1).toSeq,
      ends.map(_._1).toSeq,
      deselected,
      budget.toSeq
    )
  }
}
