package orb

import spinal.core._
import spinal.lib._
import Arith._

/** A finished ORB feature. `descriptor(i)` is test i: byte i/8, bit i%8 of OpenCV's descriptor. With `frameEnd`
  * set, the item is no feature but the end of a processed frame, after all of that frame's features. */
case class OrbFeature(f: FrameConfig, h: HarrisConfig, d: OrbDescriptorConfig) extends Bundle {
  val x, y = UInt(f.coordWidth bits)
  val bin = UInt(d.binWidth bits)
  val score = UInt(h.scoreWidth bits)
  val descriptor = Bits(256 bits)
  /** the feature's frame is a keyframe */
  val keyframe = Bool()
  /** not a feature: the end of a processed frame, after all of its features (`end` says how it ended) */
  val frameEnd = Bool()
  val end = FrameEndInfo()
}

/** Rotated BRIEF, as `orb.model.OrbModel.descriptor`, on a store of smoothed rows.
  *
  * Store: `smoothedRows` (37 + slackRows) rows, one RAM per row used as a ring; the smoothed stream writes the row
  * of the current raw row. A corner's 37 rows are complete when row cy + 22 starts; from then on it has
  * `slackRows` row starts before its oldest row is overwritten, and is dropped (counted) if it is not done by then.
  *
  * Engines: two, in parallel; engine 0 reads every row RAM through its read/write port (never on the row being
  * written), engine 1 through the second port. The 256 tests go in pairs (2k, 2k + 1) through a pipeline that
  * rotates their points with the bin's cos/sin (x' = round(x cos - y sin), y' = round(x sin + y cos), half to even)
  * and decodes their rows; a pair whose four points lie in four different rows is read in one clock, otherwise its
  * tests go one at a time, and a test whose two points share a row takes two clocks. The decoded ports, the RAMs'
  * data and the selected values are each registered, so no path crosses two of the 45-row decode, the long wires
  * to and from the RAMs, and the compare.
  * Corners
  * are handed to the engines in turn and their features collected in the same turn, so they leave in raster
  * order. A consumer that waits holds the collection (two register stages, no FIFO RAM): the engines keep their
  * results, corners wait in the ready queue, and only a corner whose rows are overwritten before an engine takes it
  * is dropped (counted). The camera never waits. */
class DescriptorUnit(f: FrameConfig, h: HarrisConfig, d: OrbDescriptorConfig) extends Component {
  import OrbDescriptorConfig.sampleReach
  val io = new Bundle {
    val smoothed = slave Flow (SmoothedPixel(f))
    val corners = slave Flow (OrientedCorner(f, h, d))
    val features = master Stream (OrbFeature(f, h, d))
    val dropped = out UInt (f.counterWidth bits)
  }
  val rows = d.smoothedRows
  val slotWidth = log2Up(rows)
  val addrWidth = f.addrWidth
  val span = 2 * sampleReach // rows from the oldest to the newest of a patch
  /** v mod rows, for 0 <= v < 3 rows */
  def wrap(v: UInt): UInt = {
    val w = v.resize(slotWidth + 2)
    val once = Mux(w >= rows, w - rows, w)
    Mux(once >= rows, once - rows, once).resize(slotWidth)
  }

  // The smoothed stream: beat (x, y) carries the smoothed pixel (x - 3, y - 3) of raw row y.
  val stream = new Area {
    val s = io.smoothed
    val rowStart = s.valid && s.pixel.x === 0
    val frameStart = rowStart && s.pixel.y === 0
    val slot = Reg(UInt(slotWidth bits)) init 0
    val slotNow = Mux(rowStart, wrap(slot +^ 1), slot)
    val rowCount = Reg(UInt(OrientationUnit.rowCountWidth bits)) init 0
    val rowNow = Mux(rowStart, rowCount + 1, rowCount)
    val frame = Reg(UInt(OrientationUnit.frameTagWidth bits)) init 0
    val frameNow = Mux(frameStart, frame + 1, frame)
    when(rowStart) { slot := slotNow; rowCount := rowNow }
    when(frameStart) { frame := frameNow }
    // For the last rows: was the first pixel of the row processed, and in which frame. A corner's rows are good iff
    // the first pixel of its row cy + 22 was processed in its own frame (no fault before it) - the model's rule.
    case class RowInfo() extends Bundle { val active = Bool(); val frame = UInt(OrientationUnit.frameTagWidth bits) }
    val history = Vec.fill(d.slackRows)(Reg(RowInfo()))
    history.foreach(_.active.init(False))
    val thisRow = RowInfo(); thisRow.active := s.pixel.active; thisRow.frame := frameNow
    val historyNow = Mux(rowStart, Vec(thisRow +: history.init), history)
    when(rowStart) { history := historyNow }
    val write = s.valid && s.pixel.x >= OrbDescriptorConfig.blurRadius
    val writeAddr = (s.pixel.x - OrbDescriptorConfig.blurRadius).resize(addrWidth)
  }

  /** An oriented corner as it waits for an engine: without its moments, which only the bin needed. */
  case class ReadyCorner() extends Bundle {
    val corner = HarrisCorner(f, h)
    val bin = UInt(d.binWidth bits)
    val startRow = UInt(OrientationUnit.rowCountWidth bits)
    val frameTag = UInt(OrientationUnit.frameTagWidth bits)
    val keyframe, frameEnd = Bool()
    val end = FrameEndInfo()
  }
  val ready = StreamFifo(ReadyCorner(), d.readyQueueDepth)
  ready.io.push.valid := io.corners.valid
  ready.io.push.payload.assignSomeByName(io.corners.payload)
  val queueDrop = io.corners.valid && !ready.io.push.ready

  val tests = Pattern.tests
  val coordWidth = 6 // rotated offsets lie in [-18, 18]
  val csWidth = d.rotationFracBits + 2
  val cosSin = Vec((0 until d.angleBins).map { b =>
    val (c, s) = orb.model.OrbModel.cosSin(b, d)
    S(c, csWidth bits) ## S(s, csWidth bits)
  })

  /** v / 2^rotationFracBits rounded half to even (OpenCV's cvRound), as a rotated offset. */
  def roundOffset(v: SInt): SInt = {
    val fb = d.rotationFracBits
    val q = floorShift(v, fb)
    val r = v(fb - 1 downto 0).asUInt
    val half = U(BigInt(1) << (fb - 1), fb bits)
    val up = r > half || (r === half && q.lsb)
    (q + Mux(up, S(1, q.getWidth bits), S(0, q.getWidth bits))).resize(coordWidth)
  }

  case class EnginePort() extends Bundle {
    val enable = Bool()
    val address = UInt(addrWidth bits)
  }

  // The engine's front end: the 128 test pairs (2k, 2k+1) flow through a pipeline that rotates their four points
  // (a1, a2, b1, b2) and turns them into row RAMs (one-hot) and columns; it depends on nothing read, so it can be
  // as deep as timing wants. Its stages, one register each:
  val productWidth = 5 + csWidth
  case class PairIndex() extends Bundle { val k = UInt(7 bits) }
  case class PairPattern() extends Bundle { val p = Vec(SInt(5 bits), 8) } // x1 y1 x2 y2 of test 2k, then of 2k+1
  case class PairProducts() extends Bundle { val xc, ys, xs, yc = Vec(SInt(productWidth bits), 4) }
  case class PairRotated() extends Bundle { val rx, ry = Vec(SInt(coordWidth bits), 4) }
  case class PairReads() extends Bundle {
    val row = Vec(Bits(rows bits), 4)
    val col = Vec(UInt(addrWidth bits), 4)
    val sameA, sameB, dual = Bool()
  }
  val pairPatterns = Vec((0 until 128).map { k =>
    val ts = Seq(tests(2 * k), tests(2 * k + 1))
    ts.flatMap(t => Seq(t.x1, t.y1, t.x2, t.y2)).map(v => S(v, 5 bits).asBits).reduce(_ ## _)
  })

  val engines = for (e <- 0 until 2) yield new Area {
    val busy, done, drop = Reg(Bool()) init False
    val corner = Reg(ReadyCorner())
    val base = Reg(UInt(slotWidth bits))
    val rowsLeft = Reg(UInt(log2Up(d.slackRows + 1) bits))
    val bits = Reg(UInt(9 bits))
    val descriptor = Reg(Bits(256 bits))
    val cs = Reg(Bits(2 * csWidth bits))
    val c = cs(csWidth, csWidth bits).asSInt; val s = cs(0, csWidth bits).asSInt
    val restart = False.allowOverride() // a corner starts or is given up: empty the front end

    val fetch = new Area {
      val k = Reg(UInt(8 bits))
      val pairs = Stream(PairIndex())
      pairs.valid := busy && !k.msb
      pairs.k := k.resize(7)
      when(pairs.fire) { k := k + 1 }
    }
    val pattern = fetch.pairs.m2sPipe(flush = restart).map { i =>
      val o = PairPattern(); val bitsOf = pairPatterns(i.k)
      for (j <- 0 until 8) o.p(j) := bitsOf((7 - j) * 5, 5 bits).asSInt
      o
    }
    val products = pattern.m2sPipe(flush = restart).map { q =>
      val o = PairProducts()
      for (pt <- 0 until 4) {
        val x = q.p(2 * pt); val y = q.p(2 * pt + 1)
        o.xc(pt) := x * c; o.ys(pt) := y * s; o.xs(pt) := x * s; o.yc(pt) := y * c
      }
      o
    }
    // x' = round(x cos - y sin), y' = round(x sin + y cos)
    val rotated = products.m2sPipe(flush = restart).map { q =>
      val o = PairRotated()
      for (pt <- 0 until 4) {
        o.rx(pt) := roundOffset(q.xc(pt).resize(productWidth + 1) - q.ys(pt))
        o.ry(pt) := roundOffset(q.xs(pt).resize(productWidth + 1) + q.yc(pt))
      }
      o
    }
    // Rows are distinct iff the offsets are (the ring holds more than the 37 rows of a patch).
    val reads = rotated.m2sPipe(flush = restart).map { q =>
      val o = PairReads()
      for (pt <- 0 until 4) {
        val v = base.resize(slotWidth + 1) + (q.ry(pt).resize(coordWidth + 1) + sampleReach).asUInt.resize(slotWidth + 1)
        o.row(pt) := B((0 until rows).map(r => v === r || v === r + rows))
        o.col(pt) := (corner.corner.x.intoSInt + q.rx(pt)).asUInt.resize(addrWidth)
      }
      o.sameA := q.ry(0) === q.ry(1)
      o.sameB := q.ry(2) === q.ry(3)
      o.dual := q.ry.toSeq.combinations(2).map { case Seq(u, v) => u =/= v }.reduce(_ && _)
      o
    }.m2sPipe(flush = restart).s2mPipe(flush = restart)

    // Issue: a pair whose four points lie in four rows takes one clock; otherwise its tests go one after the
    // other, and a test whose two points share a row reads them in two clocks.
    val issue = new Area {
      val pair = reads
      val testB = Reg(Bool()) init False
      val second = Reg(Bool()) init False
      val go = busy && pair.valid
      val dual = pair.dual
      val same = Mux(testB, pair.sameB, pair.sameA)
      val first = !same || !second
      val last = !same || second
      val readA1 = go && (dual || (!testB && first))
      val readA2 = go && (dual || (!testB && last))
      val readB1 = go && (dual || (testB && first))
      val readB2 = go && (dual || (testB && last))
      pair.ready := go && (dual || (testB && last))
      when(go) {
        second := !last
        when(!dual && last) { testB := !testB }
      }
      when(restart) { testB := False; second := False }
    }
    // The decoded ports are registered beside the RAMs and their data registered on the way out, so the long
    // wires between the engine and the 45 RAMs start and end at flip-flops.
    val decoded = Vec(EnginePort(), rows)
    val ports = RegNext(decoded)
    ports.foreach(_.enable.init(False))
    for (r <- 0 until rows) {
      val hits = Seq(issue.readA1, issue.readA2, issue.readB1, issue.readB2).zipWithIndex
        .map { case (en, pt) => (en && issue.pair.payload.row(pt)(r), issue.pair.payload.col(pt)) }
      decoded(r).enable := hits.map(_._1).orR
      decoded(r).address := hits.map { case (hit, col) => Mux(hit, col, U(0, addrWidth bits)) }.reduceBalancedTree(_ | _)
    }

    // The RAMs' data, registered, three clocks after the issue; a register after the row selection; then the
    // comparisons.
    val readData = Vec(UInt(8 bits), rows)
    val readLatency = 4 // port register, RAM, data register, row selection
    val rowsD = Delay(issue.pair.row, readLatency - 1)
    def select(pt: Int): UInt = RegNext((0 until rows).map(r => readData(r) & U(8 bits, default -> rowsD(pt)(r))).reduceBalancedTree(_ | _))
    /** `b` when the data it goes with arrive; a restart voids what is in flight */
    def delayed(b: Bool): Bool = (0 until readLatency).foldLeft(b)((v, _) => RegNext(v && !restart) init False)
    val v1 = select(0); val v2 = select(1); val v3 = select(2); val v4 = select(3)
    val holdD = delayed(issue.go && !issue.dual && !issue.last)
    val completesD = delayed(issue.go && (issue.dual || issue.last))
    val dualD = delayed(issue.go && issue.dual)
    val testBD = delayed(issue.testB)
    val pairedD = delayed(issue.go && !issue.dual && issue.same)
    val p1 = Mux(testBD, v3, v1); val p2 = Mux(testBD, v4, v2)
    val held = Reg(UInt(8 bits))
    when(holdD) { held := p1 }
    val bitFirst = Mux(pairedD, held, p1) < p2
    val bitB = v3 < v4
    when(busy && completesD) {
      when(dualD) {
        descriptor := bitB ## (v1 < v2) ## descriptor(255 downto 2)
        bits := bits + 2
      } otherwise {
        descriptor := bitFirst ## descriptor(255 downto 1)
        bits := bits + 1
      }
    }
    when(busy && bits === 256) { busy := False; done := True }
  }

  // The store: one RAM per row. Port A writes the streamed row or serves engine 0; port B serves engine 1.
  val store = for (r <- 0 until rows) yield new Area {
    val ram = Mem(UInt(8 bits), f.maxWidth)
    val writeHere = stream.write && stream.slotNow === r
    val e0 = engines(0).ports(r); val e1 = engines(1).ports(r)
    engines(0).readData(r) := RegNext(ram.readWriteSync(Mux(writeHere, stream.writeAddr, e0.address), io.smoothed.smoothed,
      writeHere || e0.enable, writeHere))
    engines(1).readData(r) := RegNext(ram.readSync(e1.address, e1.enable))
  }

  // Two register stages to the output (no RAM): a consumer that waits holds the collection, then the engines,
  // then the dispatch; corners queue meanwhile and are dropped only when their rows run out.
  val output = Stream(OrbFeature(f, h, d))

  // Handing corners to the engines in turn.
  val dispatch = new Area {
    val next = Reg(UInt(1 bits)) init 0
    val head = ready.io.pop.m2sPipe() // a RAM output is too slow to decide on in the same clock
    val since = (stream.rowNow - head.startRow).asSInt // rows since the patch was complete (negative: not yet)
    val due = head.valid && !head.frameEnd && !since.msb
    val late = since.asUInt >= d.slackRows
    val row = stream.historyNow(since.asUInt.resize(log2Up(d.slackRows max 2)))
    val dataOk = row.active && row.frame === head.frameTag
    val engineFree = Vec(engines.map(e => !e.busy && !e.done))(next)
    // A frame end leaves when every corner before it has: both engines idle and collected.
    val marker = head.valid && head.frameEnd && engines.map(e => !e.busy && !e.done).andR
    head.ready := (due && (engineFree || late || !dataOk)) || (marker && output.ready)
    val start = due && engineFree && !late && dataOk
    val refused = head.fire && !start && !head.frameEnd
    for ((e, i) <- engines.zipWithIndex) when(start && next === i) {
      e.busy := True; e.drop := False; e.restart := True
      e.corner := head.payload
      // the newest patch row (cy + 18) is in the slot of raw row cy + 21, `since + 1` rows back
      e.base := wrap(stream.slotNow.resize(slotWidth + 2) + (2 * rows - 1 - span) - since.asUInt.resize(slotWidth + 2))
      e.rowsLeft := (d.slackRows - since.asUInt).resize(e.rowsLeft.getWidth)
      e.fetch.k := 0; e.bits := 0
      e.cs := cosSin(head.bin)
    }
    when(start) { next := next + 1 }
  }
  // A row start overwrites the oldest slot: an engine whose slack runs out gives up its corner.
  for (e <- engines) when(stream.rowStart && e.busy) {
    e.rowsLeft := e.rowsLeft - 1
    when(e.rowsLeft === 1 && e.bits =/= 256) { e.busy := False; e.done := True; e.drop := True; e.restart := True }
  }

  // Collecting in the same turn keeps raster order.
  val collect = new Area {
    val next = Reg(UInt(1 bits)) init 0
    val e = Vec(engines.map(_.done))(next)
    val drop = Vec(engines.map(_.drop))(next)
    val sel = engines.map(_.corner)
    val corner = Vec(sel)(next)
    output.valid := (e && !drop) || dispatch.marker
    output.frameEnd := dispatch.marker
    output.end := dispatch.head.end
    output.x := corner.corner.x
    output.y := corner.corner.y
    output.bin := corner.bin
    output.keyframe := Mux(dispatch.marker, dispatch.head.end.keyframe, corner.keyframe)
    output.score := corner.corner.score
    output.descriptor := Vec(engines.map(_.descriptor))(next)
    val engineDrop = e && drop
    when(e && (drop || output.ready)) {
      next := next + 1
      for ((en, i) <- engines.zipWithIndex) when(next === i) { en.done := False }
    }
    io.features << output.s2mPipe().m2sPipe()
  }

  val drops = Reg(UInt(f.counterWidth bits)) init 0
  drops := drops + U(queueDrop).resize(f.counterWidth) + U(dispatch.refused).resize(f.counterWidth) +
    U(collect.engineDrop).resize(f.counterWidth)
  io.dropped := drops
}

object DescriptorUnit {
  /** Clocks a descriptor spends in the engine beyond its read issues: the front end's stages before the first
    * issue, the read latency and the compare after the last (an upper bound). */
  val pipelineClocks: Int = 16

  /** Read issues of a bin's 256 tests: a pair (2k, 2k + 1) whose four points lie in four rows takes one clock,
    * otherwise each test one clock, or two when its two points share a row (the engine's issue rule). */
  def issueClocks(bin: Int, d: OrbDescriptorConfig): Int =
    orb.model.OrbModel.rotatedTests(bin, d).grouped(2).map { case Seq(a, b) =>
      val rows = Seq(a._2, a._4, b._2, b._4)
      if (rows.distinct.size == 4) 1
      else Seq(a, b).map(t => if (t._2 == t._4) 2 else 1).sum
    }.sum

  private val maxCache = scala.collection.concurrent.TrieMap[OrbDescriptorConfig, Int]()
  /** The most clocks one engine takes for a descriptor, over all bins. */
  def maxClocks(d: OrbDescriptorConfig): Int =
    maxCache.getOrElseUpdate(d, (0 until d.angleBins).map(issueClocks(_, d)).max + pipelineClocks)
}
