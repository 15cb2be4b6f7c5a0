package orb.model

import orb.FrameConfig

/** What the frame tracker says about one beat (mirrors `orb.TrackedPixel`). `end` closes the last frame that
  * was processed: on its last pixel (ok) or on the beat where a fault showed (not ok; for a frame cut short that
  * beat is the next start of frame). */
final case class TrackedBeat(luma: Int, x: Int, y: Int, active: Boolean, end: Option[FrameEnd])

final case class FrameCounters(frames: Long = 0, badFrames: Long = 0, badLines: Long = 0)

/** Beat-by-beat mirror of `orb.FrameTracker`: learns the frame geometry from the markers and checks every frame
  * against it.
  *
  *  - A frame is *processed* only when the frame before it was well formed (no fault, ended on a line end, at
  *    least one line); its width and height then become the expected geometry. So the first frame after reset,
  *    and the frame after any faulty frame, only measure the geometry and produce nothing.
  *  - Faults: a pixel beyond the expected width (or beyond maxWidth while the first line is measured), an end of
  *    line before the expected width, a line beyond the expected height (maxHeight while measuring), and a start
  *    of frame before the expected height or in the middle of a line. The first fault of a frame ends its
  *    processing for good (counted once in badFrames); every line of wrong length counts once in badLines.
  *  - Beats before the first start of frame after reset are ignored.
  */
final class FrameTrackerModel(cfg: FrameConfig) {
  private var inFrame, locked, processed, active, bad, done, widthKnown, lineFaulted, key = false
  private var x, y, lineW, expW, expH = 0
  private var counters = FrameCounters()
  def stats: FrameCounters = counters
  def geometry: (Int, Int) = (expW, expH)

  def step(b: Beat): Option[TrackedBeat] = {
    var frameEnd, frameOk = false
    var frameKey = key
    if (b.sof) {
      if (inFrame) {
        val good = !bad && x == 0 && y >= 1 && (!processed || done)
        if (!good) {
          if (x != 0 && !lineFaulted) counters = counters.copy(badLines = counters.badLines + 1)
          if (!bad) {
            counters = counters.copy(badFrames = counters.badFrames + 1)
            if (processed && !done) { frameEnd = true; frameOk = false }
          }
        } else { expW = lineW; expH = y }
        locked = good
      }
      inFrame = true; processed = locked; active = locked; bad = false; done = false
      widthKnown = locked; lineW = expW; lineFaulted = false; key = b.keyframe
      x = 0; y = 0
      counters = counters.copy(frames = counters.frames + 1)
    }
    if (!inFrame) return None

    val limitW = if (widthKnown) lineW else cfg.maxWidth
    val limitH = if (processed) expH else cfg.maxHeight
    val lineFault = x >= limitW || (widthKnown && b.eol && x != lineW - 1)
    val fault = lineFault || y >= limitH
    if (lineFault && !lineFaulted) counters = counters.copy(badLines = counters.badLines + 1)
    if (fault && !bad) {
      counters = counters.copy(badFrames = counters.badFrames + 1)
      if (processed && !done) { frameEnd = true; frameOk = false; frameKey = key }
    }
    val beatActive = active && !fault
    val complete = processed && !bad && !fault && b.eol && y == expH - 1
    if (complete) { frameEnd = true; frameOk = true; frameKey = key }
    val out = TrackedBeat(b.luma, x, y, beatActive, if (frameEnd) Some(FrameEnd(frameOk, frameKey)) else None)

    if (fault) { bad = true; active = false }
    if (complete) { done = true; active = false }
    if (lineFault) lineFaulted = true
    if (b.eol) {
      if (!widthKnown && !lineFaulted) { lineW = x + 1; widthKnown = true }
      x = 0; y = (y + 1) min cfg.maxHeight; lineFaulted = false
    } else {
      x = (x + 1) min cfg.maxWidth
    }
    Some(out)
  }
}
