package orb

import spinal.core._
import spinal.lib._

case class CoreStatus(c: FrameConfig) extends Bundle {
  val frames, badFrames, badLines, corners = UInt(c.counterWidth bits)
}

/** The core: camera pixels in, Harris corners out (the descriptor and matcher stages are built on top of this).
  *
  * pixels -> FrameTracker (1 clk) -> LineBuffer (shared raw rows, 1 clk) -> HarrisDetector (`stages.latency` clk)
  *
  * Never stalls: every stage advances with valid pixels, blanking of any length (also none) passes through. */
class OrbCore(val cfg: OrbConfig = OrbConfig.default) extends Component {
  val io = new Bundle {
    val pixels = slave Flow (PixelBeat())
    /** a pixel is a corner candidate when its score is above this */
    val harrisThreshold = in UInt (32 bits)
    val corners = master Flow (HarrisCorner(cfg.frame, cfg.harris))
    val frameEnds = master Flow (FrameEndInfo())
    val status = out(CoreStatus(cfg.frame))
  }
  val tracker = new FrameTracker(cfg.frame)
  val lines = new LineBuffer(cfg.frame, cfg.rawRows)
  val harris = new HarrisDetector(cfg.frame, cfg.harris, cfg.rawRows)

  tracker.io.pixels << io.pixels
  lines.io.pixels << tracker.io.tracked
  harris.io.columns << lines.io.columns
  harris.io.geometry := tracker.io.geometry
  harris.io.threshold := io.harrisThreshold
  io.corners << harris.io.corners
  io.frameEnds << harris.io.frameEnds
  io.status.frames := tracker.io.counters.frames
  io.status.badFrames := tracker.io.counters.badFrames
  io.status.badLines := tracker.io.counters.badLines
  io.status.corners := harris.io.cornerCount
}

object OrbCore {
  /** clocks from a pixel entering to the corner it completes leaving (tracker + line buffer + detector) */
  def latency(stages: HarrisStages = HarrisStages()): Int = 2 + stages.latency
}
