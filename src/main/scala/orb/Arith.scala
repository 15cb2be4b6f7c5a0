package orb

import spinal.core._
import spinal.lib._

/** Small fixed-point helpers shared by the stages. */
object Arith {

  /** operand width of the target's multiplier blocks (18 x 18 on Cyclone II and on the ECP5 proxy, unsigned too) */
  val multiplierWidth: Int = 18

  /** v * k for a constant k >= 0, `width` bits out: the shifted copies of v for k's set bits, reduced by 3:2
    * compressors (a LUT level each) into one adder: a single carry chain however many bits k has set. */
  def constMul(v: UInt, k: Int, width: Int): UInt = carrySaveSum(constTerms(v, k, width), width)

  /** `constMul` before its adder: the shifted copies reduced to at most two words whose sum (modulo 2^width) is
    * v * k, for a carry chain a register later */
  def constMulWords(v: UInt, k: Int, width: Int): Seq[UInt] = carrySaveWords(constTerms(v, k, width), width)

  private def constTerms(v: UInt, k: Int, width: Int): Seq[UInt] = {
    require(k >= 0)
    (0 until 31).filter(b => ((k >> b) & 1) == 1).map(b => v.resize(width) |<< b)
  }

  /** one 3:2 compressor over words (a LUT level): a sum word and a carry word with the same total; the carry word's
    * free low bit holds the one when `plusOne` */
  private def compress(a: UInt, b: UInt, c: UInt, plusOne: Boolean): Seq[UInt] = {
    val sum = a ^ b ^ c
    val carry = (((a & b) | (a & c) | (b & c)) |<< 1) | U(if (plusOne) 1 else 0, a.getWidth bits)
    Seq(sum, carry)
  }

  /** `terms` reduced by 3:2 compressors to at most two words with the same sum (plus one if `plusOne`: three terms
    * or more, the one in the first carry word's free low bit) modulo 2^width */
  def carrySaveWords(terms: Seq[UInt], width: Int, plusOne: Boolean = false): Seq[UInt] = {
    require(!plusOne || terms.size >= 3, "the one takes a carry word's free bit: three terms or more")
    terms.map(_.resize(width)) match {
      case Seq(a, b, c, rest @ _*) => carrySaveWords(rest ++ compress(a, b, c, plusOne), width)
      case few => few
    }
  }

  /** the sum of `terms` (plus one if `plusOne`) modulo 2^width: three terms into a sum and a carry word while more
    * than two remain, then one adder; the one takes the first carry word's free low bit */
  def carrySaveSum(terms: Seq[UInt], width: Int, plusOne: Boolean = false): UInt =
    terms.map(_.resize(width)) match {
      case Seq() => U(if (plusOne) 1 else 0, width bits)
      case Seq(a) => if (plusOne) a + 1 else a
      case Seq(a, b) if !plusOne => a + b
      case Seq(a, b) => carrySaveSum(Seq(a, b, U(1, width bits)), width)
      case Seq(a, b, c, rest @ _*) => carrySaveSum(rest ++ compress(a, b, c, plusOne), width)
    }

  /** `carrySaveSum` of signed terms (two's complement modulo 2^width) */
  def carrySaveSumSigned(terms: Seq[SInt], width: Int, plusOne: Boolean = false): SInt =
    carrySaveSum(terms.map(_.resize(width).asUInt), width, plusOne).asSInt

  /** v * k for a constant k >= 0 and a signed v, as shifted copies added and subtracted (k = 2^a - 2^b - ... where
    * that takes fewer terms); `width` bits out. */
  def constMulSigned(v: SInt, k: Int, width: Int): SInt = {
    require(k >= 0)
    // canonical signed digits: no two adjacent non-zero digits
    val digits = scala.collection.mutable.ArrayBuffer[(Int, Int)]()
    var rest = k
    var bit = 0
    while (rest != 0) {
      if ((rest & 1) == 1) {
        val d = 2 - (rest & 3) // 1 when rest = ...01, -1 when rest = ...11
        digits += ((bit, d))
        rest -= d
      }
      rest >>= 1
      bit += 1
    }
    val terms = digits.map { case (b, d) => (v.resize(width) |<< b, d) }
    if (terms.isEmpty) S(0, width bits)
    else {
      val (pos, neg) = terms.partition(_._2 > 0)
      val plus = if (pos.isEmpty) S(0, width bits) else pos.map(_._1).reduceBalancedTree(_ + _)
      if (neg.isEmpty) plus else plus - neg.map(_._1).reduceBalancedTree(_ + _)
    }
  }

  /** Inclusive prefix sums e(0) + ... + e(k) for each k of `wanted` (Kogge-Stone, only the sums those need), `width`
    * bits, with a register after every `levelsPerStage` adder levels and after the last; returns the sums and the
    * clocks they take. */
  def prefixSums(
      e: collection.IndexedSeq[SInt],
      wanted: Seq[Int],
      width: Int,
      levelsPerStage: Int
  ): (Map[Int, SInt], Int) = {
    val levels = log2Up(e.size)
    val need = Array.fill(levels + 1)(Set[Int]())
    need(levels) = wanted.toSet
    for (j <- levels - 1 to 0 by -1) need(j) = need(j + 1) ++ need(j + 1).filter(_ >= (1 << j)).map(_ - (1 << j))
    var current: Map[Int, SInt] = need(0).map(k => k -> e(k).resize(width)).toMap
    var clocks = 0
    for (j <- 0 until levels) {
      val span = 1 << j
      var next = need(j + 1).map(k => k -> (if (k >= span) current(k) + current(k - span) else current(k))).toMap
      if ((j + 1) % levelsPerStage == 0 || j == levels - 1) {
        next = next.map { case (k, v) => k -> RegNext(v) }
        clocks += 1
      }
      current = next
    }
    (current, clocks)
  }

  /** A constant table read in two steps, so that no step is a deep lookup: `parts` sub-tables indexed by the low
    * bits of the index (`words`), whose words the caller registers with the high bits (`part`), then the word of that
    * part (`pick`). */
  final case class SplitTable(table: Seq[BigInt], width: Int, parts: Int) {
    require(isPow2(parts) && table.nonEmpty && table.forall(v => v >= 0 && v < (BigInt(1) << width)))
    val partSize: Int = 1 << log2Up((table.size + parts - 1) / parts)

    /** part `q`'s word at `index` (its low bits) */
    private def word(q: Int, index: UInt): UInt = {
      val entries = (0 until partSize).map(i => table.lift(q * partSize + i).getOrElse(BigInt(0)))
      Vec(entries.map(v => U(v, width bits)))(within(index))
    }
    def words(index: UInt): Vec[UInt] = Vec((0 until parts).map(word(_, index)))

    /** the bits of `index` a part's word reads (its low bits; `part` takes the rest) */
    def within(index: UInt): UInt = index.resize(log2Up(partSize))

    /** `words`, each part read with its own copy of the index (the copies kept apart: no one register drives
      * every part) */
    def wordsEach(indices: Seq[UInt]): Vec[UInt] = {
      require(indices.size == parts)
      Vec(indices.zipWithIndex.map { case (index, q) => word(q, index) })
    }
    def part(index: UInt): UInt = {
      val low = log2Up(partSize)
      // a slice, not a shift: plain Verilog without width warnings
      if (index.getWidth <= low) U(0, log2Up(parts) bits) else index(index.high downto low).resize(log2Up(parts))
    }
    def pick(words: Vec[UInt], part: UInt): UInt = words(part)

    /** `pick` with a copy of the part per group of bits (equal groups, the first in the low bits): no one register
      * selects every bit */
    def pickEach(words: Vec[UInt], partCopies: Seq[UInt]): UInt = {
      require(width % partCopies.size == 0, s"$width bits in ${partCopies.size} equal groups")
      val g = width / partCopies.size
      // Cat of a sequence puts its first element in the low bits
      Cat(partCopies.zipWithIndex.map { case (part, i) => Vec(words.map(_(i * g, g bits)))(part) }).asUInt
    }

    /** `pick` in two steps, for a register between them: each half of the parts narrowed to its word by the part's
      * low bits (`halves`, the part a copy per half), then the half by the part's top bit (`pickHalf`, `part.msb`) */
    def halves(words: Vec[UInt], partCopies: Seq[UInt]): Vec[UInt] = {
      require(parts >= 2, "a table in one part has no halves")
      require(partCopies.size == 2, "a copy of the part per half")
      val half = parts / 2
      Vec((0 until 2).map(u => Vec(words.slice(u * half, u * half + half))(partCopies(u).resize(log2Up(half)))))
    }
    def pickHalf(halves: Vec[UInt], upper: Bool): UInt = halves(U(upper))
  }

  /** The last `n` values of `v` (element 0 = `v` itself), advancing only on valid pixels: the horizontal extent of
    * a window, whatever the blanking. */
  def lastValid[T <: Data](v: T, n: Int, valid: Bool): Vec[T] = History[T](v, n, valid, null.asInstanceOf[T])

  /** `a > b` (`a >= b` if `orEqual`) in `parts` parts side by side, for a register between
    * them and their combination (`combineParts`): no carry through the whole width in one clock. From bit 0 up:
    * each part's `>` and `===` from the highest part down, then the lowest part's comparison. */
  def comparedInParts(a: UInt, b: UInt, orEqual: Boolean, parts: Int): Bits = {
    val width = a.getWidth max b.getWidth
    require(parts >= 1 && parts <= width, s"$parts parts of $width bits")
    val (aw, bw) = (a.resize(width), b.resize(width))
    // part k holds bits cuts(k) until cuts(k + 1), part 0 the lowest
    val cuts = (0 to parts).map(k => width * k / parts)
    def part(v: UInt, k: Int): UInt = v(cuts(k + 1) - 1 downto cuts(k))
    val low = if (orEqual) part(aw, 0) >= part(bw, 0) else part(aw, 0) > part(bw, 0)
    val upper = (parts - 1 to 1 by -1).flatMap(k => Seq(part(aw, k) > part(bw, k), part(aw, k) === part(bw, k)))
    // Cat of a sequence puts its first element in the low bits
    Cat(upper :+ low)
  }

  /** the comparison of `comparedInParts` from its parts */
  def combineParts(h: Bits): Bool = {
    val upper = (h.getWidth - 1) / 2
    (0 until upper).foldRight(h.msb)((k, lower) => h(2 * k) || (h(2 * k + 1) && lower))
  }

  /** A score's level (`orb.model.BudgetModel.levelOf`: its leading one's position above the `fb` bits after it)
    * in steps, each for a register after it. First: the leading one's position, `log2Up(score width)` bits. */
  def leadOf(score: UInt): UInt = {

    /** (any bit set, the highest set bit's position) of `bits`, as a balanced tree of halves */
    def highest(bits: Seq[Bool]): (Bool, UInt) =
      if (bits.size == 1) (bits.head, U(0, 0 bits))
      else {
        val half = 1 << (log2Up(bits.size) - 1)
        val (loAny, lo) = highest(bits.take(half))
        val (hiAny, hi) = highest(bits.drop(half))
        val width = log2Up(bits.size)
        (loAny || hiAny, Mux(hiAny, True ## hi.resize(width - 1), False ## lo.resize(width - 1)).asUInt)
      }
    highest(score.asBools.toSeq)._2.resize(log2Up(score.getWidth))
  }

  /** Then the `fb` bits after the leading one, coarsely: the score shifted down by the leading one's position
    * without its last two bits (a shift by a multiple of 4), `fb + 3` bits kept. */
  def afterLeadCoarse(score: UInt, lead: UInt, fb: Int): UInt = {
    val byFours = lead(lead.high downto 2) @@ U(0, 2 bits)
    ((score @@ U(0, fb bits)) >> byFours).resize(fb + 3)
  }

  /** Last: the rest of the shift (the position's last two bits), then the level: the position and the bits. */
  def rankFrom(coarse: UInt, lead: UInt, fb: Int, width: Int): UInt =
    if (fb == 0) lead.resize(width)
    else (lead @@ (coarse >> lead(1 downto 0)).resize(fb)).resize(width)

  /** Arithmetic shift right (floor), written as a slice so that the Verilog has no width-changing shift. */
  def floorShift(v: SInt, n: Int): SInt = if (n == 0) v else v(v.high downto n)
  def floorShift(v: UInt, n: Int): UInt = if (n == 0) v else v(v.high downto n)
}
