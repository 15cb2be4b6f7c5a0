package orb

import spinal.core._
import spinal.lib._

/** The core: camera pixels in, Harris corners and ORB features out (`OrbTop` adds the keyframe store and matcher).
  *
  * pixels -> FrameTracker (1 clk) -> LineBuffer (shared raw rows, 1 clk) -+-> HarrisDetector -> corners -> FeatureBudget
  *                                                                        +-> OrientationUnit (selected corners + raw rows)
  *                                                                        +-> Smoother -> DescriptorUnit -> features
  *
  * Never stalls the camera: every stage advances with valid pixels, blanking of any length (also none) passes
  * through; only the feature output is a Stream. The feature budget bounds the corners that go on so that the
  * orientation slots, the descriptor engine and a consumer as fast as `OrbTop`'s matcher always keep up; a consumer
  * that waits longer holds the descriptor engine, and a corner that cannot wait for it any longer is dropped
  * and counted. */
class OrbCore(val cfg: OrbConfig = OrbConfig.default) extends Component {
  val io = new Bundle {
    val pixels = slave Flow (PixelBeat())

    /** Harris threshold and segment test */
    val cornerControl = in(CornerParamsHw())
    val corners = master Flow (CornerHw(cfg.frame, cfg.harris))
    val features = master Stream (FeatureHw(cfg.frame, cfg.harris, cfg.descriptor))
    val frameEnds = master Flow (FrameEndHw())
    val status = out(CoreStatus(cfg.frame))
  }
  val tracker = new FrameTracker(cfg.frame, LineBuffer.readCopies(cfg.frame, cfg.rawRows))
  val lines = new LineBuffer(cfg.frame, cfg.rawRows)
  val harris = new HarrisDetector(cfg.frame, cfg.harris, cfg.rawRows)
  val budget = new FeatureBudget(cfg)
  val smoother = new Smoother(cfg.frame, cfg.rawRows)
  val orientation = new OrientationUnit(cfg.frame, cfg.harris, cfg.descriptor, cfg.rawRows)
  val descriptors = new DescriptorUnit(cfg.frame, cfg.harris, cfg.descriptor)

  tracker.io.pixels << io.pixels
  lines.follow(tracker)
  harris.io.columns << lines.io.columns
  harris.io.geometry := tracker.io.geometry
  harris.io.control := io.cornerControl
  io.corners << harris.io.corners
  smoother.io.columns << lines.io.columns
  orientation.io.columns << lines.io.columns
  budget.attach(lines.io.columns, harris, tracker.io.geometry, io.cornerControl.target)
  orientation.io.corners << budget.io.selected
  descriptors.io.smoothed << smoother.io.smoothed
  descriptors.io.corners << orientation.io.oriented
  io.features << descriptors.io.features
  // counted a clock late: the handshake reaches one register, not the counter's enables
  val featureCount = Pipes.lateCounter(cfg.frame, io.features.fire && !io.features.end.now)
  io.status.features := featureCount
  // the sum of the blocks' drop counts registered (a clock late): the register map reads it through one LUT level
  io.status.featureDrops := RegNext(budget.io.dropped + orientation.io.dropped + descriptors.io.dropped) init 0
  io.status.deselected := budget.io.deselected
  io.frameEnds << harris.io.frameEnds
  io.status.frames := tracker.io.counters.frames
  io.status.badFrames := tracker.io.counters.badFrames
  io.status.badLines := tracker.io.counters.badLines
  io.status.corners := harris.io.cornerCount
}

object OrbCore {

  /** clocks from a pixel entering to the corner it completes leaving (tracker + line buffer + detector) */
  def latency(stages: HarrisStages = HarrisStages()): Int = FrameTracker.latency + RowWindow.latency + stages.latency
}
