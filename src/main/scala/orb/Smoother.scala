package orb

import spinal.core._
import spinal.lib._
import spinal.lib.misc.pipeline._
import Arith._

/** A smoothed pixel for the descriptor's samples: the 7x7 OpenCV Gaussian of the raw pixel 3 rows above and
  * 3 columns left of `pixel` (the beat that completed its neighbourhood). */
case class SmoothedPixel(f: FrameConfig) extends Bundle {
  val pixel = TrackedPixel(f)
  val smoothed = UInt(8 bits)
}

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
  val nodes = Array.fill(Smoother.latency + 1)(Node())
  val links = (0 until Smoother.latency).map(i => StageLink(nodes(i), nodes(i + 1)))

  val PIXEL = Payload(TrackedPixel(f))
  val TAPS = Payload(Vec(UInt(8 bits), blurKernel.size))
  nodes(0).driveFrom(io.columns) { (n, p) =>
    n(PIXEL) := p.pixel
    for (r <- blurKernel.indices) n(TAPS)(r) := p.column(r)
  }

  /** Symmetric 7-tap weighted sum: pre-add the mirrored taps at `pre`, weigh and add at `sum`. */
  private def gauss7(values: collection.IndexedSeq[UInt], pre: Node, sum: Node, width: Int): UInt = {
    val pairs = pre.insert(Vec(Seq((0, 6), (1, 5), (2, 4)).map { case (i, j) => values(i).resize(width) + values(j).resize(width) } :+
      values(3).resize(width)))
    sum(pairs).zip(blurKernel.take(4)).map { case (v, k) => constMul(v, k, width) }.reduceBalancedTree(_ + _)
  }

  // 255 * 256 = 65280: a column sum fits 16 bits, a 2-D sum 24 bits (the 2-D weights sum to 2^16).
  val COLUMN = nodes(1).insert(gauss7(nodes(0)(TAPS), nodes(0), nodes(1), 16))
  val row = new Area {
    val n = nodes(2)
    val last7 = lastValid(n(COLUMN), 7, n.isValid)
    val ROUNDED = nodes(3).insert(floorShift(gauss7(last7, n, nodes(3), 24) + U(1 << 15, 24 bits), 16).resize(8))
  }

  val out = nodes(Smoother.latency)
  io.smoothed.valid := out.isValid
  io.smoothed.pixel := out(PIXEL)
  io.smoothed.smoothed := out(row.ROUNDED)

  Builder(links)
}

object Smoother {
  val latency: Int = 4
}
