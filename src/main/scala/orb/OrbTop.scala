package orb

import spinal.core._
import spinal.lib._
import spinal.lib.bus.avalon._

/** The complete core: camera pixels in, correspondences out, parameters and counters on Avalon-MM.
  *
  * pixels -> OrbCore (Harris, orientation, BRIEF) -> feature Stream -> Matcher (keyframe store, Hamming scan)
  *        -> correspondence Stream (behind a FIFO; see `Matcher` for slow and stalled consumers)
  *
  * The camera is never stalled: the matcher holds the feature stream while it scans, which holds the descriptor
  * engines; corners wait in the descriptor unit's queue. The feature budget in the core bounds them so that no
  * corner's rows are gone before an engine takes it (`OrbConfig.budgetService`), as long as the correspondence
  * consumer keeps up; one that does not can make the matcher hold the features long enough to drop some
  * (`FEATURE_DROPS`, counted). */
class OrbTop(val cfg: OrbConfig = OrbConfig.default) extends Component {
  val io = new Bundle {
    val pixels = slave Flow (PixelBeat())
    val correspondences = master Stream (CorrespondenceHw(cfg.frame))
    val ctrl = slave(AvalonMM(OrbTop.avalonConfig))
  }
  val core = new OrbCore(cfg)
  val matcher = new Matcher(cfg.frame, cfg.harris, cfg.descriptor, cfg.matcher)
  core.io.pixels << io.pixels
  matcher.io.features << core.io.features
  io.correspondences << matcher.io.correspondences

  val regs = new RegisterFile(io.ctrl, cfg, this)
  core.io.cornerControl.threshold := regs(RegisterMap.HARRIS_THRESHOLD)
  core.io.cornerControl.segmentTest := regs(RegisterMap.SEGMENT_TEST)
  core.io.cornerControl.segmentThreshold := regs(RegisterMap.SEGMENT_THRESHOLD)
  core.io.cornerControl.target := regs(RegisterMap.TARGET)
  matcher.io.params.hammingThreshold := regs(RegisterMap.HAMMING_THRESHOLD)
  matcher.io.params.ratio := regs(RegisterMap.RATIO)
  matcher.io.params.ratioTest := regs(RegisterMap.RATIO_TEST)
  matcher.io.params.crossCheck := regs(RegisterMap.CROSS_CHECK)
}

object OrbTop {
  val avalonConfig: AvalonMMConfig = RegisterMap.config
}
