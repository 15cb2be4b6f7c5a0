package orb

import spinal.core._
import spinal.lib._
import spinal.lib.misc.pipeline._
import Arith._
import orb.Pipes.keptApart

/** Where each step of the detector sits in its pipeline (node index); a later node means more registers in
  * between. Steps of one node share a clock; the default registers the input column three times (it comes from
  * the line buffer's RAM, which the smoother and the orientation unit share: one register may lie by the RAM, one
  * by the Sobel adders and one on the wire between them), puts a register after every adder and multiplier (in
  * the Sobel and window sums after every LUT level and every carry chain: never both in one clock), and gives the
  * gradients two registers before the products (the second becomes the multiplier block's input register, the
  * first stays beside the Sobel adders, so no adder drives the long wires to the multipliers) and the products two
  * after them (the first is the multiplier block's output register, the second lies beside the adders that take
  * them). */
case class HarrisStages(
    sobel: Int = 3,
    sobelPairs: Int = 4,
    gradients: Int = 5,
    products: Int = 7,
    columnPre: Int = 9,
    columnWords: Int = 10,
    columnHalves: Int = 11,
    columnSum: Int = 12,
    rowPre: Int = 13,
    rowWords: Int = 14,
    rowHalves: Int = 15,
    rowSum: Int = 16,
    trace: Int = 17,
    multiply: Int = 19,
    kTrace: Int = 21,
    kTraceSum: Int = 22,
    response: Int = 23,
    score: Int = 24,
    suppressRead: Int = 25,
    suppressParts: Int = 3,
    segmentCompare: Int = 3,
    segmentArc: Int = 4,
    segmentAny: Int = 5
) {
  private val order = Seq(
    sobel,
    sobelPairs,
    gradients,
    products,
    columnPre,
    columnWords,
    columnHalves,
    columnSum,
    rowPre,
    rowWords,
    rowHalves,
    rowSum,
    trace,
    multiply,
    kTrace,
    kTraceSum,
    response,
    score,
    suppressRead
  )
  require(
    order.head >= 0 && order.zip(order.tail).forall { case (a, b) => b > a },
    "each step needs the previous one's registered result: node indices must strictly increase"
  )
  require(suppressParts >= 1, "the suppression compares scores in one part or more")
  require(
    segmentCompare >= 0 && segmentArc > segmentCompare && segmentAny > segmentArc && segmentAny <= response,
    "the segment test compares, then tests each arc a node later and ORs the arcs a node after that, at the latest " +
      "where the score is formed"
  )

  /** the window column arrives `RowWindow.latency` nodes after it is read (through the RAM's output register) and is
    * registered once more before it is compared (in `suppressParts` parts side by side); each comparison's parts are
    * combined a node later, the comparisons and the position's tests a node after that, and the corner leaves one
    * node later still */
  def window: Int = suppressRead + RowWindow.latency
  def suppress: Int = window + 1
  def combine: Int = suppress + 1
  def decide: Int = combine + 1
  def output: Int = decide + 1

  /** clocks from a column at the input to the corner it completes at the output */
  def latency: Int = output
}

/** Harris-Stephens detector over the shared raw line buffer (see `HarrisConfig` for the arithmetic and
  * `orb.model.HarrisModel` for the same steps in plain Scala).
  *
  * Input: one column of the newest `HarrisConfig.rawRows` rows per pixel. The gradients of 7 rows are computed
  * side by side from those 9 raw rows, so no gradient or product is ever stored: the only memories are the
  * shared raw rows and 2 rows of scores for the suppression. A corner at (x, y) leaves with the input pixel
  * (x + 5, y + 5), `stages.latency` clocks after it. The pixels' positions must be the `FrameTracker`'s (they are
  * counted again from their line and frame starts, see `position`). */
class HarrisDetector(f: FrameConfig, h: HarrisConfig, columnRows: Int, stages: HarrisStages = HarrisStages())
    extends Component {
  require(columnRows >= HarrisConfig.rawRows)
  val io = new Bundle {
    val columns = slave Flow (LineColumn(f, columnRows))
    val geometry = in(FrameGeometry(f))
    val control = in(CornerParamsHw())
    val corners = master Flow (CornerHw(f, h))
    val frameEnds = master Flow (FrameEndHw())
    val cornerCount = out(f.counter())
  }
  val reach = HarrisConfig.reach
  // the stages: `at(i)` is the beat i clocks after the input, a register between each
  val pipeline = new StagePipeline
  def at(i: Int): Node = pipeline.node(i)

  // The run-time parameters, registered here: they come from the register file across the chip and fan out to
  // every comparator (a write takes effect a clock later; they are constant within a frame).
  val control = RegNext(io.control)
  // The frame's geometry, registered twice here too (the tracker is across the chip): it changes only at the start of
  // the frame after one that measured it (which produces nothing), and a frame's first beats reach the border test
  // many clocks later (see `suppress`).
  val geometry = RegNext(RegNext(io.geometry))
  val COLUMN = Payload(Vec(UInt(8 bits), HarrisConfig.rawRows))
  val PIXEL = Payload(TrackedPixel(f))
  at(0).driveFrom(io.columns) { (n, p) =>
    n(PIXEL) := p.pixel
    for (r <- 0 until HarrisConfig.rawRows) n(COLUMN)(r) := p.column(r)
  }

  /** A copy of node `i`'s valid (a register kept apart, from node `i - 1`'s): each window's shift register is
    * enabled by one of its own, not by the register that also drives the node's stage (node 0's is the input's). */
  private def validCopy(i: Int): Bool =
    if (i == 0) at(0).isValid else keptApart(RegNext(at(i - 1).isValid) init False)

  /** Binomial 1 6 15 20 15 6 1 of `values`, every step from registers with one LUT level or
    * one carry chain, never both in one clock: the symmetric pairs and 20 d at `pre` (four adders), a + 6 b and
    * 15 c + 20 d = 16 c + ~c + 1 + 20 d each as two carry-save words at `words` (a LUT level), each pair of words
    * added at `halves`, the halves at `sum`. The row pass's rounding bias is in its last value already (see
    * `biasedLast`), so no step adds three terms. */
  private def binomial7(
      values: collection.IndexedSeq[SInt],
      pre: Node,
      words: Node,
      halves: Node,
      sum: Node,
      width: Int
  ): SInt = {
    require(values.size == 7)
    def wide(i: Int): UInt = values(i).resize(width).asUInt
    val PAIRS = pre.insert(Vec(
      wide(0) + wide(6),
      wide(1) + wide(5),
      wide(2) + wide(4),
      (wide(3) |<< 4) + (wide(3) |<< 2)
    ))
    val Seq(a, b, c, d20) = words(PAIRS).toSeq
    val WORDS = words.insert(Vec(
      carrySaveWords(Seq(a, b |<< 2, b |<< 1), width) ++
        carrySaveWords(Seq(c |<< 4, ~c, d20), width, plusOne = true)
    ))
    val w = halves(WORDS)
    val HALVES = halves.insert(Vec(w(0) + w(1), w(2) + w(3)))
    (sum(HALVES)(0) + sum(HALVES)(1)).asSInt
  }

  /** The last 7 values of `v` that the row window sums (element 0 = `v`), the last with `bias` added as it is
    * loaded (an adder from the register before it): the outer pair then sums the bias without a third term. */
  private def biasedLast(v: SInt, width: Int, bias: SInt, valid: Bool): Vec[SInt] = {
    val first = lastValid(v.resize(width), 6, valid)
    Vec(first :+ RegNextWhen(first.last + bias, valid))
  }

  // Column index r is r rows above the newest; gradients are taken for the 7 rows centred on indices 1..7,
  // at column x-1 of the newest pixel x. Each Sobel sum of 1 2 1 weights as two adders of pairs: gx of row r is
  // d(r-1) + 2 d(r) + d(r+1), d(j) = p(x, j) - p(x-2, j), so (d(r-1) + d(r)) + (d(r) + d(r+1)); gy likewise over
  // the three columns of e(c) = p(c, r-1) - p(c, r+1). The differences in one step, the pairs in the next, the
  // gradients in the one after that: an adder a clock, each from registers.
  val sobelNode = at(stages.sobel)
  val sobel = new sobelNode.Area {
    val cols = lastValid(this(COLUMN), 3, validCopy(stages.sobel)) // 0: column x, 1: x-1, 2: x-2
    val gw = h.gradWidth
    def px(c: Int, r: Int): SInt = cols(c)(r).intoSInt.resize(gw)
    // Index r-1 is the row below r (newer), so gy = bottom - top as in OpenCV.
    val ACROSS = insert(Vec((0 until 9).map(r => px(0, r) - px(2, r))))
    val DOWN = insert(Vec((1 to 7).map(r => Vec((0 until 3).map(c => px(c, r - 1) - px(c, r + 1))))))
    val pairsNode = at(stages.sobelPairs)
    val across = pairsNode(ACROSS)
    val down = pairsNode(DOWN)
    val ACROSS_PAIRS = pairsNode.insert(Vec((0 until 8).map(j => across(j) + across(j + 1))))
    val DOWN_PAIRS = pairsNode.insert(Vec(down.map(e => Vec(e(0) + e(1), e(1) + e(2)))))
    val gradNode = at(stages.gradients)
    val GX = gradNode.insert(Vec((0 until 7).map(i => gradNode(ACROSS_PAIRS)(i) + gradNode(ACROSS_PAIRS)(i + 1))))
    val GY = gradNode.insert(Vec(gradNode(DOWN_PAIRS).map(p => p(0) + p(1))))
  }

  // Segment test at the window's centre (x - 4, y - 4 of the newest pixel x, y): its 7x7 raw pixels are rows
  // 1..7 of the 7 columns before the newest, the same rows and columns the gradients cover.
  val segment = h.segment.map { sc =>
    val compareNode = at(stages.segmentCompare)
    val arcNode = at(stages.segmentArc)
    new Area {
      // the window in two bands of rows (row indices 1 .. split and split + 1 .. 7), each shifted by a copy of the
      // node's valid of its own: one register would enable all 448 bits of the window. At the Sobel's node its
      // first three columns are the Sobel's (x, x - 1, x - 2), and the bands start from its last.
      val split = 4
      val shared = if (stages.segmentCompare == stages.sobel) 2 else 0
      val first: Vec[UInt] = if (shared > 0) sobel.cols(shared) else compareNode(COLUMN)
      val upper = lastValid(Vec(first.slice(1, split + 1)), 8 - shared, validCopy(stages.segmentCompare))
      val lower = lastValid(Vec(first.slice(split + 1, 8)), 8 - shared, validCopy(stages.segmentCompare))

      /** column x - j, row index i + 1 */
      def win(j: Int, i: Int): UInt =
        if (j < shared) sobel.cols(j)(i + 1)
        else if (i < split) upper(j - shared)(i)
        else lower(j - shared)(i - split)
      def px(dx: Int, dy: Int): UInt = win(4 - dx, 3 - dy) // dy > 0 is down, a newer row
      // centre + t and centre - t, registered a beat ahead from the pixel that becomes the centre (the window
      // advances with valid pixels), so that no adder lies before the 32 comparisons; a copy of each per arc of
      // the circle (kept apart), so that no one register feeds all 16 comparisons
      val t = control.segmentThreshold
      val upcoming = px(1, 0)
      val copies = SegmentTestConfig.thresholdCopies
      val brighterThan = Seq.fill(copies)(keptApart(RegNextWhen(upcoming +^ t, compareNode.isValid)))
      val darkerThan = Seq.fill(copies)(
        keptApart(RegNextWhen(
          upcoming.intoSInt.resize(SegmentTestConfig.signedWidth) - t.intoSInt.resize(SegmentTestConfig.signedWidth),
          compareNode.isValid
        ))
      )
      val ring = SegmentTestConfig.circle.map { case (dx, dy) => px(dx, dy) }
      def arcOf(i: Int): Int = i * copies / ring.size
      val BRIGHTER = compareNode.insert(Vec(ring.zipWithIndex.map { case (p, i) => p > brighterThan(arcOf(i)) }).asBits)
      val DARKER = compareNode.insert(
        Vec(ring.zipWithIndex.map { case (p, i) =>
          p.intoSInt.resize(SegmentTestConfig.signedWidth) < darkerThan(arcOf(i))
        }).asBits
      )
      // each arc's test (all its pixels brighter, or all darker) registered, then their OR
      def arcs(b: Bits): Seq[Bool] = (0 until 16).map(s => (0 until sc.arc).map(k => b((s + k) % 16)).andR)
      val ARCS = arcNode.insert(Cat(arcs(arcNode(BRIGHTER)) ++ arcs(arcNode(DARKER))))
      val PASSES = at(stages.segmentAny).insert(at(stages.segmentAny)(ARCS).orR)
    }
  }

  // Exact products; 11x11 bits, one embedded multiplier each.
  val productsNode = at(stages.products)
  val products = new productsNode.Area {
    val XX = insert(Vec(sobel.GX.map(g => (g * g).resize(h.crossWidth))))
    val YY = insert(Vec(sobel.GY.map(g => (g * g).resize(h.crossWidth))))
    val XY = insert(Vec((0 until 7).map(i => (sobel.GX(i) * sobel.GY(i)).resize(h.crossWidth))))
  }

  // Vertical pass of the window: exact sums over the 7 rows of one column.
  val column = new Area {
    val w = h.columnCrossWidth
    def sum(products: Payload[Vec[SInt]]): SInt = binomial7(
      at(stages.columnPre)(products),
      at(stages.columnPre),
      at(stages.columnWords),
      at(stages.columnHalves),
      at(stages.columnSum),
      w
    )
    val VXX = at(stages.columnSum).insert(sum(products.XX))
    val VYY = at(stages.columnSum).insert(sum(products.YY))
    val VXY = at(stages.columnSum).insert(sum(products.XY))
  }

  // Horizontal pass over the last 7 column sums (they advance with valid pixels only), then the window shift.
  val row = new Area {
    val pre = at(stages.rowPre)
    val w = h.windowCrossWidth
    // Rounded half up: the floor's bias of half a unit on every window sum would show in det - k tr^2.
    val half = if (h.windowShift == 0) S(0, w bits) else S(BigInt(1) << (h.windowShift - 1), w bits)
    def window(v: Payload[SInt]): SInt =
      floorShift(
        binomial7(
          biasedLast(pre(v), w, half, validCopy(stages.rowPre)),
          pre,
          at(stages.rowWords),
          at(stages.rowHalves),
          at(stages.rowSum),
          w
        ),
        h.windowShift
      )
    val SXX = at(stages.rowSum).insert(window(column.VXX).resize(h.sSquareWidth + 1).asUInt.resize(h.sSquareWidth))
    val SYY = at(stages.rowSum).insert(window(column.VYY).resize(h.sSquareWidth + 1).asUInt.resize(h.sSquareWidth))
    val SXY = at(stages.rowSum).insert(window(column.VXY).resize(h.sCrossWidth))
  }

  // The trace in its own step, so that every multiplier input is a plain register (the block's input register).
  val traceNode = at(stages.trace)
  val trace = new traceNode.Area {
    val TRACE = insert((row.SXX +^ row.SYY).resize(h.traceWidth))
  }

  // det and trace^2: three multipliers of at most 18x18 bits with the default shifts, a node after the trace at the
  // earliest (`multiply` > `trace` + 1 puts a plain register before the multiplier's own input register).
  val multiplyNode = at(stages.multiply)
  val multiply = new multiplyNode.Area {
    val XXYY = insert(row.SXX * row.SYY)
    val XY2 = insert((row.SXY * row.SXY).asUInt.resize(2 * h.sCrossWidth - 2))
    val TR2 = insert(trace.TRACE * trace.TRACE)
  }

  val kTraceNode = at(stages.kTrace)
  val kTrace = new kTraceNode.Area {
    // kNum * tr^2 by shifts and adds (kNum is a small constant): the shifted copies carry-saved into two words here,
    // their one carry chain a node later, from registers (a LUT level and a long carry chain do not fit one clock)
    val KTR2_WORDS = insert(Vec(constMulWords(multiply.TR2, h.kNum, h.kTrace2Width + h.kShift)))
    val DET = insert(multiply.XXYY.intoSInt.resize(h.detWidth) - multiply.XY2.intoSInt.resize(h.detWidth))
  }
  val kTraceSumNode = at(stages.kTraceSum)
  val kTraceSum = new kTraceSumNode.Area {
    val KTR2 = insert(floorShift(kTrace.KTR2_WORDS.reduce(_ + _), h.kShift).resize(h.kTrace2Width))
  }

  // The response, then the score a node later: the response's sign (the end of its carry chain) and the segment
  // test reach the score's clearing from registers.
  val responseNode = at(stages.response)
  val scoreNode = at(stages.score)
  val response = new responseNode.Area {
    val R = insert(kTrace.DET.resize(h.responseWidth) - kTraceSum.KTR2.intoSInt.resize(h.responseWidth))
    // A pixel that fails the segment test scores 0: it can neither be a corner nor suppress a neighbour.
    val CANDIDATE = insert(segment.fold(True)(seg => !control.segmentTest || seg.PASSES))
    val shifted = floorShift(scoreNode(R), h.scoreShift)
    val SCORE = scoreNode.insert(
      Mux(shifted.sign || !scoreNode(CANDIDATE), U(0, h.scoreWidth bits), shifted.asUInt.resize(h.scoreWidth))
    )
  }

  // The beat's position is not carried through the stages: a beat at x = 0 starts a line and one at x = y = 0 a
  // frame (the tracker's positions only start over there; they step by one per beat and saturate at the limits
  // otherwise), two flags compared a node after the input (from its register); a counter a node before the
  // suppression's read follows them, so that the read's node holds the beat's position in a register (the node
  // holds the beat the counter took a clock earlier).
  val position = new Area {
    val compared = at(1)
    val LINE_START = compared.insert(compared(PIXEL).x === 0)
    val FRAME_START = compared.insert(compared(PIXEL).x === 0 && compared(PIXEL).y === 0)
    val counting = at(stages.suppressRead - 1)
    val x, y = Reg(f.coord()) init 0
    when(counting.isValid) {
      x := Mux(counting(LINE_START), U(0, f.coordWidth bits), Mux(x === f.maxWidth, x, x + 1))
      when(counting(FRAME_START)) {
        y := 0
      } elsewhen (counting(LINE_START) && y =/= f.maxHeight) {
        y := y + 1
      }
    }
    val X = at(stages.suppressRead).insert(x)
    val Y = at(stages.suppressRead).insert(y)
  }

  // 3x3 suppression over the last 3 rows of scores (its own small row window) and 3 columns of registers.
  val suppress = new Area {
    val read = at(stages.suppressRead)
    val scores = new RowWindow(RowWindowConfig(3, f.maxWidth, h.scoreWidth))
    val WINDOW = at(stages.window).insert(scores.column(read.isValid, read(position.X), read(response.SCORE).asBits))
    val n = at(stages.suppress)
    val shift = validCopy(stages.suppress)
    val cols = lastValid(Vec(n(WINDOW).map(_.asUInt)), 3, shift) // 0: x, 1: x-1 (centre), 2: x-2
    // Row 0 is the newest (below the centre), row 2 the oldest (above).
    val centre = keptApart(cols(1)(1))
    val earlier = Seq(cols(2)(2), cols(1)(2), cols(0)(2), cols(2)(1))
    val later = Seq(cols(0)(1), cols(2)(0), cols(1)(0), cols(0)(0))
    // the centre's copies (kept apart, as the centre itself), each for a third of its nine comparisons: no one
    // register reaches every comparison's parts
    val centreCopies = Seq.fill(3)(keptApart(RegNextWhen(cols(0)(1), shift)))
    // the threshold's comparison first, then the neighbours'
    val comparisons = 1 + earlier.size + later.size
    def centreFor(comparison: Int): UInt = centreCopies(comparison * centreCopies.size / comparisons)
    val p = n(PIXEL)
    // (v - reach) in [border, size - 1 - border], without unsigned wrap-around for small frames: v >= border + reach
    // and v < size + reach - border, each one comparison of the beat's position with a constant or a register
    // (the size's bound registered beside them), tested a stage ahead from the same beat's position. The bound
    // from registers in two steps (an adder and a comparison with constants side by side, then the choice): the
    // geometry settles long before a frame's first beat reaches here (see `geometry`).
    val w = at(stages.window)
    def below(size: UInt): UInt = {
      val end = size +^ reach
      val none = RegNext(end < h.border)
      val bound = RegNext(end - h.border)
      RegNext(Mux(none, U(0, widthOf(end) bits), bound))
    }
    def inside(v: UInt, size: UInt): Seq[Bool] = Seq(v >= h.border + reach, v < below(size))
    val INSIDE = w.insert(Vec(inside(w(position.X), geometry.width) ++ inside(w(position.Y), geometry.height)))
    // The comparisons with the centre in parts side by side, registered; each combined a node later, then the
    // tests combined into the corner's flag. The threshold's bits above a score's decide alone (a register).
    def parts(a: UInt, b: UInt, orEqual: Boolean): Bits = Arith.comparedInParts(a, b, orEqual, stages.suppressParts)
    val t = control.threshold
    val unreachable = RegNext(if (h.scoreWidth < widthOf(t)) t(t.high downto h.scoreWidth).orR else False) init False
    val FLAGS = n.insert(Vec(Seq(p.active, !unreachable) ++ n(INSIDE)))
    val COMPARED = n.insert(
      Vec(Seq(parts(centreFor(0), control.threshold.resize(h.scoreWidth), orEqual = false)) ++
        earlier.zipWithIndex.map { case (e, i) => parts(centreFor(1 + i), e, orEqual = false) } ++
        later.zipWithIndex.map { case (l, i) => parts(centreFor(1 + earlier.size + i), l, orEqual = true) })
    )
    val CENTRE = n.insert(centre)
    val c = at(stages.combine)
    val HOLDS = c.insert(Vec(c(FLAGS).asBits.andR +: c(COMPARED).map(Arith.combineParts)))
    val d = at(stages.decide)
    val TESTS = d.insert(d(HOLDS).asBits.andR)
    // the corner's position, the centre's, registered with the tests
    val CX = n.insert(n(position.X) - reach)
    val CY = n.insert(n(position.Y) - reach)
  }

  val outputNode = at(stages.output)
  val output = new outputNode.Area {
    io.corners.valid := isValid && outputNode(suppress.TESTS)
    io.corners.x := outputNode(suppress.CX)
    io.corners.y := outputNode(suppress.CY)
    io.corners.score := outputNode(suppress.CENTRE)
    io.frameEnds.valid := isValid && outputNode(PIXEL).end.now
    io.frameEnds.payload := outputNode(PIXEL).end.info
    val count = Reg(f.counter()) init 0
    when(io.corners.valid) { count := count + 1 }
    io.cornerCount := count
  }

  pipeline.build()
  Pipes.keepValidsApart(pipeline)
  // the registered column kept apart: the smoother's centre tap is its twin (see `Smoother`)
  keptApart(at(1)(COLUMN))
}
