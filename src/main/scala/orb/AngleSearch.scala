package orb

import spinal.core._
import spinal.lib._
import orb.Pipes.keptApart
import spinal.lib.misc.pipeline._

/** The orientation bin of (m10, m01) without a divider, as `orb.model.OrbModel.angleBin`: fold into the first
  * octant (signs, swap so that b <= a), count the bin boundaries below the angle with a binary search, one
  * comparison b 2^F >= a T_j per step, unfold. One corner per clock; latency `4 steps + 5`: a step multiplies a's
  * two parts by the tangent it tries in two multiplier blocks (plain registers on both sides of each product; the
  * tangent picked from the two the step before looked up), adds the partial products and compares. */
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

  /** the node of the first step's multiplier input */
  val first = 3
  val fracBits = d.tanFracBits

  /** Step `i`'s tangent for a count of the steps before it: `before` is a sum of larger steps (powers of two), a
    * multiple of 2 step, so the index it tries, before + step - 1, is looked up by before / step in a table of the
    * step's own indices (no adder before the lookup). An index past the octant is never tried (`inRange`); its entry
    * repeats the one without the quotient's top bit, so that (m a power of two) the table does not depend on that
    * bit: no entry forced to 0 by it, which synthesis would make a reset of the multipliers' input register. */
  case class StepTable(i: Int) {
    val step = steps(i)
    val shift = log2Up(step)
    val quotientWidth = countWidth - shift
    def tried(q: Int): Int = q * step + step - 1
    val half = 1 << (quotientWidth - 1)
    def entry(q: Int): Long =
      if (tried(q) < m) tangents(tried(q)) else if (q >= half && tried(q - half) < m) tangents(tried(q - half)) else 0L
    def quotient(before: UInt): UInt = before(countWidth - 1 downto shift)
    def tangent(before: UInt): UInt =
      Vec((0 until (1 << quotientWidth)).map(q => U(entry(q), tWidth bits)))(quotient(before))
    def inRange(before: UInt): Bool = Vec((0 until (1 << quotientWidth)).map(q => Bool(tried(q) < m)))(quotient(before))
  }
  val tables = steps.indices.map(StepTable)

  // Step i tries to add its step to the count of the steps before it: its tangent enters the multipliers' input
  // registers at node first + 4i, the partial products of a and T_j come a node later, their sum the node after, the
  // comparison the next. The next step's two possible tangents (for this step's bit clear or set) are looked up from
  // the count before this step while it compares, into registers: the bit only picks one of them.
  val counts = scala.collection.mutable.ArrayBuffer[Payload[UInt]]()
  val candidates = scala.collection.mutable.ArrayBuffer[(Payload[UInt], Payload[UInt])]()
  for (i <- steps.indices) {
    val table = tables(i)
    val n = at(first + 4 * i)
    val before = if (i == 0) U(0, countWidth bits) else n(counts(i - 1))
    val BEFORE = n.insert(before)
    val TRY = n.insert(table.inRange(before) && n(fold.A) =/= 0)
    val lookedUp =
      if (i == 0) table.tangent(before)
      else {
        val (without, withBit) = candidates(i - 1)
        Mux(before(tables(i - 1).shift), n(withBit), n(without))
      }
    val p = at(first + 4 * i + 1)
    // a's and T_j's copies that feed only the multipliers (their input registers): loaded with the step's valid
    // and kept apart, so that neither is merged with a twin (the pipeline's register of a, a bit of T_j equal to
    // one of `before`) that feeds more than multipliers
    val aForProducts = keptApart(RegNextWhen(n(fold.A), n.isValid))
    val tangent = keptApart(RegNextWhen(lookedUp, n.isValid))
    val LO = p.insert(aForProducts(loWidth - 1 downto 0) * tangent)
    val HI = p.insert(aForProducts(momentWidth - 1 downto loWidth) * tangent)
    // b 2^F >= a T_j = P exactly when b >= ceil(P / 2^F): the sum forms P / 2^F and whether P has a fraction, so
    // that the comparison is as wide as b, not as P
    val s = at(first + 4 * i + 2)
    val (whole, fraction) =
      if (fracBits <= loWidth) {
        val w = (s(HI).getWidth + loWidth - fracBits) max (s(LO).getWidth - fracBits)
        val lo = s(LO)
        val sum = (s(HI) << (loWidth - fracBits)).resize(w + 1) + lo(lo.getWidth - 1 downto fracBits).resize(w + 1)
        (sum, lo(fracBits - 1 downto 0) =/= 0)
      } else {
        val product = (s(HI) << loWidth).resize(momentWidth + tWidth) + s(LO).resize(momentWidth + tWidth)
        (product(product.getWidth - 1 downto fracBits), product(fracBits - 1 downto 0) =/= 0)
      }
    val WHOLE = s.insert(whole)
    val FRACTION = s.insert(fraction)
    val c = at(first + 4 * i + 3)
    // b >= whole + fraction, as 2b + 1 > 2 whole + fraction: one comparison
    val cw = (momentWidth max c(WHOLE).getWidth) + 1
    val take = c(TRY) && ((c(fold.B).resize(cw - 1) @@ True) > (c(WHOLE).resize(cw - 1) @@ c(FRACTION)))
    // `before` is a multiple of 2 step: adding the step sets its bit (no carry, no adder after the comparison)
    counts += c.insert(c(BEFORE) | (take.asUInt << table.shift).resize(countWidth))
    if (i + 1 < steps.size) {
      val next = tables(i + 1)
      val withBit = c(BEFORE) | U(table.step, countWidth bits)
      candidates += ((c.insert(next.tangent(c(BEFORE))), c.insert(next.tangent(withBit))))
    }
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
