package orb

import spinal.core._
import spinal.lib._
import spinal.lib.misc.pipeline._
import Arith._
import orb.Pipes.keptApart

/** The 7x7 Gaussian (sigma 2) of `orb.model.OrbModel.smooth`, computed in the stream from the newest 7 rows of the
  * shared raw column: vertical taps first, then 7 registers that advance with valid pixels; integer kernel
  * 18 34 48 56 48 34 18 per pass, one rounding at the end. No multiplier blocks: the weights are shifts and adds.
  * Latency: `Smoother.latency` clocks. */
class Smoother(f: FrameConfig, columnRows: Int) extends Component {
  import OrbDescriptorConfig.blurKernel
  require(columnRows >= blurKernel.size)
  val io = new Bundle {
    val columns = slave Flow (LineColumn(f, columnRows))
    val smoothed = master Flow (SmoothedPixel(f))
  }
  // the stages: `at(i)` is the beat i clocks after the input, a register between each
  val pipeline = new StagePipeline
  def at(i: Int): Node = pipeline.node(i)

  val PIXEL = Payload(TrackedPixel(f))
  val TAPS = Payload(Vec(UInt(8 bits), blurKernel.size))
  at(0).driveFrom(io.columns) { (n, p) =>
    n(PIXEL) := p.pixel
    for (r <- blurKernel.indices) n(TAPS)(r) := p.column(r)
  }

  /** Symmetric 7-tap weighted sum in four registered steps: pre-add the mirrored taps at `pre`, weigh them (shifted
    * copies into one adder each: `constMul`) at the next node, add them in pairs at the one after, and the two halves
    * at the last. */
  private val firstRegisters = scala.collection.mutable.ArrayBuffer[(Int, Payload[Vec[UInt]])]()
  private def gauss7(values: collection.IndexedSeq[UInt], pre: Int, width: Int): UInt = {
    val pairs = at(pre).insert(Vec(Seq((0, 6), (1, 5), (2, 4)).map { case (i, j) =>
      values(i).resize(width) + values(j).resize(width)
    } :+ values(3).resize(width)))
    firstRegisters += ((pre + 1, pairs))
    val terms = at(pre + 1).insert(Vec(at(pre + 1)(pairs).zip(blurKernel.take(4)).map { case (v, k) =>
      constMul(v, k, width)
    }))
    val t = at(pre + 2)(terms)
    val halves = at(pre + 2).insert(Vec(t(0) + t(1), t(2) + t(3)))
    at(pre + 3)(halves)(0) + at(pre + 3)(halves)(1)
  }

  // 255 * 256 = 65280: a column sum fits 16 bits, a 2-D sum 24 bits (the 2-D weights sum to 2^16).
  val COLUMN = at(Smoother.columnSum).insert(gauss7(at(0)(TAPS), 0, 16))
  val row = new Area {
    val n = at(Smoother.rowPre)
    val last7 = lastValid(n(COLUMN), 7, n.isValid)
    val SUM = at(Smoother.rowSum).insert(gauss7(last7, Smoother.rowPre, 24))
    // Rounded half up: the integer part plus the first fraction bit (an 8-bit increment, in a clock of its own).
    val sum = at(Smoother.round)(SUM)
    val ROUNDED = at(Smoother.round).insert((sum(23 downto 16) +^ sum(15 downto 15)).resize(8))
  }

  // The position's tests a stage before the flags they make (registered): no flag waits for a comparison. The row
  // is only tested (a node after the input, from its register) and not carried: the output has no use for it.
  val flags = new Area {
    val Y_ZERO = at(1).insert(at(1)(PIXEL).y === 0)
    val tests = at(Smoother.latency - 2)
    val X_ZERO = tests.insert(tests(PIXEL).x === 0)
    val X_BLURRED = tests.insert(tests(PIXEL).x >= OrbDescriptorConfig.blurRadius)
    val n = at(Smoother.latency - 1)
    val active = n(PIXEL).active
    val ROW_START = n.insert(n(X_ZERO) && active)
    val FRAME_START = n.insert(n(X_ZERO) && n(Y_ZERO))
    val HOLDS_SMOOTHED = n.insert(active && n(X_BLURRED))
  }
  val out = at(Smoother.latency)
  io.smoothed.valid := out.isValid
  io.smoothed.x := out(PIXEL).x
  io.smoothed.active := out(PIXEL).active
  io.smoothed.smoothed := out(row.ROUNDED)
  io.smoothed.rowStart := out(flags.ROW_START)
  io.smoothed.frameStart := out(flags.FRAME_START)
  io.smoothed.holdsSmoothed := out(flags.HOLDS_SMOOTHED)

  pipeline.build()
  Pipes.keepValidsApart(pipeline)
  // A sum's first registers kept apart: the column sum's centre tap is the twin of Harris's registered column, which
  // synthesis would otherwise drive both blocks from (Harris keeps its own apart too).
  firstRegisters.foreach { case (node, payload) => keptApart(at(node)(payload)) }
}

object Smoother {

  /** stages: the column sum's four steps end at `columnSum`, the row sum's at `rowSum`, then the rounding, and a
    * register to the descriptor store's write data */
  val columnSum: Int = 3
  val rowPre: Int = columnSum + 1
  val rowSum: Int = rowPre + 3
  val round: Int = rowSum + 1
  val latency: Int = round + 1
}
