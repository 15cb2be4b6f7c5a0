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
  require(maxWidth < (1 << coordWidth) && maxHeight < (1 << coordWidth),
    s"coordWidth=$coordWidth cannot hold maxWidth=$maxWidth / maxHeight=$maxHeight")
  def addrWidth: Int = log2Up(maxWidth)
  def counterWidth: Int = 32
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
    defaultThreshold: Long = 1L << 14
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

/** Run-time parameters of the corner detector (registers of `OrbTop`).
  * @param threshold        a candidate is a corner when its Harris score exceeds this
  * @param segmentThreshold the segment test's intensity threshold t, or None for no segment test (every pixel a
  *                         candidate: pure Harris maxima) */
final case class CornerParams(threshold: Long, segmentThreshold: Option[Int]) {
  require(threshold >= 0 && threshold <= 0xffffffffL, "the Harris threshold is a 32-bit register")
  require(segmentThreshold.forall(t => t >= 0 && t <= 255), "the segment threshold is 0..255")
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
  /** The 16 circle offsets (dx, dy) in circular order, as OpenCV's FAST (dy > 0 is down). */
  val circle: Seq[(Int, Int)] = Seq((0, -3), (1, -3), (2, -2), (3, -1), (3, 0), (3, 1), (2, 2), (1, 3),
    (0, 3), (-1, 3), (-2, 2), (-3, 1), (-3, 0), (-3, -1), (-2, -2), (-1, -3))
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
  * @param orientationSlots corners of one row whose moments accumulate at the same time (a corner occupies a slot
  *                         while the 31 columns of its patch pass; corners closer than 31 px share the time)
  * @param cornerQueueDepth corners waiting for the rows of their orientation patch (about 10 rows of corners)
  * @param slackRows        rows after its patch is complete during which a corner's descriptor may still be
  *                         computed (each costs one more smoothed row of memory); a corner not done by then is
  *                         dropped and counted
  * @param readyQueueDepth  oriented corners waiting for a descriptor engine
  */
case class OrbDescriptorConfig(angleBins: Int = 512, tanFracBits: Int = 18, rotationFracBits: Int = 16,
                               orientationSlots: Int = 8, cornerQueueDepth: Int = 256,
                               slackRows: Int = 8, readyQueueDepth: Int = 128) {
  require(angleBins >= 8 && angleBins % 8 == 0, "angleBins must be a multiple of 8")
  require(orientationSlots >= 1 && cornerQueueDepth >= 2 && slackRows >= 1 && readyQueueDepth >= 2)
  /** Smoothed rows kept: the 37 a descriptor reads plus `slackRows` in which it may still be computed. */
  def smoothedRows: Int = 2 * OrbDescriptorConfig.sampleReach + 1 + slackRows
  require(tanFracBits >= 8 && tanFracBits <= 30 && rotationFracBits >= 8 && rotationFracBits <= 30)
  def binDegrees: Double = 360.0 / angleBins
  def binsPerOctant: Int = angleBins / 8
  def binWidth: Int = log2Up(angleBins)
}

object OrbDescriptorConfig {
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
  * @param popcountLevelsPerStage adder levels of the 256-bit popcount tree between pipeline registers
  * @param ratioFracBits fraction bits of the ratio-test factor r (best < r * second), a run-time value below 2
  * @param outputDepth   correspondences the output FIFO holds
  * @param outputTimeout clocks the matcher waits for a consumer that keeps the FIFO full before it drops (and
  *                      counts) correspondences instead (a slower consumer loses nothing)
  * @param defaultHammingThreshold, defaultRatio, defaultRatioTest, defaultCrossCheck the run-time parameters'
  *                      values after reset (registers of `OrbTop`)
  */
case class MatcherConfig(storeCapacity: Int = 512, comparators: Int = 4, popcountLevelsPerStage: Int = 2,
                         ratioFracBits: Int = 8, outputDepth: Int = 64, outputTimeout: Int = 4096,
                         defaultHammingThreshold: Int = 64, defaultRatio: Int = 205,
                         defaultRatioTest: Boolean = false, defaultCrossCheck: Boolean = true) {
  require(storeCapacity >= 1 && ratioFracBits >= 1 && ratioFracBits <= 16)
  require(comparators >= 1 && isPow2(comparators) && storeCapacity % comparators == 0,
    "comparators must be a power of two dividing storeCapacity")
  require(popcountLevelsPerStage >= 1 && outputDepth >= 2 && outputTimeout >= 1)
  require(defaultHammingThreshold >= 0 && defaultHammingThreshold <= 256 && defaultRatio >= 0 && defaultRatio < (2 << ratioFracBits))
  def groups: Int = storeCapacity / comparators
  def ratioWidth: Int = ratioFracBits + 1
  /** clocks a live feature holds the matcher: the scan, the RAM read, the popcount, the lane register, the merge
    * levels, the accumulation, the ratio product, one to decide */
  def clocksPerFeature: Int = groups + 1 + MatcherConfig.popcountStages(this) + 1 + log2Up(comparators) + 1 + 1 + 1
}

object MatcherConfig {
  /** Hamming distances 0..256, and 257 for "none" (no second entry; no live feature yet) */
  val distanceWidth: Int = 9
  val none: Int = 257
  /** The popcount adds 8-bit chunk counts (32 of them) in a binary tree of 5 levels. */
  val chunkBits: Int = 8
  val treeLevels: Int = log2Up(256 / chunkBits)
  def popcountStages(m: MatcherConfig): Int = 1 + (treeLevels + m.popcountLevelsPerStage - 1) / m.popcountLevelsPerStage

  /** Ones in `b` (256 bits), after `popcountStages` clocks: chunk counts registered, then a register every
    * `levelsPerStage` levels of the adder tree, and after the last. */
  def popCount(b: Bits, levelsPerStage: Int): UInt = {
    import spinal.lib._
    var v: Seq[UInt] = b.subdivideIn(chunkBits bits).map(c => RegNext(CountOne(c))).toSeq
    var level = 0
    while (v.size > 1) {
      v = v.grouped(2).map(g => g(0) +^ g(1)).toSeq
      level += 1
      if (level % levelsPerStage == 0 || v.size == 1) v = v.map(RegNext(_))
    }
    v.head.resize(distanceWidth)
  }
}

/** The whole core. Later stages (descriptor, store, matcher) add their blocks here. */
case class OrbConfig(frame: FrameConfig = FrameConfig(), harris: HarrisConfig = HarrisConfig(),
                     descriptor: OrbDescriptorConfig = OrbDescriptorConfig(), matcher: MatcherConfig = MatcherConfig()) {
  // Every sample (18 px + 3 px of blur) inside the image, and row cy + 22, where a descriptor starts, in the frame.
  require(harris.border >= OrbDescriptorConfig.startRowOffset && harris.border >= OrbDescriptorConfig.patchRadius,
    s"the border must be at least ${OrbDescriptorConfig.startRowOffset}: a corner's descriptor starts at row y + 22")
  /** Raw-image rows kept by the shared line buffer: as many as its most demanding reader needs (the orientation
    * disc, 31 rows; Harris reads the newest 9, the smoother the newest 7). */
  def rawRows: Int = HarrisConfig.rawRows max (2 * OrbDescriptorConfig.patchRadius + 1)
  def maxWidth: Int = frame.maxWidth
}

object OrbConfig {
  /** DE2-70 / Cyclone II EP2C70 target, 1024-pixel lines. */
  val default: OrbConfig = OrbConfig()
  /** 640-pixel lines (VGA cameras): smaller line buffers. */
  val vga: OrbConfig = OrbConfig(frame = FrameConfig(maxWidth = 640, maxHeight = 1023))

  val presets: Map[String, OrbConfig] = Map("default" -> default, "vga" -> vga)
}
