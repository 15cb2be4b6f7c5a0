package orb

import spinal.core._

// Every bundle that crosses a block boundary, in the order of the flow (pixel beat, tracked pixel, line column,
// smoothed pixel, corner, oriented corner, feature, correspondence), then the status and control bundles. A bundle
// that has a twin in the golden model (`orb.model`) is named after it with `Hw`.

/** One pixel of the camera stream; a clock with `valid` low is blanking (any length, including none).
  * The markers follow the AXI4-Stream video convention: `sof` on the first pixel of a frame (it also samples
  * `keyframe`), `eol` on the last pixel of every line. Width and height are learned from the markers. */
case class PixelBeat() extends Bundle {
  val luma = UInt(8 bits)
  val sof = Bool()
  val eol = Bool()
  val keyframe = Bool()
}

/** A pixel with its position, as the frame tracker hands it to the line buffer and the detectors. */
case class TrackedPixel(c: FrameConfig) extends Bundle {
  val luma = UInt(8 bits)
  val x, y = c.coord()

  /** part of a processed frame, and no fault in that frame up to and including this pixel */
  val active = Bool()

  /** the keyframe flag of this pixel's frame (sampled at its start of frame) */
  val keyframe = Bool()

  /** the beat that closes the last processed frame (one beat per processed frame; its `keyframe` may already be the
    * next frame's) */
  val end = FrameEndMark()

  /** where the pixel is in the stream, without its value */
  def place: PixelPlace = {
    val p = PixelPlace(c)
    p.assignSomeByName(this)
    p
  }
}

/** A tracked pixel's place in the stream without its value: what a block that reads the pixel's column (the value
  * is in it) delays beside its own sums. */
case class PixelPlace(c: FrameConfig) extends Bundle {
  val x, y = c.coord()
  val active = Bool()
  val keyframe = Bool()
  val end = FrameEndMark()
}

case class LineColumn(f: FrameConfig, rows: Int) extends Bundle {
  val pixel = TrackedPixel(f)

  /** 0 = the current row */
  val column = Vec(UInt(8 bits), rows)
}

/** A smoothed pixel for the descriptor's samples: the 7x7 OpenCV Gaussian of the raw pixel 3 rows above and
  * 3 columns left of the beat that completed its neighbourhood, with that beat's column and processed flag (what the
  * descriptor store needs of it: the rows are counted by their starts). */
case class SmoothedPixel(f: FrameConfig) extends Bundle {
  val x = f.coord()
  val active = Bool()
  val smoothed = UInt(8 bits)

  /** the pixel's position tested in the smoother, a clock ahead (the consumer's row and frame decisions then come
    * from registers): the first pixel of a processed row; the first of a frame (x = y = 0); a processed pixel that
    * carries a smoothed one (x >= `blurRadius`: `smoothed` is pixel (x - 3, y - 3)) */
  val rowStart, frameStart, holdsSmoothed = Bool()
}

case class CornerHw(c: FrameConfig, h: HarrisConfig) extends Bundle {
  val x, y = c.coord()
  val score = UInt(h.scoreWidth bits)
}

/** A corner with its intensity moments (its bin is found at the descriptor unit's queue: `AngleSearch`). */
case class OrientedCorner(f: FrameConfig, h: HarrisConfig) extends Bundle {
  val corner = CornerHw(f, h)
  val m10, m01 = SInt(OrientationUnit.momentWidth bits)

  /** the corner's row and frame on the stream, counted from reset (`RowClock`) */
  val rowTag = f.rowTag()
  val frameTag = f.frameTag()

  /** the corner's frame is a keyframe */
  val keyframe = Bool()

  /** not a corner: the end of a processed frame, after all of its corners */
  val end = FrameEndMark()
}

/** A finished ORB feature. `descriptor(i)` is test i: byte i/8, bit i%8 of OpenCV's descriptor. With `end.now`
  * set, the item is no feature but the end of a processed frame, after all of that frame's features. */
case class FeatureHw(f: FrameConfig, h: HarrisConfig, d: OrbDescriptorConfig) extends Bundle {
  val x, y = f.coord()
  val bin = UInt(d.binWidth bits)
  val score = UInt(h.scoreWidth bits)

  /** the score's rank (`orb.model.MatcherModel.rank`), what the matcher reads of it */
  val rank = UInt(MatcherConfig.rankWidth(h) bits)
  val descriptor = Bits(OrbDescriptorConfig.descriptorBits bits)

  /** the feature's frame is a keyframe (for a frame's end: that frame's, as `end.info.keyframe`) */
  val keyframe = Bool()

  /** not a feature: the end of a processed frame, after all of its features */
  val end = FrameEndMark()
}

/** A correspondence: a live feature at (liveX, liveY) matched to the keyframe feature at (keyX, keyY). */
case class CorrespondenceHw(f: FrameConfig) extends Bundle {
  val liveX, liveY, keyX, keyY = f.coord()
  val distance = UInt(MatcherConfig.distanceWidth bits)
}

// ---- status and control ----

/** How a processed frame ended (`orb.model.FrameEnd`): the payload of a stream of frame ends. */
case class FrameEndHw() extends Bundle {

  /** the frame completed without a fault */
  val ok = Bool()

  /** the keyframe flag sampled at that frame's start */
  val keyframe = Bool()
}

/** A frame end inside a stream of other items (pixels, corners, features), the one marker they all carry: `now` on
  * the item that ends a processed frame, `info` how that frame ended (`Option[FrameEnd]` in the model). */
case class FrameEndMark() extends Bundle {
  val now = Bool()
  val info = FrameEndHw()
}

case class FrameGeometry(c: FrameConfig) extends Bundle {
  val width, height = c.coord()
}

case class FrameCountersHw(c: FrameConfig) extends Bundle {
  val frames, badFrames, badLines = c.counter()
}

/** The corner detector's run-time parameters (`CornerParams` in the model). */
case class CornerParamsHw() extends Bundle {

  /** a candidate is a corner when its score is above this */
  val threshold = UInt(32 bits)

  /** only pixels that pass the segment test are candidates (ignored without `HarrisConfig.segment`) */
  val segmentTest = Bool()
  val segmentThreshold = UInt(SegmentTestConfig.valueWidth bits)

  /** the feature budget's target: features per frame */
  val target = UInt(BudgetConfig.targetWidth bits)
}

/** Run-time matching parameters (`orb.model.MatchParams` in hardware); sampled at the first item of each frame. */
case class MatchParamsHw(m: MatcherConfig) extends Bundle {
  val hammingThreshold = UInt(MatcherConfig.distanceWidth bits)
  val ratio = UInt(m.ratioWidth bits)
  val ratioTest, crossCheck = Bool()
}

case class MatcherStatus(f: FrameConfig) extends Bundle {

  /** features in the store now; keyframe features beyond the capacity (all keyframes so far) */
  val stored, storeOverflow = f.counter()

  /** correspondences pushed to the output FIFO; those dropped because it was full */
  val matches, matchDrops = f.counter()
}

case class CoreStatus(c: FrameConfig) extends Bundle {
  val frames, badFrames, badLines, corners, features = c.counter()

  /** corners the feature budget did not select (`BudgetConfig`'s rule) */
  val deselected = c.counter()

  /** selected corners that got no descriptor: a fault in their frame before their rows were complete, or (never by
    * design, see `OrbConfig.budgetService`; only a consumer that holds the output too long) no orientation slot, a full
    * queue, no engine in time */
  val featureDrops = c.counter()
}
