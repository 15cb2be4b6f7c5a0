package orb.model

import orb.{BudgetConfig, OrbConfig}

/** The feature budget (`orb.FeatureBudget`), one function per step; `orb.BudgetConfig` states the rule.
  *
  * Per processed frame: the corners (raster order) are grouped into cells, each cell keeps its `perCell` strongest
  * (`cellWinners`); a band of cells is emitted when the first pixel of row (band end + `emitRowOffset`) is processed
  * (`emitBeat`), its winners in raster order; the `Cut` from the previous good frame and the target decide which of
  * them become features (`select`); a good frame's winner histogram gives the next cut (`nextCut`). */
object BudgetModel {

  /** Which winners of a frame become features: every winner above `level`, the first `remainder` at `level`, never
    * more than the target in a frame. `history` false (after reset): the first `target` winners. */
  final case class Cut(level: Int, remainder: Int, history: Boolean)
  val noHistory: Cut = Cut(0, 0, history = false)

  /** How a frame's corners fared. */
  final case class FrameSelection(selected: Seq[Corner], deselected: Int, dropped: Int, histogram: IndexedSeq[Int])

  /** The leading one's position and the `fracBits` bits after it: each octave of scores in 2^fracBits equal parts (0
    * for 0). */
  def levelOf(score: Long, fracBits: Int): Int =
    if (score <= 0) 0
    else {
      val e = 63 - java.lang.Long.numberOfLeadingZeros(score)
      (e << fracBits) | (((score << fracBits) >> e) & ((1 << fracBits) - 1)).toInt
    }

  /** A winner's level in the frame's histogram: its rank without the last `rankFracBits - levelFracBits` bits, which
    * is `levelOf(score, levelFracBits)` (the hardware takes it so, from the rank the winner carries). */
  def level(score: Long, cfg: BudgetConfig): Int = rank(score, cfg) >> (cfg.rankFracBits - cfg.levelFracBits)

  /** A corner's rank in its cell: its score's level at `rankFracBits`. */
  def rank(score: Long, cfg: BudgetConfig): Int = levelOf(score, cfg.rankFracBits)

  def cellOf(c: Corner, cfg: BudgetConfig): (Int, Int) = (c.y >> cfg.bandShift, c.x >> cfg.cellShift)

  /** The `k` highest ranked corners of every cell (the first in raster order on ties), in raster order. */
  def cellWinners(corners: Seq[Corner], k: Int, cfg: BudgetConfig): Seq[Corner] =
    corners.zipWithIndex.groupBy { case (c, _) => cellOf(c, cfg) }.values
      .flatMap(_.sortBy { case (c, i) => (-rank(c.score, cfg), i) }.take(k)).toSeq.sortBy(_._2).map(_._1)

  /** The beat (raster index) at which the band of row `y` is emitted. */
  def emitBeat(y: Int, width: Int, cfg: BudgetConfig): Long =
    (((y >> cfg.bandShift) + 1).toLong * cfg.cellHeight + cfg.emitRowOffset) * width

  /** Applies the cut to a frame's winners, which arrive in raster order. */
  def select(winners: Seq[Corner], cut: Cut, target: Int, cfg: BudgetConfig, scoreWidth: Int): FrameSelection = {
    val hist = Array.fill(cfg.levels(scoreWidth))(0)
    var taken, atCut = 0
    val selected = winners.filter { c =>
      val l = level(c.score, cfg)
      hist(l) += 1
      val inCut = !cut.history || l > cut.level || (l == cut.level && atCut < cut.remainder)
      val take = taken < target && inCut
      if (take) taken += 1
      if (take && cut.history && l == cut.level) atCut += 1
      take
    }
    FrameSelection(selected, winners.size - selected.size, 0, hist.toIndexedSeq)
  }

  /** The cut that gives exactly `target` features on a frame with this winner histogram: the highest level L with
    * at least `target` winners at L or above, and r = target minus those above L; every winner when there are
    * fewer than `target` (L = 0, r = target). */
  def nextCut(histogram: IndexedSeq[Int], target: Int): Cut = {
    var above = 0
    for (l <- histogram.indices.reverse) {
      if (above + histogram(l) >= target) return Cut(l, target - above, history = true)
      above += histogram(l)
    }
    Cut(0, target, history = true)
  }

  /** One processed frame: its emitted corners (raster order), its width, how many of its beats were processed
    * (`activeCount`; all of them when the frame was good). Winners of bands whose emission beat came after a fault
    * are dropped (the fault ends the frame's processing); the corners their cells beat are deselected. Lines too
    * short for the engines to serve `perCell` corners per cell keep fewer (`OrbConfig.perCellFor`). */
  def frame(
      corners: Seq[Corner],
      width: Int,
      activeCount: Long,
      cut: Cut,
      target: Int,
      c: OrbConfig
  ): FrameSelection = {
    val cfg = c.budget
    val winners = cellWinners(corners, c.perCellFor(width), cfg)
    val (emitted, cutOff) = winners.partition(w => emitBeat(w.y, width, cfg) < activeCount)
    val s = select(emitted, cut, target, cfg, c.harris.scoreWidth)
    s.copy(deselected = s.deselected + corners.size - winners.size, dropped = cutOff.size)
  }
}
