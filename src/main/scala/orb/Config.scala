package orb

import spinal.core._

/** Geometry limits of the pixel stream: longer lines or taller frames are faults. Only `maxWidth` costs memory
  * (it is the depth of every line buffer); `maxHeight` only sizes counters.
  *
  * @param coordWidth bits of every x/y coordinate; 11 bits address up to 2047 in both directions
  */
case class FrameConfig(maxWidth: Int = 1024, maxHeight: Int = 2047, coordWidth: Int = 11) {
  require(maxWidth >= 16 && maxHeight >= 16, "frames smaller than 16x16 are not supported")
  // x and y saturate at maxWidth / maxHeight after a fault, so those values must be representable too.
  require(
    maxWidth < (1 << coordWidth) && maxHeight < (1 << coordWidth),
    s"coordWidth=$coordWidth cannot hold maxWidth=$maxWidth / maxHeight=$maxHeight"
  )
  def addrWidth: Int = log2Up(maxWidth)
  def counterWidth: Int = 32

  /** an x or y coordinate */
  def coord(): UInt = UInt(coordWidth bits)

  /** an event counter of the register map (wraps) */
  def counter(): UInt = UInt(counterWidth bits)

  /** rows counted since reset, wrapping (`RowClock`): a corner's row tag is compared with the stream's within a few
    * dozen rows, so half the range must exceed that wait (`OrbConfig` checks it) */
  def rowTagWidth: Int = 12

  /** frames counted since reset, wrapping: a corner is decided in its own frame or the next */
  def frameTagWidth: Int = 4
  def rowTag(): UInt = UInt(rowTagWidth bits)
  def frameTag(): UInt = UInt(frameTagWidth bits)
}

/** Harris-Stephens corner detector.
  *
  * Fixed-point data path (every width below is derived here, from the worst case of an 8-bit image):
  *  - Sobel gx, gy: OpenCV's 3x3 kernel, exact, |g| <= 1020 (11 bits signed).
  *  - products gx^2, gy^2, gx*gy: exact (20 bits unsigned / 21 bits signed).
  *  - 7x7 binomial window (1 6 15 20 15 6 1, outer product, weights sum to 4096): exact sums, then
  *    `>> windowShift` rounded half up. The default 15 keeps the window sums in 17/18 bits, so every product of the
  *    response stage fits one 18x18 multiplier of the target.
  *  - R = Sxx*Syy - Sxy^2 - ((kNum * (Sxx+Syy)^2) >> kShift), exact apart from that floor.
  *  - score = max(0, R >> scoreShift); with the defaults a positive R >> 7 always fits 27 bits. The suppression
  *    keeps two rows of scores, so every bit costs 2 x maxWidth bits of M4K (27 bits: 12 M4K, 32 bits: 16); a
  *    score step of 128 units of R is far below any corner's R (over 2^20 at the default threshold).
  *
  * @param segment  corner candidates: with a segment test, a pixel can only be a corner if it passes it (OpenCV's
  *                 FAST test, see `SegmentTestConfig`); its score, the threshold and the 3x3 suppression are
  *                 Harris-Stephens' as above, taken over the candidates (a non-candidate scores 0). None builds pure
  *                 Harris maxima and no segment-test logic. The test can also be switched off at run time.
  * @param defaultThreshold the threshold after reset. An ideal right-angle corner of 45 grey levels contrast
  *               scores about 2^13, of 54 levels about 2^14 (the score grows with the 4th power of the contrast:
  *               32 levels ~ 2.1e3, 64 levels ~ 34e3). With the segment test, a candidate in texture is no longer
  *               suppressed by a stronger non-candidate neighbour, so a threshold gives more corners than pure
  *               Harris maxima; the default 2^14 keeps about the corner rate pure Harris has at 2^13 (all the
  *               photographs of data/: 6,870 corners against 8,652). The hardware takes the threshold at run time.
  * @param border no corner closer than this to any image edge; the default 22 leaves the ORB stage a pixel
  *               to spare: the rotated BRIEF tests reach 18 px (18.4 before rounding), plus 3 px for the 7x7
  *               smoothing of the sampled image
  */
case class HarrisConfig(
    kNum: Int = 41,
    kShift: Int = 10,
    windowShift: Int = 15,
    scoreShift: Int = 7,
    border: Int = 22,
    segment: Option[SegmentTestConfig] = Some(SegmentTestConfig()),
    defaultThreshold: Long = 1L << 8
) {
  import HarrisConfig._
  require(kNum > 0 && kShift >= 0 && kNum < (1 << kShift), "k = kNum / 2^kShift must lie in (0, 1)")
  require(windowShift >= 0 && scoreShift >= 0)
  require(border >= reach, s"border must be >= $reach: the filters need that many pixels of context")
  require(windowShift < 32, "the window shift must leave some of the window sum")
  require(border >= SegmentTestConfig.radius, "the segment test's circle must lie inside the frame")
  def k: Double = kNum.toDouble / (1 << kShift)

  /** The run-time parameters after reset, with another Harris threshold if given. */
  def defaultParams: CornerParams = params(defaultThreshold)
  def params(threshold: Long): CornerParams = CornerParams(threshold, segment.map(_.defaultThreshold))

  // Worst cases, in the integer units of each stage.
  val gradMax: BigInt = 4 * 255
  val productMax: BigInt = gradMax * gradMax
  val columnSumMax: BigInt = productMax * binomialSum
  val windowSumMax: BigInt = columnSumMax * binomialSum
  val windowedMax: BigInt = (windowSumMax + (BigInt(1) << windowShift >> 1)) >> windowShift
  val traceMax: BigInt = 2 * windowedMax
  val detMax: BigInt = windowedMax * windowedMax
  val kTrace2Max: BigInt = (traceMax * traceMax * kNum) >> kShift

  def gradWidth: Int = bitsSigned(gradMax)
  def squareWidth: Int = bitsUnsigned(productMax)
  def crossWidth: Int = bitsSigned(productMax)
  def columnSquareWidth: Int = bitsUnsigned(columnSumMax)
  def columnCrossWidth: Int = bitsSigned(columnSumMax)
  def windowSquareWidth: Int = bitsUnsigned(windowSumMax)
  def windowCrossWidth: Int = bitsSigned(windowSumMax)
  def sSquareWidth: Int = bitsUnsigned(windowedMax)
  def sCrossWidth: Int = bitsSigned(windowedMax)
  def traceWidth: Int = bitsUnsigned(traceMax)
  def kTrace2Width: Int = bitsUnsigned(kTrace2Max)
  def detWidth: Int = bitsSigned(detMax)

  /** R lies in [-kTrace2Max - detMax, detMax]. */
  def responseWidth: Int = bitsSigned(detMax + kTrace2Max)

  /** A positive R is at most det <= windowedMax^2. */
  def scoreWidth: Int = bitsUnsigned(detMax >> scoreShift)
  require(scoreWidth <= 32, s"scores need $scoreWidth bits; raise scoreShift so that they fit the 32-bit threshold")
}

object HarrisConfig {
  val binomial: Seq[Int] = Seq(1, 6, 15, 20, 15, 6, 1)
  val binomialSum: Int = binomial.sum

  /** Context the detector needs around a corner: Sobel 1 + window 3 + non-maximum suppression 1. */
  val reach: Int = 5

  /** Raw rows the detector reads at once: the 7 rows of gradients, each needing one row above and below. */
  val rawRows: Int = 9
  def bitsUnsigned(max: BigInt): Int = max.bitLength max 1
  def bitsSigned(maxAbs: BigInt): Int = maxAbs.bitLength + 1
}

/** Run-time parameters of the corner detector and the feature budget (registers of `OrbTop`).
  * @param threshold        a candidate is a corner when its Harris score exceeds this (the budget's minimum score)
  * @param segmentThreshold the segment test's intensity threshold t, or None for no segment test (every pixel a
  *                         candidate: pure Harris maxima)
  * @param target           the feature budget: features per frame (see `BudgetConfig`) */
final case class CornerParams(
    threshold: Long,
    segmentThreshold: Option[Int],
    target: Int = BudgetConfig().defaultTarget
) {
  require(threshold >= 0 && threshold <= 0xffffffffL, "the Harris threshold is a 32-bit register")
  require(segmentThreshold.forall(t => t >= 0 && t <= 255), "the segment threshold is 0..255")
  require(target >= 0 && target <= BudgetConfig.targetMax, s"the target is 0..${BudgetConfig.targetMax}")
}

/** The feature budget: which corners become features, so that every frame gives a bounded, spread set of the
  * strongest corners and the engines behind it can never fall behind, whatever the input.
  *
  * Rule (`orb.model.BudgetModel` is its specification):
  *  1. Cells. The frame is cut into cells of `cellWidth` columns x `cellHeight` rows (aligned to x = 0, y = 0);
  *     of the corners of a cell only the `perCell` strongest survive, ranked by their score's level at
  *     `rankFracBits` (the leading one's position and the bits after it: each octave in 16 parts by default, so a
  *     cell's lists compare 9 bits instead of the default scores' 27; the first in raster order on ties). This
  *     bounds the density by construction, so that the descriptor engine and the matcher serve every survivor at
  *     one pixel per clock for any line length and no blanking at all (`OrbConfig.budgetService` checks it for
  *     every line length; lines too short for `perCell` get fewer per cell, `OrbConfig.perCellFor`).
  *  2. Frame target. The cell winners are ranked in score levels (the leading one's position and the
  *     `levelFracBits` bits after it: each octave in four equal parts by default). From the winners' level
  *     histogram of a good frame the core takes for the next frame the cut level L and remainder r that give
  *     exactly `target` features: every winner above level L, the first r in raster order at level L. A frame
  *     never gets more than `target` features (winners past it are deselected); with no history (after reset) the
  *     first `target` winners in raster order are taken.
  * So a still scene gives exactly min(target, winners) features from its second frame on; in video the cut
  * follows the scene one frame late. A corner that does not become a feature is deselected and counted.
  *
  * Why these cells: a cell must be complete (its last corner detected, `HarrisConfig.reach` rows later) before
  * the orientation of its first row starts (row y + 15, the raw buffer's 31 rows), so at most 8 rows tall; the
  * engines' slack of 8 rows then allows about one corner per 256 pixels (`OrbConfig.budgetService`), and 4 rows by
  * 256 columns with 4 corners each stays within that, lets corners cluster (texture is rarely even) and needs at
  * most 8 orientation slots (a row's corners within 31 columns come from two cells at most). Cells of 64 columns
  * with one corner each have the same bound but keep far fewer corners where texture is uneven.
  *
  * @param defaultTarget the target after reset: 500, OpenCV's `nfeatures` default, below the keyframe store's
  *                      512 entries so that a keyframe is always stored whole */
case class BudgetConfig(
    cellWidth: Int = 256,
    cellHeight: Int = 4,
    perCell: Int = 4,
    levelFracBits: Int = 2,
    rankFracBits: Int = 4,
    defaultTarget: Int = 500
) {
  require(isPow2(cellWidth) && isPow2(cellHeight), "cells are powers of two wide and tall")
  require(
    cellWidth >= 2 * OrbDescriptorConfig.patchRadius + 1,
    "cells at least 31 px wide: a row's corners within 31 columns then come from two cells at most"
  )
  require(
    cellHeight + HarrisConfig.reach + 1 <= OrbDescriptorConfig.patchRadius - 1,
    "a cell must be complete before the orientation of its first row starts (row y + 15)"
  )
  require(perCell >= 1 && perCell <= 16)
  require(levelFracBits >= 0 && levelFracBits <= 4)
  require(rankFracBits >= 0 && rankFracBits <= 8)
  require(rankFracBits >= levelFracBits, "a winner's level is its rank's leading bits")
  require(defaultTarget >= 0 && defaultTarget <= BudgetConfig.targetMax)
  def cellShift: Int = log2Up(cellWidth)
  def bandShift: Int = log2Up(cellHeight)
  def cellsPerRow(maxWidth: Int): Int = (maxWidth + cellWidth - 1) / cellWidth

  /** A band's winners are final when the first pixel of this row (relative to the band's end) is processed: its
    * last corner leaves the detector `reach` rows later, and one row more covers the detector's latency. */
  def emitRowOffset: Int = HarrisConfig.reach + 1
  def levels(scoreWidth: Int): Int = scoreWidth << levelFracBits
  def levelWidth(scoreWidth: Int): Int = log2Up(levels(scoreWidth))
  def rankWidth(scoreWidth: Int): Int = log2Up(scoreWidth << rankFracBits)

  /** Cells of width W whose columns meet the corners' columns [border, W - 1 - border]. */
  def cellsWithCorners(width: Int, border: Int): Int =
    if (width < 2 * border + 1) 0 else (width - 1 - border) / cellWidth - border / cellWidth + 1
}

object BudgetConfig {
  val targetWidth: Int = 16
  val targetMax: Int = (1 << targetWidth) - 1
}

/** OpenCV's FAST segment test as a corner candidate filter: a pixel passes when `arc` contiguous pixels of the
  * 16 on the radius-3 Bresenham circle around it are all brighter than centre + t, or all darker than centre - t.
  *
  * Why: Harris maxima alone sit inside the corner's blob, where the windowed response peaks, and that place moves
  * when the view changes; the segment test pins candidates to the corner point itself, as in OpenCV's ORB (FAST
  * candidates ranked by Harris). On graf1 -> graf3 (a 30 degree viewpoint change) this lifts the inliers of the
  * same number of matches above OpenCV single-scale ORB's; see the README. Cost: a 7x7 window of registers on the
  * raw rows Harris already reads, 32 comparators and 32 `arc`-input ANDs; no memory.
  *
  * @param arc              contiguous circle pixels required (OpenCV's FAST-9: 9; 9..12 as FAST's variants)
  * @param defaultThreshold t after reset (OpenCV's FAST default, 20) */
case class SegmentTestConfig(arc: Int = 9, defaultThreshold: Int = 20) {
  require(arc >= 9 && arc <= 12, "FAST's segment tests need 9 to 12 contiguous pixels of 16")
  require(defaultThreshold >= 0 && defaultThreshold <= 255)
}

object SegmentTestConfig {
  val radius: Int = 3

  /** the pixels' and the threshold's width */
  val valueWidth: Int = 8

  /** a pixel and the centre less the threshold as signed numbers (a sign bit and a bit of headroom over a
    * difference of two values) */
  val signedWidth: Int = valueWidth + 2

  /** copies of the centre's thresholds, each compared with an arc of the circle */
  val thresholdCopies: Int = 4

  /** The 16 circle offsets (dx, dy) in circular order, as OpenCV's FAST (dy > 0 is down). */
  val circle: Seq[(Int, Int)] = Seq(
    (0, -3),
    (1, -3),
    (2, -2),
    (3, -1),
    (3, 0),
    (3, 1),
    (2, 2),
    (1, 3),
    (0, 3),
    (-1, 3),
    (-2, 2),
    (-3, 1),
    (-3, 0),
    (-3, -1),
    (-2, -2),
    (-1, -3)
  )
}

/** ORB descriptor: orientation by intensity centroid, rotated BRIEF on a smoothed image.
  *
  * @param angleBins        orientation bins over 360 degrees; a multiple of 8 so that the octant folding of the
  *                         angle search lands on bin centres. Measured against OpenCV's own angle and descriptor
  *                         (`orb.sim.OrbFidelity`): 64 bins (the paper's) differ by 8.6-9.8 bits of 256, 256 bins by
  *                         2.6-3.5, 512 bins by 1.5-2.1; 512 costs one more step of the angle search and
  *                         a 512-entry cos/sin table, nothing per pixel.
  * @param tanFracBits      fraction bits of the bin-boundary tangents the angle search compares against
  * @param rotationFracBits fraction bits of the per-bin cos/sin used to rotate the test pattern
  * @param cornerQueueDepth selected corners waiting for the rows of their orientation patch (the budget's bands
  *                         from their emission to the orientation of their last row: `OrbConfig` checks the depth)
  * @param slackRows        rows after its patch is complete during which a corner's descriptor may still be
  *                         computed (each costs one more smoothed row of memory); a corner not done by then is
  *                         dropped and counted
  * @param readyQueueDepth  oriented corners waiting for a descriptor engine (checked as the corner queue)
  */
case class OrbDescriptorConfig(
    angleBins: Int = 512,
    tanFracBits: Int = 18,
    rotationFracBits: Int = 16,
    cornerQueueDepth: Int = 64,
    slackRows: Int = 7,
    readyQueueDepth: Int = 128
) {
  require(angleBins >= 8 && angleBins % 8 == 0, "angleBins must be a multiple of 8")
  require(cornerQueueDepth >= 2 && slackRows >= 1 && readyQueueDepth >= 2)

  /** Smoothed rows kept: the 37 a descriptor reads plus `slackRows` in which it may still be computed. */
  def smoothedRows: Int = 2 * OrbDescriptorConfig.sampleReach + 1 + slackRows
  require(tanFracBits >= 8 && tanFracBits <= 30 && rotationFracBits >= 8 && rotationFracBits <= 30)
  def binDegrees: Double = 360.0 / angleBins
  def binsPerOctant: Int = angleBins / 8
  def binsPerQuadrant: Int = angleBins / 4
  def binWidth: Int = log2Up(angleBins)

  /** tan of the boundary between bins j and j + 1 of the first octant, scaled 2^tanFracBits (the angle search's
    * table) */
  val boundaryTangents: IndexedSeq[Long] =
    (0 until binsPerOctant).map(j => math.round(math.tan(math.toRadians((j + 0.5) * binDegrees)) * (1L << tanFracBits)))

  /** Banks of the smoothed-row store: two ring slots each (the last one alone when the count is odd). */
  def smoothedBanks: Int = (smoothedRows + 1) / 2

  /** cos and sin of bin b's angle, scaled 2^rotationFracBits: cos of bins 0..a quadrant, the rest by symmetry (so
    * the hardware keeps a quarter of the table). */
  val quarterCos: IndexedSeq[Long] = (0 to binsPerQuadrant).map { k =>
    math.round(math.cos(math.toRadians(k * binDegrees)) * (1L << rotationFracBits).toDouble)
  }
  def cosSin(bin: Int): (Long, Long) = {
    val q = bin / binsPerQuadrant
    val r = bin % binsPerQuadrant
    val (c, s) = (quarterCos(r), quarterCos(binsPerQuadrant - r))
    q match {
      case 0 => (c, s)
      case 1 => (-s, c)
      case 2 => (-c, -s)
      case _ => (s, -c)
    }
  }
  require(
    (0 until angleBins).forall { b =>
      val t = math.toRadians(b * binDegrees)
      val scale = (1L << rotationFracBits).toDouble
      cosSin(b) == ((math.round(math.cos(t) * scale), math.round(math.sin(t) * scale)))
    },
    "the quarter table must give every bin's rounded cos and sin"
  )
}

object OrbDescriptorConfig {

  /** rBRIEF tests, one bit each; OpenCV's descriptor holds them in bytes, test i in byte i / 8, bit i % 8 */
  val descriptorBits: Int = 256
  val descriptorBytes: Int = descriptorBits / 8

  /** Radius of OpenCV's orientation patch, and its half widths per row (`umax`, rows 0..15). */
  val patchRadius: Int = 15
  val umax: Seq[Int] = Seq(15, 15, 15, 15, 14, 14, 14, 13, 13, 12, 11, 10, 9, 8, 6, 3)

  /** The rotated tests reach at most 18 px (|(x, y)| <= 18.39 before rounding). */
  val sampleReach: Int = 18

  /** OpenCV's own 8-bit kernel for GaussianBlur(7x7, sigma 2): the Gaussian quantised to 1/256 with error
    * diffusion, so that it sums to exactly 256 (used per pass: the 2-D weights sum to 2^16). */
  val blurKernel: Seq[Int] = Seq(18, 34, 48, 56, 48, 34, 18)
  val blurRadius: Int = 3

  /** A corner's descriptor can start when raw row cy + startRowOffset begins: its 37 smoothed rows are complete. */
  val startRowOffset: Int = sampleReach + blurRadius + 1

  /** For a column |u| of the orientation patch, the rows |v| <= vmax(|u|) belong to the disc. */
  def vmax(u: Int): Int = umax.lastIndexWhere(_ >= u.abs)
}

/** Keyframe store and Hamming matcher.
  *
  * @param storeCapacity keyframe features kept: the strongest `storeCapacity` of the keyframe by Harris score
  *                      (the rest are counted); each takes 278 bits (x, y, descriptor) and 32 bits of cross-check state,
  *                      which hold its score while the keyframe loads
  * @param comparators   Hamming distances computed per clock (P): a live feature takes storeCapacity / P clocks
  *                      plus the pipeline latency. The store is P RAMs of storeCapacity / P x 278 bits, so the
  *                      default 512 / 4 = 128 deep fills the M4K's 128 x 36 shape exactly (32 M4K)
  * @param popcountChunkBits the popcount's first step counts the ones of chunks this wide (4: one LUT4 per count bit)
  * @param popcountLevelsPerStage adder levels of the 256-bit popcount tree between pipeline registers
  * @param ratioFracBits fraction bits of the ratio-test factor r (best < r * second), a run-time value below 2
  * @param outputDepth   correspondences the output FIFO holds
  * @param outputTimeout clocks the matcher waits for a consumer that keeps the FIFO full before it drops (and
  *                      counts) correspondences instead (a slower consumer loses nothing)
  * @param defaultHammingThreshold, defaultRatio, defaultRatioTest, defaultCrossCheck the run-time parameters'
  *                      values after reset (registers of `OrbTop`)
  */
case class MatcherConfig(
    storeCapacity: Int = 512,
    comparators: Int = 4,
    popcountChunkBits: Int = 4,
    popcountLevelsPerStage: Int = 1,
    ratioFracBits: Int = 8,
    outputDepth: Int = 64,
    outputTimeout: Int = 4096,
    defaultHammingThreshold: Int = 64,
    defaultRatio: Int = 205,
    defaultRatioTest: Boolean = false,
    defaultCrossCheck: Boolean = true
) {
  require(storeCapacity >= 1 && ratioFracBits >= 1 && ratioFracBits <= 16)
  require(
    comparators >= 1 && isPow2(comparators) && storeCapacity % comparators == 0,
    "comparators must be a power of two dividing storeCapacity"
  )
  require(popcountLevelsPerStage >= 1 && outputTimeout >= 1)
  require(
    isPow2(popcountChunkBits) && popcountChunkBits <= OrbDescriptorConfig.descriptorBits,
    "popcountChunkBits must be a power of two"
  )
  require(
    popcountChunkBits < OrbDescriptorConfig.descriptorBits,
    "the popcount adds at least two chunks' counts (its last stage is an adder)"
  )
  require(outputDepth >= MatcherConfig.pushLatency + 2, "the output FIFO must hold the sweep's pushes in flight")
  require(
    defaultHammingThreshold >= 0 && defaultHammingThreshold <= 256 && defaultRatio >= 0 && defaultRatio < (2 << ratioFracBits)
  )

  /** the run-time parameters after reset (the registers of `OrbTop`), as the model takes them */
  def defaultParams: orb.model.MatchParams =
    orb.model.MatchParams(
      defaultHammingThreshold,
      if (defaultRatioTest) Some(defaultRatio) else None,
      defaultCrossCheck
    )
  def groups: Int = storeCapacity / comparators
  def ratioWidth: Int = ratioFracBits + 1

  /** clocks a live feature holds the matcher: the scan (its groups rounded up to pairs), the RAM read
    * (`MatcherConfig.readLatency`), the popcount, the lane register, the merge levels (two steps each), the pairs'
    * and the accumulation's comparisons and choices (5), the best entry's position read back
    * (`MatcherConfig.decideLatency`, the decision in its last clock). A keyframe feature that replaces an entry holds
    * it no longer: the rescan reads every group once, its pairs as the scan's. */
  def clocksPerFeature: Int =
    (groups + 1) / 2 * 2 + MatcherConfig.readLatency + MatcherConfig.popcountStages(this) + 1 +
      2 * log2Up(comparators) + 5 + MatcherConfig.decideLatency

  /** an upper bound on the clocks a frame's end item holds the matcher: a live frame's cross-checked entries leave
    * one per clock (storeCapacity), a keyframe's cross-check words are cleared one group per clock, plus the
    * pipeline */
  def frameEndClocks: Int = storeCapacity + groups + 32
}

object MatcherConfig {

  /** RAMs per lane of the store: each holds a slice of every entry, read through its own address register */
  val storeParts: Int = 2

  /** Hamming distances 0..256, and 257 for "none" (no second entry; no live feature yet) */
  val distanceWidth: Int = log2Up(OrbDescriptorConfig.descriptorBits + 2)
  val none: Int = OrbDescriptorConfig.descriptorBits + 1

  /** clocks from a read's address to its data: the address register (each lane's own), the RAM, its output register */
  val readLatency: Int = 3

  /** clocks from a read's address to its cross word: a plain register behind the RAM's output register (the rescan
    * and the sweep that read it lie apart from the RAM; the scan's comparison reads the RAM's register, a clock
    * before) */
  val crossLatency: Int = readLatency + 1

  /** clocks from a scan's last accumulation to its decision: the best entry's group into the scan's address, the
    * read to its lane's word (`crossLatency`), the lane's register (the ratio's product, registered twice, is ready
    * long before) */
  val decideLatency: Int = 1 + crossLatency + 1

  /** clocks from the sweep's read of an entry to its correspondence's push into the output FIFO (the entry zeroed
    * unless read into a register of its lane, the lanes ORed into a register, then the push's register) */
  val pushLatency: Int = crossLatency + 3

  /** Parts of the rank comparisons of the rescan and the replacement, side by side (`Arith.comparedInParts`): a
    * part's equality one LUT level less than in halves. */
  val rankParts: Int = 3

  /** Bits of a score's rank after its leading one. The store keeps the strongest features by rank
    * (`orb.model.MatcherModel.rank`), the score's level as the budget forms it (`BudgetModel.levelOf`) with finer
    * steps: it orders as the score does but for ties within about 2^-8 of each other, and the replacement's and the
    * rescan's registers and comparisons hold half the score's bits. */
  val rankFracBits: Int = 8

  /** the rank's bits: the leading one's position above `rankFracBits` */
  def rankWidth(h: HarrisConfig): Int = log2Up(h.scoreWidth << rankFracBits)

  /** Parts of a copy of the live descriptor, each loaded by its own copy of the idle flag. */
  val liveDescriptorParts: Int = 8

  /** Lanes that share a copy of the live descriptor: one, each copy beside its lane's RAMs (the lanes lie apart; the
    * copies are flip-flops alone in their LEs, paid for by the input register the matcher no longer has). */
  val lanesPerLiveCopy: Int = 1

  /** The popcount adds the counts of its chunks in a binary tree of this many levels. */
  def treeLevels(m: MatcherConfig): Int = log2Up(OrbDescriptorConfig.descriptorBits / m.popcountChunkBits)
  def popcountStages(m: MatcherConfig): Int =
    2 + (treeLevels(m) + m.popcountLevelsPerStage - 1) / m.popcountLevelsPerStage

  /** The Hamming distance of `a` and `b` (256 bits), after `popcountStages` clocks: their xor registered (beside the
    * lane's logic: `a` comes from a RAM's output register), the chunk counts registered, then a register every
    * `popcountLevelsPerStage` levels of the adder tree, and after the last (`distance`). */
  class Hamming(a: Bits, b: Bits, m: MatcherConfig) extends Area {
    import spinal.lib._
    val differ = RegNext(a ^ b)
    private var v: Seq[UInt] = differ.subdivideIn(m.popcountChunkBits bits).map(c => RegNext(CountOne(c))).toSeq
    private val levels = treeLevels(m)
    // the last stage's levels: the stages before it end on a multiple of `popcountLevelsPerStage`
    private val lastStage = (levels - 1) % m.popcountLevelsPerStage + 1
    for (level <- 1 to levels - lastStage) {
      v = v.grouped(2).map(g => g(0) +^ g(1)).toSeq
      if (level % m.popcountLevelsPerStage == 0) v = v.map(RegNext(_))
    }

    /** the last stage's sum, before its register */
    val sum = v.reduceBalancedTree(_ +^ _).resize(distanceWidth)
    val distance = RegNext(sum)

    /** whether the distance is below `limit` (a value a clock before the distance's), registered beside it: compared
      * with the last stage's sum (a short carry chain behind its adder), so no comparison waits for the distance's
      * register */
    def below(limit: UInt): Bool = RegNext(sum < limit)
  }
}

/** The whole core: frame, detector, feature budget, descriptor unit and matcher, and the checks that tie them together
  * (the budget's service bound, the queue depths, the row tags). */
case class OrbConfig(
    frame: FrameConfig = FrameConfig(),
    harris: HarrisConfig = HarrisConfig(),
    descriptor: OrbDescriptorConfig = OrbDescriptorConfig(),
    matcher: MatcherConfig = MatcherConfig(),
    budget: BudgetConfig = BudgetConfig()
) {
  // Every sample (18 px + 3 px of blur) inside the image, and row cy + 22, where a descriptor starts, in the frame.
  require(
    harris.border >= OrbDescriptorConfig.startRowOffset && harris.border >= OrbDescriptorConfig.patchRadius,
    s"the border must be at least ${OrbDescriptorConfig.startRowOffset}: a corner's descriptor starts at row y + 22"
  )
  // A corner's row tag is compared with the smoothed stream's row count from the orientation of its last row (row
  // cy + 15, 7 rows before its descriptor may start) until its descriptor starts or it is refused: at most
  // `slackRows` rows after the start row, plus a clock for each corner ahead of it in the ready queue. Half the tag's
  // range must exceed that, so the difference never wraps.
  require(
    (1 << (frame.rowTagWidth - 1)) > OrbDescriptorConfig.startRowOffset + descriptor.slackRows + descriptor.readyQueueDepth,
    s"rowTagWidth ${frame.rowTagWidth} is too narrow for the descriptor unit's wait"
  )
  require(frame.frameTagWidth >= 2, "a corner's frame tag must tell its frame from the next and the one before")

  /** Raw-image rows kept by the shared line buffer: as many as its most demanding reader needs (the orientation
    * disc, 31 rows; Harris reads the newest 9, the smoother the newest 7). */
  def rawRows: Int = HarrisConfig.rawRows max (2 * OrbDescriptorConfig.patchRadius + 1)
  def maxWidth: Int = frame.maxWidth

  /** The run-time parameters after reset: the detector's and the budget's target. */
  def defaultParams: CornerParams = harris.defaultParams.copy(target = budget.defaultTarget)

  // The feature budget's cells against what the stages behind them can serve (see `budgetService`).
  require(
    harris.border >= budget.cellHeight + budget.emitRowOffset,
    "every band with corners must be emitted before its frame ends"
  )
  require(
    perCellFor(frame.maxWidth) == budget.perCell,
    s"the stages behind the feature budget cannot serve ${budget.perCell} corners per cell in ${frame.maxWidth}-px lines: " +
      budgetService(frame.maxWidth, budget.perCell).getOrElse("")
  )

  /** The most corners the budget lets through per band of `cellHeight` rows, in the longest lines. */
  def budgetPerBand: Int = budget.perCell * budget.cellsWithCorners(frame.maxWidth, harris.border)

  /** Bands whose corners wait in the orientation queue at once: from a band's emission (row band end +
    * `emitRowOffset`) to the orientation of its last row (row + 15); and in the descriptor unit's ready queue: from
    * the orientation of a row (row + 15) until its descriptor must start (row + 22 + `slackRows`). */
  def bandsQueued(fromRow: Int, toRow: Int): Int = (toRow - fromRow) / budget.cellHeight + 2
  require(
    descriptor.cornerQueueDepth >= budgetPerBand * bandsQueued(
      budget.cellHeight + budget.emitRowOffset,
      budget.cellHeight - 1 + OrbDescriptorConfig.patchRadius
    ),
    "the orientation's corner queue is too short for the budget's bands"
  )
  require(
    descriptor.readyQueueDepth >= budgetPerBand * bandsQueued(
      OrbDescriptorConfig.patchRadius,
      OrbDescriptorConfig.startRowOffset + descriptor.slackRows
    ),
    "the descriptor unit's ready queue is too short for the budget's bands"
  )

  /** Clocks the descriptor stage needs per feature in a busy stretch: the matcher's scan, or the engine's front end
    * and the dispatch, whichever is longer (the engine starts a corner while the one before drains); a keyframe
    * feature replacing a weaker entry takes less. */
  def clocksPerFeature: Int =
    matcher.clocksPerFeature max (DescriptorUnit.fetchClocks(descriptor) + DescriptorUnit.dispatchClocks)
  // The bin's search at the ready queue's head prepares the next corner while the engine fetches the one before
  // (a group of tests per clock at the fastest), so the dispatch waits for it no longer than `windowClocks` counts.
  require(
    DescriptorUnit.headClocks(descriptor) <= orb.model.DescriptorSchedule.groups,
    "the angle search must find a bin faster than the engine takes corners"
  )

  /** The latest the last of `n` corners released together into an idle descriptor unit has its descriptor, in
    * clocks after their release. One engine with two slots: it starts a corner `DescriptorUnit.dispatchClocks` after
    * its release, after the front end has fetched the previous corner (at most `DescriptorUnit.fetchClocks` after
    * that one's start) and after the corner two before has handed its feature on (its slot); a corner finishes at
    * most `DescriptorUnit.maxClocks` after its start; a finished feature is handed on once the matcher has taken the
    * one before (no credit for the output's registers), the matcher taking it `DescriptorUnit.handOnClocks` later
    * at the earliest and one feature per `matcher.clocksPerFeature`. Every time here only grows when a corner comes
    * later or takes longer (max-plus), so corners released together bound any window of corners released over time. */
  def windowClocks(n: Int): Long = {
    val toFetched = DescriptorUnit.fetchClocks(descriptor).toLong
    val toFinished = DescriptorUnit.maxClocks(descriptor).toLong
    val gap = DescriptorUnit.dispatchClocks.toLong
    val never = Long.MinValue / 4
    var fetched = never
    var handedOn = Vector(never, never) // the corner two before, the one before
    var taken = never
    var finished = 0L
    for (_ <- 0 until n) {
      val start = gap max (fetched + gap) max (handedOn.head + gap)
      fetched = start + toFetched
      finished = start + toFinished
      val handed = (finished max taken) + 1
      taken = (handed + DescriptorUnit.handOnClocks) max (taken + matcher.clocksPerFeature)
      handedOn = Vector(handedOn(1), handed)
    }
    finished
  }

  /** Why no corner that the budget selects can be dropped for lack of time in lines of `w` pixels with `k` corners
    * per cell, with no blanking at all (blanking only adds time). A corner of row y is released when row y + 22
    * starts and must be finished before `slackRows` more rows have started. Corners are served in raster order; if
    * corners i..j (n of them) are released within rows y .. y + d, corner j is finished at most `windowClocks(n)`
    * after corner i's release. At most k corners per cell, so n <= k x cells(w) x (bands met by d + 1 rows); every
    * band must be served within its own rows on average; a band's winners leave the budget in time; and between
    * frames the matcher also sweeps its store, which must end before the next frame's first corner is released.
    * None when served, else why not. */
  def budgetService(w: Int, k: Int): Option[String] = {
    val tDesc = DescriptorUnit.maxClocks(descriptor)
    val s = clocksPerFeature
    val ch = budget.cellHeight
    val slack = descriptor.slackRows
    val perBand = k.toLong * budget.cellsWithCorners(w, harris.border)
    val windows = (0 to 4 * ch + 2 * slack).iterator.flatMap { d =>
      val n = perBand * ((d + ch - 1) / ch + 1)
      val finish = windowClocks(n.toInt)
      if (finish < (d + slack).toLong * w) None
      else Some(s"W = $w: $n budget corners in ${d + 1} rows need $finish clocks, the slack gives ${(d + slack) * w}")
    }
    val steady = if (perBand * s <= ch.toLong * w) None
    else Some(s"W = $w: $perBand corners per band of $ch rows need ${perBand * s} clocks, the band has ${ch * w}")
    // A band's winners leave one per `FeatureBudget.winnerClocks` from its emission row: done before the band two
    // later (same bank) gets its first corner, and before the band's first row needs its orientation.
    val emitting = FeatureBudget.emissionClocks(perBand, budget.perCell)
    val emitRows =
      (budget.cellHeight - 1) min (OrbDescriptorConfig.patchRadius - budget.cellHeight - budget.emitRowOffset)
    val emission = if (emitting < emitRows.toLong * w) None
    else Some(s"W = $w: a band's $perBand winners leave in $emitting clocks, more than $emitRows rows")
    val gapRows = harris.border + OrbDescriptorConfig.startRowOffset + 1 - slack
    val between = if (matcher.frameEndClocks + 2L * s + tDesc < gapRows.toLong * w) None
    else Some(s"W = $w: the matcher's end of frame does not fit between two frames' corners")
    // A frame that ended early leaves its queued corners to be refused when the next frame starts, one per angle
    // search (`DescriptorUnit.headClocks`): all of them before that frame's first corner is due.
    val queued = perBand * bandsQueued(OrbDescriptorConfig.patchRadius, OrbDescriptorConfig.startRowOffset + slack)
    val firstDue = (harris.border + OrbDescriptorConfig.startRowOffset).toLong * w
    val refusals =
      if (queued * DescriptorUnit.headClocks(descriptor) < firstDue) None
      else Some(s"W = $w: $queued corners of a frame that ended early are not refused before the next frame's are due")
    (windows ++ steady.iterator ++ emission.iterator ++ between.iterator ++ refusals.iterator).nextOption()
  }

  /** Corners kept per cell in lines of `w` pixels: `perCell`, or fewer where the lines are too short for the engines
    * to serve that many (`budgetService`); 0 (no feature at all) in frames too narrow even for one. */
  def perCellFor(w: Int): Int = perCellTable.getOrElse(w, 0)
  private lazy val perCellTable: Map[Int, Int] =
    ((2 * harris.border + 1) to frame.maxWidth).map(w =>
      w -> (budget.perCell to 1 by -1).find(k => budgetService(w, k).isEmpty).getOrElse(0)
    ).toMap

  /** Where `perCellFor` changes: (from width, corners per cell), ascending from the narrowest frame with a corner;
    * narrower frames have none. */
  lazy val perCellSteps: Seq[(Int, Int)] = {
    val ws = (2 * harris.border + 1) to frame.maxWidth
    ws.map(w => (w, perCellFor(w))).foldLeft(Vector[(Int, Int)]()) { case (acc, (w, k)) =>
      if (acc.lastOption.forall(_._2 != k)) acc :+ (w -> k) else acc
    }
  }
}

object OrbConfig {

  /** DE2-70 / Cyclone II EP2C70 target, 1024-pixel lines. */
  val default: OrbConfig = OrbConfig()

  /** 640-pixel lines (VGA cameras): smaller line buffers. */
  val vga: OrbConfig = OrbConfig(frame = FrameConfig(maxWidth = 640, maxHeight = 1023))

  val presets: Map[String, OrbConfig] = Map("default" -> default, "vga" -> vga)
}
