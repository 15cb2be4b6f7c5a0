package orb

import spinal.core._
import spinal.lib._
import orb.Pipes.keptApart

/** A corner's moments with whatever travels beside them. */
case class AngleQuery[T <: Data](itemType: HardType[T]) extends Bundle {
  val item = itemType()
  val m10, m01 = SInt(OrientationUnit.momentWidth bits)
}

/** The item with its orientation bin. */
case class AngleFound[T <: Data](itemType: HardType[T], d: OrbDescriptorConfig) extends Bundle {
  val item = itemType()
  val bin = UInt(d.binWidth bits)
}

/** What the search is doing: waiting for a corner, folding its moments into the first octant, comparing against
  * the boundaries' tangents, unfolding the count into the bin, holding the result for the consumer. */
object AngleSearchState extends SpinalEnum {
  val IDLE, FOLD, SEARCH, UNFOLD, FULL = newElement()
}

/** The orientation bin of (m10, m01) without a divider, as `orb.model.OrbModel.angleBin`, one corner at a time:
  * fold into the first octant (signs, swap so that b <= a), count the bin boundaries below the angle with a binary
  * search, one comparison b 2^F >= a T_j per step, unfold. A step takes seven clocks: the index it tries into a
  * register, its tangent looked up in two (each half of the table, then the half) into the multipliers' input
  * register, a's two parts times the tangent into the products' registers, their sum, the comparison into a
  * register. The data path runs every clock (no enables on the multipliers' registers); only the count and the step
  * move, once a step. `AngleSearch.clocks` from a corner's acceptance to
  * the next: far fewer than a descriptor takes, so the search at the descriptor unit's queue never holds the engine
  * up. */
class AngleSearch[T <: Data](itemType: HardType[T], d: OrbDescriptorConfig) extends Component {
  import AngleSearch._
  val io = new Bundle {
    val input = slave Stream (AngleQuery(itemType))
    val output = master Stream (AngleFound(itemType, d))
  }
  val momentWidth = OrientationUnit.momentWidth
  val m = d.binsPerOctant
  val tangents = d.boundaryTangents
  val steps = stepsOf(d)
  val tWidth = log2Up(tangents.max + 1)
  val countWidth = log2Up(m + 1)

  /** a = hi 2^L + lo: lo fills a multiplier's operand, and so does the tangent */
  val loWidth = Arith.multiplierWidth
  require(tWidth <= Arith.multiplierWidth && momentWidth - loWidth <= Arith.multiplierWidth)
  val fracBits = d.tanFracBits

  // one-hot: `idle` is one register, which enables the input's copy
  val state = Reg(AngleSearchState(binaryOneHot)) init AngleSearchState.IDLE
  val idle = state === AngleSearchState.IDLE
  val item = Reg(itemType())
  val m10, m01 = Reg(SInt(momentWidth bits))
  io.input.ready := idle
  // copied every clock while idle (an enable from the state alone, not from the input's handshake): the corner
  // accepted is the last one copied
  when(idle) {
    item := io.input.item
    m10 := io.input.m10
    m01 := io.input.m01
  }

  // The fold, registers behind the moments' (which hold while the corner is searched): the magnitudes, their
  // comparison, the swap it decides, each a clock later; `foldClocks` clocks in all.
  val fold = new Area {
    val ax = RegNext(m10.abs)
    val ay = RegNext(m01.abs)
    val negative10 = RegNext(m10.sign)
    val negative01 = RegNext(m01.sign)
    val swap = RegNext(ay > ax)
    val a = RegNext(Mux(swap, ay, ax))
    val b = RegNext(Mux(swap, ax, ay))
    // a = max(|m10|, |m01|) is not zero when either moment is not: tested on the moments in parts, then joined
    val nonZeroParts = RegNext(Vec(Seq(m10, m01).flatMap(_.asBits.subdivideIn(2 slices, strict = false)).map(_ =/= 0)))
    val aNonZero = RegNext(nonZeroParts.asBits.orR)
  }

  /** the clocks of an activity that lasts more than one */
  val clock = Reg(UInt(log2Up(foldClocks max clocksPerStep) bits))

  // The search: `count` holds the boundaries below the angle found so far (a sum of the steps taken, larger steps
  // first), `step` the step being tried (one-hot) and `below` step - 1: the index tried is count + step - 1, which,
  // count being a multiple of 2 step, is count | below (no adder before the lookup).
  val search = new Area {
    val count = Reg(UInt(countWidth bits))
    val step = Reg(UInt(countWidth bits))
    val below = Reg(UInt(countWidth bits))
    val tried = count | below

    /** The table is indexed by the index's low bits only (`tableBits`): an index past the octant is never tried,
      * so its entry does not matter, and the lookup is a function of fewer bits (fewer logic levels). */
    val tableBits = log2Up(m)
    require(tableBits >= 1, "two bins per octant at least")
    def entry(j: Int): Long = tangents(j min (m - 1))
    val index = RegNext(tried)
    // the lookup in two clocks: each half of the table on the index's lower bits into a register, then the half its
    // top bit names (a few logic levels before either register, none after the multipliers' input register)
    val halfBits = tableBits - 1
    val halves = (0 until 2).map { h =>
      val entries = (0 until (1 << halfBits)).map(j => U(entry((h << halfBits) | j), tWidth bits))
      RegNext(if (halfBits == 0) entries.head else Vec(entries)(index(halfBits - 1 downto 0)))
    }
    val upper = RegNext(index(tableBits - 1))
    // a's copy and the tangent feed only the multipliers (their input registers), kept apart so that neither is
    // merged with a twin that feeds more than multipliers
    val aForProducts = keptApart(RegNext(fold.a))
    val tangent = keptApart(RegNext(Mux(upper, halves(1), halves(0))))
    val trying = RegNext(index < m && fold.aNonZero)
    val lo = RegNext(aForProducts(loWidth - 1 downto 0) * tangent)
    val hi = RegNext(aForProducts(momentWidth - 1 downto loWidth) * tangent)
    // b 2^F >= a T_j = P exactly when b >= ceil(P / 2^F): the sum forms P / 2^F and whether P has a fraction, so
    // that the comparison is as wide as b, not as P; the fraction's bits tested in two halves (each a register)
    val (wholeNow, fractionBits) =
      if (fracBits <= loWidth) {
        val w = (hi.getWidth + loWidth - fracBits) max (lo.getWidth - fracBits)
        val sum = (hi << (loWidth - fracBits)).resize(w + 1) + lo(lo.getWidth - 1 downto fracBits).resize(w + 1)
        (sum, lo(fracBits - 1 downto 0))
      } else {
        val product = (hi << loWidth).resize(momentWidth + tWidth) + lo.resize(momentWidth + tWidth)
        (product(product.getWidth - 1 downto fracBits), product(fracBits - 1 downto 0))
      }
    val whole = RegNext(wholeNow)
    val fractionHalves = fractionBits.subdivideIn(2 slices, strict = false).map(half => RegNext(half =/= 0))
    val fraction = fractionHalves.reduce(_ || _)
    // b >= whole + fraction, as 2b + 1 > 2 whole + fraction: one comparison
    val cw = (momentWidth max whole.getWidth) + 1
    val takes = RegNext(trying && ((fold.b.resize(cw - 1) @@ True) > (whole.resize(cw - 1) @@ fraction)))
    val lastStep = step.lsb
  }

  // The count unfolded over the octant's swap and the quadrant's signs: the bin is offset +- count, the offset and
  // the sign decided as the fold ends, so the unfolding is one adder.
  // With Q = swap ? 2m - count : count, the quadrants give Q, n/2 - Q, n/2 + Q and n - Q (0 for Q = 0).
  val unfold = new Area {
    val n = d.angleBins
    val bw = d.binWidth
    val right = !fold.negative10
    val up = !fold.negative01
    // the quadrant's base, and whether Q is subtracted from it
    val base = Mux(right, Mux(up, U(0, bw + 1 bits), U(n, bw + 1 bits)), U(n / 2, bw + 1 bits))
    val qSubtracted = right =/= up
    // base + Q or base - Q; Q = 2m - count after a swap: the offset takes 2m in Q's sign, the count the other one
    val offset = RegNext(
      Mux(fold.swap, Mux(qSubtracted, base - d.binsPerQuadrant, base + d.binsPerQuadrant), base)
    )
    val subtract = RegNext(qSubtracted =/= fold.swap)
    val count = search.count.resize(bw + 1)
    val sum = Mux(subtract, offset - count, offset + count)
    // the sum lies in [0, n]; n (the fourth quadrant's n - 0) is bin 0 (a power of two wraps by itself)
    val bin = Reg(UInt(bw bits))
  }

  switch(state) {
    is(AngleSearchState.IDLE) {
      clock := 0
      when(io.input.valid) {
        state := AngleSearchState.FOLD
      }
    }
    is(AngleSearchState.FOLD) {
      clock := clock + 1
      when(clock === foldClocks - 1) {
        clock := 0
        search.count := 0
        search.step := U(steps.head, countWidth bits)
        search.below := U(steps.head - 1, countWidth bits)
        state := AngleSearchState.SEARCH
      }
    }
    is(AngleSearchState.SEARCH) {
      clock := clock + 1
      when(clock === clocksPerStep - 1) {
        clock := 0
        // count is a multiple of 2 step: taking the step sets its bit (no carry)
        when(search.takes) {
          search.count := search.count | search.step
        }
        search.step := search.step |>> 1
        search.below := search.below |>> 1
        when(search.lastStep) {
          state := AngleSearchState.UNFOLD
        }
      }
    }
    is(AngleSearchState.UNFOLD) {
      unfold.bin := (if (isPow2(unfold.n)) unfold.sum.resize(unfold.bw)
                     else Mux(unfold.sum === unfold.n, U(0, unfold.bw bits), unfold.sum.resize(unfold.bw)))
      state := AngleSearchState.FULL
    }
    is(AngleSearchState.FULL) {
      when(io.output.ready) {
        state := AngleSearchState.IDLE
      }
    }
  }
  io.output.valid := state === AngleSearchState.FULL
  io.output.item := item
  io.output.bin := unfold.bin
}

object AngleSearch {

  /** the fold's registers behind the moments' */
  val foldClocks: Int = 3

  /** a step's clocks: the index, the lookup (two), the products, their sum, the comparison, its register */
  val clocksPerStep: Int = 7

  /** the steps tried, largest first: m, m/2, .., 1 for m = binsPerOctant a power of two (else from the largest power
    * of two below m; an index past the octant is never taken) */
  def stepsOf(d: OrbDescriptorConfig): Seq[Int] =
    Iterator.iterate(1)(_ * 2).takeWhile(_ <= d.binsPerOctant).toSeq.reverse

  /** clocks from a corner's acceptance to the next acceptance when the consumer takes the result at once: the
    * acceptance, the fold, the steps, the unfolding, the result's clock */
  def clocks(d: OrbDescriptorConfig): Int = 1 + foldClocks + clocksPerStep * stepsOf(d).size + 1 + 1
}
