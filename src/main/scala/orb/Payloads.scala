package orb

import spinal.core._

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
  val x, y = UInt(c.coordWidth bits)
  /** part of a processed frame, and no fault in that frame up to and including this pixel */
  val active = Bool()
  /** the keyframe flag of this pixel's frame (sampled at its start of frame) */
  val keyframe = Bool()
  /** this beat closes the last processed frame (one beat per processed frame), described by `end` */
  val ends = Bool()
  val end = FrameEndInfo()
}

/** How a processed frame ended. */
case class FrameEndInfo() extends Bundle {
  /** the frame completed without a fault */
  val ok = Bool()
  /** the keyframe flag sampled at that frame's start */
  val keyframe = Bool()
}

case class FrameGeometry(c: FrameConfig) extends Bundle {
  val width, height = UInt(c.coordWidth bits)
}

case class FrameCountersHw(c: FrameConfig) extends Bundle {
  val frames, badFrames, badLines = UInt(c.counterWidth bits)
}

case class HarrisCorner(c: FrameConfig, h: HarrisConfig) extends Bundle {
  val x, y = UInt(c.coordWidth bits)
  val score = UInt(h.scoreWidth bits)
}

/** The corner detector's run-time parameters (`CornerParams` in the model). */
case class CornerControl() extends Bundle {
  /** a candidate is a corner when its score is above this */
  val threshold = UInt(32 bits)
  /** only pixels that pass the segment test are candidates (ignored without `HarrisConfig.segment`) */
  val segmentTest = Bool()
  val segmentThreshold = UInt(8 bits)
  /** the feature budget's target: features per frame */
  val target = UInt(BudgetConfig.targetWidth bits)
}
