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
    val correspondences = master Stream (CorrespondenceBeat(cfg.frame))
    val ctrl = slave(AvalonMM(OrbTop.avalonConfig))
  }
  val core = new OrbCore(cfg)
  val matcher = new Matcher(cfg.frame, cfg.harris, cfg.descriptor, cfg.matcher)
  core.io.pixels << io.pixels
  matcher.io.features << core.io.features
  io.correspondences << matcher.io.correspondences

  val regs = new Area {
    import OrbTop.Registers._
    val bus = AvalonMMSlaveFactory(io.ctrl)
    val m = cfg.matcher
    bus.read(B(OrbTop.id, 32 bits), ID)
    val ratioTest = bus.createReadAndWrite(Bool(), CONTROL, 0) init Bool(m.defaultRatioTest)
    val crossCheck = bus.createReadAndWrite(Bool(), CONTROL, 1) init Bool(m.defaultCrossCheck)
    val segmentTest = bus.createReadAndWrite(Bool(), CONTROL, 2) init Bool(cfg.harris.segment.isDefined)
    val harrisThreshold = bus.createReadAndWrite(UInt(32 bits), HARRIS_THRESHOLD) init cfg.harris.defaultThreshold
    val segmentThreshold = bus.createReadAndWrite(UInt(8 bits), SEGMENT_THRESHOLD) init cfg.harris.segment.fold(0)(_.defaultThreshold)
    val target = bus.createReadAndWrite(UInt(BudgetConfig.targetWidth bits), TARGET) init cfg.budget.defaultTarget
    val hamming = bus.createReadAndWrite(UInt(MatcherConfig.distanceWidth bits), HAMMING_THRESHOLD) init m.defaultHammingThreshold
    val ratio = bus.createReadAndWrite(UInt(m.ratioWidth bits), RATIO) init m.defaultRatio
    core.io.cornerControl.threshold := harrisThreshold
    core.io.cornerControl.segmentTest := segmentTest
    core.io.cornerControl.segmentThreshold := segmentThreshold
    core.io.cornerControl.target := target
    matcher.io.params.hammingThreshold := hamming
    matcher.io.params.ratio := ratio
    matcher.io.params.ratioTest := ratioTest
    matcher.io.params.crossCheck := crossCheck
    val s = core.io.status
    val t = matcher.io.status
    // the counters come from across the chip: each is copied into a register beside the bus (a read sees it a clock
    // late), so the read multiplexer's inputs are local
    for ((value, address) <- Seq(s.frames -> FRAMES, s.badFrames -> BAD_FRAMES, s.badLines -> BAD_LINES,
      s.corners -> CORNERS, s.features -> FEATURES, s.featureDrops -> FEATURE_DROPS, t.stored -> STORED,
      t.storeOverflow -> STORE_OVERFLOW, t.matches -> MATCHES, t.matchDrops -> MATCH_DROPS, s.deselected -> DESELECTED))
      bus.read(RegNext(value) init 0, address)
  }
}

object OrbTop {
  /** "ORB" and the register map's version */
  val id: BigInt = BigInt("4f524203", 16)
  val avalonConfig: AvalonMMConfig = AvalonMMSlaveFactory.getAvalonConfig(addressWidth = 8, dataWidth = 32)

  /** Byte addresses of the 32-bit registers (the README documents them). */
  object Registers {
    val ID = 0x00
    /** bit 0: ratio test on, bit 1: cross-check on (both take effect at the next frame), bit 2: segment test on
      * (corner candidates; takes effect at once, as the thresholds) */
    val CONTROL = 0x04
    val HARRIS_THRESHOLD = 0x08
    val HAMMING_THRESHOLD = 0x0c
    /** ratio-test factor r scaled 2^ratioFracBits (accept when best < r * second) */
    val RATIO = 0x10
    /** the segment test's intensity threshold t (0..255) */
    val SEGMENT_THRESHOLD = 0x14
    /** the feature budget's target: features per frame (0..65535) */
    val TARGET = 0x18
    val FRAMES = 0x20
    val BAD_FRAMES = 0x24
    val BAD_LINES = 0x28
    val CORNERS = 0x2c
    val FEATURES = 0x30
    val FEATURE_DROPS = 0x34
    val STORED = 0x38
    val STORE_OVERFLOW = 0x3c
    val MATCHES = 0x40
    val MATCH_DROPS = 0x44
    /** corners the feature budget did not select */
    val DESELECTED = 0x48
  }
}
