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
  * written), engine 1 through the second port. An engine evaluates two tests per clock when their four points lie
  * in four different rows, else one: points rotated on the fly with the bin's cos/sin (x' = round(x cos - y sin),
  * y' = round(x sin + y cos), half to even), read in the same clock from their row RAMs, compared; a test whose two
  * points share a row takes two clocks. Corners
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

  val ready = StreamFifo(OrientedCorner(f, h, d), d.readyQueueDepth)
  ready.io.push.valid := io.corners.valid
  ready.io.push.payload := io.corners.payload
  val queueDrop = io.corners.valid && !ready.io.push.ready

  val tests = Pattern.tests
  val coordWidth = 6 // rotated offsets lie in [-18, 18]
  val csWidth = d.rotationFracBits + 2
  val cosSin = Vec((0 until d.angleBins).map { b =>
    val (c, s) = orb.model.OrbModel.cosSin(b, d)
    S(c, csWidth bits) ## S(s, csWidth bits)
  })
  val pattern = Vec(tests.map(t => Seq(t.x1, t.y1, t.x2, t.y2).map(v => S(v, 5 bits).asBits).reduce(_ ## _)))

  /** x cos - y sin and x sin + y cos, each rounded half to even (OpenCV's cvRound). */
  def rotate(x: SInt, y: SInt, c: SInt, s: SInt): (SInt, SInt) = {
    def round(v: SInt): SInt = {
      val fb = d.rotationFracBits
      val q = floorShift(v, fb)
      val r = v(fb - 1 downto 0).asUInt
      val half = U(BigInt(1) << (fb - 1), fb bits)
      val up = r > half || (r === half && q.lsb)
      (q + Mux(up, S(1, q.getWidth bits), S(0, q.getWidth bits))).resize(coordWidth)
    }
    (round(x * c - y * s), round(x * s + y * c))
  }

  case class EnginePort() extends Bundle {
    val enable = Bool()
    val address = UInt(addrWidth bits)
  }

  val engines = for (e <- 0 until 2) yield new Area {
    val busy, done, drop = Reg(Bool()) init False
    val corner = Reg(OrientedCorner(f, h, d))
    val base = Reg(UInt(slotWidth bits))
    val rowsLeft = Reg(UInt(log2Up(d.slackRows + 1) bits))
    val t = Reg(UInt(9 bits))
    val secondRead = Reg(Bool()) init False
    val bits = Reg(UInt(9 bits))
    val descriptor = Reg(Bits(256 bits))
    val cs = Reg(Bits(2 * csWidth bits))

    // This clock's tests: t (a) and t + 1 (b). Both go in the same clock when their four points lie in four
    // different rows; a test whose two points share a row goes alone, in two clocks.
    val c = cs(csWidth, csWidth bits).asSInt; val s = cs(0, csWidth bits).asSInt
    def slotOf(ry: SInt): UInt = wrap(base +^ (ry.resize(coordWidth + 1) + sampleReach).asUInt.resize(slotWidth + 1))
    def colOf(rx: SInt): UInt = (corner.corner.x.intoSInt + rx).asUInt.resize(addrWidth)
    case class Points(index: UInt) {
      val p = pattern(index.resize(8))
      val Seq(x1, y1, x2, y2) = (0 until 4).map(i => p((3 - i) * 5, 5 bits).asSInt)
      val (rx1, ry1) = rotate(x1, y1, c, s)
      val (rx2, ry2) = rotate(x2, y2, c, s)
      val slot1 = slotOf(ry1); val slot2 = slotOf(ry2)
      val col1 = colOf(rx1); val col2 = colOf(rx2)
      val sameRow = ry1 === ry2
    }
    val a = Points(t)
    val b = Points(t + 1)
    val running = busy && t =/= 256
    val distinct = Seq(a.slot1, a.slot2, b.slot1, b.slot2).combinations(2).map { case Seq(u, v) => u =/= v }.reduce(_ && _)
    val dual = running && !a.sameRow && !b.sameRow && t =/= 255 && distinct
    val readA1 = running && (!a.sameRow || !secondRead)
    val readA2 = running && (!a.sameRow || secondRead)
    val ports = Vec(EnginePort(), rows)
    for (r <- 0 until rows) {
      val hits = Seq((readA1, a.slot1, a.col1), (readA2, a.slot2, a.col2), (dual, b.slot1, b.col1), (dual, b.slot2, b.col2))
        .map { case (en, slot, col) => (en && slot === r, col) }
      ports(r).enable := hits.map(_._1).orR
      ports(r).address := hits.reverse.foldLeft(U(0, addrWidth bits)) { case (acc, (hit, col)) => Mux(hit, col, acc) }
    }
    when(running) {
      when(a.sameRow && !secondRead) { secondRead := True }
        .otherwise { secondRead := False; t := t + Mux(dual, U(2), U(1)) }
    }
    // One clock later: the read data, from the RAMs chosen one clock earlier.
    val readData = Vec(UInt(8 bits), rows)
    val slotA1D = RegNext(a.slot1); val slotA2D = RegNext(a.slot2)
    val slotB1D = RegNext(b.slot1); val slotB2D = RegNext(b.slot2)
    val firstOfPair = RegNext(running && a.sameRow && !secondRead) init False
    val completes = RegNext(running && (!a.sameRow || secondRead)) init False
    val dualD = RegNext(dual) init False
    val pairedD = RegNext(running && a.sameRow) init False
    val held = Reg(UInt(8 bits))
    when(firstOfPair) { held := readData(slotA1D) }
    val bitA = Mux(pairedD, held, readData(slotA1D)) < readData(slotA2D)
    val bitB = readData(slotB1D) < readData(slotB2D)
    when(busy && completes) {
      when(dualD) {
        descriptor := bitB ## bitA ## descriptor(255 downto 2)
        bits := bits + 2
      } otherwise {
        descriptor := bitA ## descriptor(255 downto 1)
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
    engines(0).readData(r) := ram.readWriteSync(Mux(writeHere, stream.writeAddr, e0.address), io.smoothed.smoothed,
      writeHere || e0.enable, writeHere)
    engines(1).readData(r) := ram.readSync(e1.address, e1.enable)
  }

  // Two register stages to the output (no RAM): a consumer that waits holds the collection, then the engines,
  // then the dispatch; corners queue meanwhile and are dropped only when their rows run out.
  val output = Stream(OrbFeature(f, h, d))

  // Handing corners to the engines in turn.
  val dispatch = new Area {
    val next = Reg(UInt(1 bits)) init 0
    val head = ready.io.pop
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
      e.busy := True; e.drop := False
      e.corner := head.payload
      // the newest patch row (cy + 18) is in the slot of raw row cy + 21, `since + 1` rows back
      e.base := wrap(stream.slotNow.resize(slotWidth + 2) + (2 * rows - 1 - span) - since.asUInt.resize(slotWidth + 2))
      e.rowsLeft := (d.slackRows - since.asUInt).resize(e.rowsLeft.getWidth)
      e.t := 0; e.bits := 0; e.secondRead := False
      e.cs := cosSin(head.bin)
    }
    when(start) { next := next + 1 }
  }
  // A row start overwrites the oldest slot: an engine whose slack runs out gives up its corner.
  for (e <- engines) when(stream.rowStart && e.busy) {
    e.rowsLeft := e.rowsLeft - 1
    when(e.rowsLeft === 1 && e.bits =/= 256) { e.busy := False; e.done := True; e.drop := True }
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
