package orb

import spinal.core._
import spinal.lib._
import orb.Pipes.keptApart
import spinal.lib.misc.pipeline._

/** The orientation bin of (m10, m01) without a divider, as `orb.model.OrbModel.angleBin`: fold into the first
  * octant (signs, swap so that b <= a), count the bin boundaries below the angle with a binary search, one
  * comparison b 2^F >= a T_j per step, unfold. One corner per clock; latency `4 steps + 5`: a step looks up the
  * tangent it tries (into a register), multiplies a's two parts by it in two multiplier blocks (plain registers on
  * both sides of each product), adds the partial products and compares. */
class AngleSearch(f: FrameConfig, h: HarrisConfig, d: OrbDescriptorConfig) extends Component {
  val io = new Bundle {
    val input = slave Flow (OrientedCorner(f, h, d))
    val output = master Flow (OrientedCorner(f, h, d))
  }
  val momentWidth = OrientationUnit.momentWidth
  val m = d.binsPerOctant
  val tangents = d.boundaryTangents
  val steps = Iterator.iterate(1)(_ * 2).takeWhile(_ <= m).toSeq.reverse // m, m/2, .., 1 when m is a power of 2
  val tWidth = log2Up(tangents.max + 1)
  val countWidth = log2Up(m + 1)

  /** a = hi 2^L + lo: lo fills a multiplier's operand, and so does the tangent */
  val loWidth = Arith.multiplierWidth
  require(tWidth <= Arith.multiplierWidth && momentWidth - loWidth <= Arith.multiplierWidth)
  // the stages: `at(i)` is the beat i clocks after the input, a register between each
  val pipeline = new StagePipeline
  def at(i: Int): Node = pipeline.node(i)

  val IN = Payload(OrientedCorner(f, h, d))
  at(0).driveFrom(io.input)((n, p) => n(IN) := p)
  // Beside the search travel the corner and its tags, not its moments: they are rebuilt at the end from the
  // magnitudes the search carries anyway and their signs.
  val beside = new Area {
    val n = at(0)
    val CORNER = n.insert(n(IN).corner)
    val ROW_TAG = n.insert(n(IN).rowTag)
    val FRAME_TAG = n.insert(n(IN).frameTag)
    val KEYFRAME = n.insert(n(IN).keyframe)
    val END = n.insert(n(IN).end)
    val M10_NEGATIVE = n.insert(n(IN).m10.sign)
    val M01_NEGATIVE = n.insert(n(IN).m01.sign)
  }

  // the magnitudes at node 0, their comparison at node 1, the swap it decides at node 2 (a register between them)
  val fold = new Area {
    val AX = at(0).insert(at(0)(IN).m10.abs)
    val AY = at(0).insert(at(0)(IN).m01.abs)
    val SWAP = at(1).insert(at(1)(AY) > at(1)(AX))
    val n = at(2)
    val A = n.insert(Mux(n(SWAP), n(AY), n(AX)))
    val B = n.insert(Mux(n(SWAP), n(AX), n(AY)))
  }

  /** the node of the first step's lookup */
  val first = 3
  // Step i tries to add `step` to the count of the steps before it: the T_j it tries at node first + 4i, the partial
  // products of the registered a and T_j a node later, their sum the node after, the comparison the next.
  val counts = scala.collection.mutable.ArrayBuffer[Payload[UInt]]()
  for ((step, i) <- steps.zipWithIndex) {
    val n = at(first + 4 * i)
    val before = if (i == 0) U(0, countWidth bits) else n(counts(i - 1))
    val BEFORE = n.insert(before)
    // `before` is a sum of larger steps (powers of two), a multiple of 2 step: the index it tries, before + step - 1,
    // is looked up by before / step in a table of this step's own indices (no adder before the lookup)
    val shift = log2Up(step)
    val quotient = before(countWidth - 1 downto shift)
    def tried(q: Int): Int = q * step + step - 1
    // an index past the octant is never tried (TRY); its entry repeats the one without the quotient's top bit, so
    // that (m a power of two) the table does not depend on that bit: no entry forced to 0 by it, which synthesis
    // would make a reset of the multipliers' input register
    val half = 1 << (quotient.getWidth - 1)
    def entry(q: Int): Long =
      if (tried(q) < m) tangents(tried(q)) else if (q >= half && tried(q - half) < m) tangents(tried(q - half)) else 0L
    val table = Vec((0 until (1 << quotient.getWidth)).map(q => U(entry(q), tWidth bits)))
    val inRange = Vec((0 until (1 << quotient.getWidth)).map(q => Bool(tried(q) < m)))
    val TRY = n.insert(inRange(quotient) && n(fold.A) =/= 0)
    val p = at(first + 4 * i + 1)
    // a's and T_j's copies that feed only the multipliers (their input registers): loaded with the step's valid
    // and kept apart, so that neither is merged with a twin (the pipeline's register of a, a bit of T_j equal to
    // one of `before`) that feeds more than multipliers
    val aForProducts = keptApart(RegNextWhen(n(fold.A), n.isValid))
    val tangent = keptApart(RegNextWhen(table(quotient), n.isValid))
    val LO = p.insert(aForProducts(loWidth - 1 downto 0) * tangent)
    val HI = p.insert(aForProducts(momentWidth - 1 downto loWidth) * tangent)
    val s = at(first + 4 * i + 2)
    val PRODUCT = s.insert((s(HI) << loWidth).resize(momentWidth + tWidth) + s(LO).resize(momentWidth + tWidth))
    val c = at(first + 4 * i + 3)
    val take = c(TRY) && ((c(fold.B).resize(momentWidth + d.tanFracBits) |<< d.tanFracBits) >= c(PRODUCT))
    // `before` is a multiple of 2 step: adding the step sets its bit (no carry, no adder after the comparison)
    counts += c.insert(c(BEFORE) | (take.asUInt << shift).resize(countWidth))
  }
  // The count unfolded over the octant's swap and the quadrant's signs: the bin is offset +- count, the offset and
  // the sign decided from the swap and the signs nodes ahead, so the unfolding is one adder.
  // With Q = swap ? 2m - count : count, the quadrants give Q, n/2 - Q, n/2 + Q and n - Q (0 for Q = 0).
  val unfold = new Area {
    val n = d.angleBins
    val bw = d.binWidth
    val early = at(2)
    val right = !early(beside.M10_NEGATIVE)
    val up = !early(beside.M01_NEGATIVE)

    // the quadrant's base, and whether Q is subtracted from it
    val base = Mux(right, Mux(up, U(0, bw + 1 bits), U(n, bw + 1 bits)), U(n / 2, bw + 1 bits))
    val qSubtracted = right =/= up
    // base + Q or base - Q; Q = 2m - count after a swap: the offset takes 2m in Q's sign, the count the other one
    val OFFSET = early.insert(
      Mux(early(fold.SWAP), Mux(qSubtracted, base - d.binsPerQuadrant, base + d.binsPerQuadrant), base)
    )
    val SUBTRACT = early.insert(qSubtracted =/= early(fold.SWAP))
    val swapped = at(first + 4 * steps.size)
    val count = swapped(counts.last).resize(bw + 1)
    val sum = Mux(swapped(SUBTRACT), swapped(OFFSET) - count, swapped(OFFSET) + count)
    // the sum lies in [0, n]; n (the fourth quadrant's n - 0) is bin 0 (a power of two wraps by itself)
    val BIN = swapped.insert(if (isPow2(n)) sum.resize(bw) else Mux(sum === n, U(0, bw bits), sum.resize(bw)))
    // |m10| is a, or b after a swap; |m01| the other: picked here, so that the next node only signs them
    val ABS10 = swapped.insert(Mux(swapped(fold.SWAP), swapped(fold.B), swapped(fold.A)))
    val ABS01 = swapped.insert(Mux(swapped(fold.SWAP), swapped(fold.A), swapped(fold.B)))
    val u = at(first + 4 * steps.size + 1)
    def moment(magnitude: UInt, negative: Bool): SInt = {
      val m = magnitude.intoSInt.resize(momentWidth)
      Mux(negative, -m, m)
    }
    val M10 = u.insert(moment(u(ABS10), u(beside.M10_NEGATIVE)))
    val M01 = u.insert(moment(u(ABS01), u(beside.M01_NEGATIVE)))
  }
  val out = at(first + 4 * steps.size + 2)
  io.output.valid := out.isValid
  io.output.corner := out(beside.CORNER)
  io.output.m10 := out(unfold.M10)
  io.output.m01 := out(unfold.M01)
  io.output.rowTag := out(beside.ROW_TAG)
  io.output.frameTag := out(beside.FRAME_TAG)
  io.output.keyframe := out(beside.KEYFRAME)
  io.output.end := out(beside.END)
  io.output.bin := out(unfold.BIN)
  pipeline.build()
}
