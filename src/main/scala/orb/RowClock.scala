package orb

import spinal.core._

/** Rows and frames of a pixel stream counted since reset, wrapping (rows: the processed ones, whose first pixel is
  * active; frames: every start of frame). The orientation unit tags each corner with the count of its row and frame
  * on its stream, and the descriptor unit compares those tags with the same counts on the smoothed stream: one
  * class, so both count the same way (as `VgaCtrl` writes one timing counter for both axes).
  * `rowNext` / `frameNext` are the counts after this clock. */
class RowClock(f: FrameConfig, rowStarts: Bool, frameStarts: Bool) extends Area {
  val row = Reg(f.rowTag()) init 0
  val frame = Reg(f.frameTag()) init 0
  val rowNext = Mux(rowStarts, row + 1, row)
  val frameNext = Mux(frameStarts, frame + 1, frame)
  row := rowNext
  frame := frameNext
}
