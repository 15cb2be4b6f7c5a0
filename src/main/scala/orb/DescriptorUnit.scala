package orb

import spinal.core._
import spinal.lib._
import orb.Pipes.keptApart
import orb.model.DescriptorSchedule
import orb.model.DescriptorSchedule.{groups, lanesPerPort, pointsPerGroup, testsPerGroup}

/** What a slot of the descriptor engine holds. */
object EngineState extends SpinalEnum(binaryOneHot) {

  /** no corner; a corner being described; its finished feature; a corner whose rows were overwritten before its
    * descriptor was complete */
  val IDLE, RUN, FINISHED, ABANDONED = newElement()
}

/** Rotated BRIEF, as `orb.model.OrbModel.descriptor`, on a banked store of smoothed rows.
  *
  * Store: `smoothedRows` (37 + slackRows) rows used as a ring, two per bank (`smoothedBanks` banks of
  * 2 x maxWidth bytes, two ports each); the smoothed stream writes the row of the current raw row through port A of
  * its bank. A corner's 37 rows are complete when row cy + 22 starts; from then on it has `slackRows` row starts
  * before its oldest row is overwritten, and is dropped (counted) if it is not done by then. Only processed rows
  * start and are written: after a fault the ring stands still until the next processed frame.
  *
  * One engine with 4 read lanes, 2 on the banks' A ports and 2 on their B ports. Its front end takes the 256 tests
  * in 128 groups of 2: the pattern, the rotation with the bin's cos/sin (x' = round(x cos - y sin), y' = round(x sin
  * + y cos), half to even), the ring slots, and the read schedule of `orb.model.DescriptorSchedule` (`GroupPlanner`):
  * a group takes one clock when its 4 points fit the lanes, otherwise each test in turn. The front end
  * depends on nothing read, so it runs ahead of the reads; it holds (`advance` low) while a group takes more than
  * one clock. Every lane's bank and address are registered before the banks, each bank port picks its address from
  * the registered lanes beside the RAM, the RAM's data is registered on the way out (the block's output register),
  * and each lane gets its byte back through two registered levels of selection, then the comparisons.
  *
  * The engine holds two corners in two slots, used in turn: a corner starts as soon as the front end has fetched
  * the previous corner's last group (and the slot of the corner before that has handed its feature on), so its
  * front end fills behind the previous corner's groups while they drain; every group in flight carries its slot's
  * tag, and a corner abandoned because its rows were overwritten voids only its own groups.
  *
  * Corners are taken in raster order and their features leave in the same order. A consumer that waits holds the
  * finished features in the slots (no FIFO RAM): corners wait in the ready queue, and only a corner whose rows are
  * overwritten before the engine takes it is dropped (counted). The camera never waits. */
class DescriptorUnit(f: FrameConfig, h: HarrisConfig, d: OrbDescriptorConfig) extends Component {
  import OrbDescriptorConfig.{blurRadius, sampleReach}
  val io = new Bundle {
    val smoothed = slave Flow (SmoothedPixel(f))
    val corners = slave Flow (OrientedCorner(f, h))
    val features = master Stream (FeatureHw(f, h, d))
    val dropped = out(f.counter())
  }
  val rows = d.smoothedRows
  val banks = d.smoothedBanks
  val slotWidth = log2Up(rows)

  /** entries of the rows' history, by the row count's low bits: a power of two (the count wraps at one) */
  val historyRows = 1 << log2Up(d.slackRows max 2)
  require(historyRows <= (1 << f.rowTagWidth), "the rows' history is kept by the row count's low bits")
  val bankWidth = log2Up(banks)
  val colWidth = f.addrWidth
  val addrWidth = colWidth + 1
  val magnitudeWidth = d.rotationFracBits + 1 // |cos|, |sin| <= 2^rotationFracBits
  val patternWidth = 4 // |pattern coordinate| <= 15
  val offsetWidth = log2Up(sampleReach + 1) + 1 // rotated offsets lie in [-18, 18]
  val rowOffsetWidth = log2Up(2 * sampleReach + 1) // ry + 18 in [0, 36]
  val patchRows = 2 * sampleReach + 1
  require(DescriptorSchedule.banks(d) == banks)

  def nextSlot(s: UInt): UInt = Mux(s === rows - 1, U(0, slotWidth bits), s + 1)

  /** ring slot -> bank (slot / 2), as a slice */
  def bankOf(slot: UInt): UInt = slot(slotWidth - 1 downto 1).resize(bankWidth)

  case class RowInfo() extends Bundle {
    val active = Bool()
    val frame = f.frameTag()
  }

  /** The smoothed stream, two clocks late: beat (x, y) carries smoothed pixel (x - 3, y - 3) of raw row y, written
    * into the ring slot of its row. The registers describe the stream after the newest beat. */
  val ring = new Area {
    // the smoother's beat registered here first (kept apart from the detector's copies of the same position: no row
    // or slot decision hangs on the long wires from it), its row and frame starts tested in the smoother
    val s = keptApart(io.smoothed.stage())
    // Only processed rows count and are written: after a fault in a frame the ring stands still until the next
    // processed frame, so the rows of the corners it already has stay until their descriptors are done (the rows
    // a broken stream sends then, however short, overwrite nothing), as the model assumes.
    def rowStarts: Bool = io.smoothed.valid && io.smoothed.rowStart
    val startsRow = RegNext(rowStarts) init False

    /** a copy of `startsRow` (kept apart) for a consumer far from the ring's slot and row registers */
    def startsRowCopy(): Bool = {
      keptApart(RegNext(rowStarts) init False)
    }
    val startsFrame = RegNext(io.smoothed.valid && io.smoothed.frameStart) init False
    // the slot, and the one after it beside it (no increment or wrap between a row start and the slot's next value)
    val slot = Reg(UInt(slotWidth bits)) init 0
    val slotAfter = Reg(UInt(slotWidth bits)) init (1 % rows)
    val slotNext = Mux(startsRow, slotAfter, slot)
    slot := slotNext
    when(startsRow) {
      slotAfter := nextSlot(slotAfter)
    }
    val clock = new RowClock(f, startsRow, startsFrame)

    /** the newest beat started a row: a copy (kept apart) for each consumer, each beside it */
    def rowStartCopy(): Bool = keptApart(RegNext(startsRowCopy()) init False)
    // For the last rows: was the row written since reset (only processed rows start), and in which frame. A
    // corner's rows are good iff the first pixel of its row cy + 22 was processed in its own frame (no fault before
    // it): the model's rule.
    // Kept by the row's count (its low bits name the entry), so a corner finds its row's entry by its own start row,
    // with no difference of rows on the way: an entry holds its row until `historyRows` rows later, and a corner
    // reads it only within `slackRows` rows.
    val history = Vec.fill(historyRows)(Reg(RowInfo()))
    history.foreach(_.active.init(False))
    val thisRow = RowInfo()
    thisRow.active := s.active
    thisRow.frame := clock.frameNext
    // a row start writes the entry of the count it starts, one more than the count's low bits before it (by a copy
    // of the row start of the history's own)
    val rowLow = clock.row.resize(log2Up(historyRows))

    /** a row start (`writes`, a copy of it) writes `entry` in this clock */
    def writesEntry(writes: Bool, entry: UInt): Bool = writes && rowLow + 1 === entry
    val writesHistory = startsRowCopy()
    for (i <- 0 until historyRows) {
      when(writesEntry(writesHistory, U(i, log2Up(historyRows) bits))) {
        history(i) := thisRow
      }
    }
    // The bank of the slot, one-hot beside it: it moves on when a row start leaves the bank's last slot. Each
    // cluster of four banks moves its part of it and decodes the newest beat's write for its banks with its own
    // copies of the flags (kept apart): no one register drives every bank.
    val writeClusters = (banks + 3) / 4
    val bank = Reg(Bits(banks bits)) init 1
    // whether the slot is a bank's last, for the slot and the one after it (registers beside them)
    def leavesBank(s: UInt): Bool = s.lsb || s === rows - 1
    def leavesBankAt(s: Int): Boolean = s % 2 == 1 || s == rows - 1
    val leaves = RegInit(Bool(leavesBankAt(0)))
    val leavesAfter = RegInit(Bool(leavesBankAt(1 % rows)))
    when(startsRow) {
      leaves := leavesAfter
      leavesAfter := leavesBank(nextSlot(slotAfter))
    }
    val leavesBankNext = Mux(startsRow, leavesAfter, leaves)
    val writeBank = Bits(banks bits)
    for (k <- 0 until writeClusters) {
      val moves = startsRowCopy() && keptApart(RegNext(leavesBankNext) init False)
      val writesHere = keptApart(RegNext(io.smoothed.valid && io.smoothed.holdsSmoothed) init False)
      for (b <- 4 * k until (4 * k + 4 min banks)) {
        val next = Mux(moves, bank((b + banks - 1) % banks), bank(b))
        bank(b) := next
        writeBank(b) := RegNext(writesHere && next) init False
      }
    }
    // address and data, one copy per cluster of four banks (kept apart): no one register drives every bank. The
    // column is subtracted once, from the smoother's position into a register beside the beat's (`s`, loaded every
    // clock as it is), so each copy takes a register across the banks, not a subtraction of its own.
    val column = RegNext((io.smoothed.x - blurRadius).resize(colWidth))
    val writeAddress = Seq.fill(writeClusters) {
      keptApart(RegNext((slotNext.lsb ## column).asUInt))
    }
    val writeData = Seq.fill(writeClusters) {
      keptApart(RegNext(s.smoothed))
    }
  }

  /** What of an oriented corner waits for the engine beside its moments, then its bin. */
  case class Waiting() extends Bundle {
    val corner = CornerHw(f, h)

    /** the row whose start means the corner's 37 smoothed rows are complete: its own row + `startRowOffset` */
    val startRow = f.rowTag()
    val frameTag = f.frameTag()
    val keyframe = Bool()
    val end = FrameEndMark()
  }

  /** An oriented corner at the queue's head, with its bin and without its moments, which only the bin needed. */
  case class ReadyCorner() extends Bundle {
    val corner = CornerHw(f, h)

    /** the score's rank (`FeatureHw.rank`) */
    val rank = UInt(MatcherConfig.rankWidth(h) bits)
    val bin = UInt(d.binWidth bits)
    val startRow = f.rowTag()
    val frameTag = f.frameTag()
    val keyframe = Bool()
    val end = FrameEndMark()
  }

  /** A corner's rotation: its bin's cos and sin as magnitudes and signs. */
  case class Rotation() extends Bundle {
    val cos, sin = UInt(magnitudeWidth bits)
    val cosNegative, sinNegative = Bool()
  }

  /** ... with its rotation, looked up while it waits */
  case class PreparedCorner() extends Bundle {
    val item = ReadyCorner()
    val rotation = Rotation()
  }
  // drained an engine's run apart: its RAM's read enables wait for no readiness (`SettledFifo`). The corners wait
  // with their moments; the head's bin is searched for as it leaves (one corner at a time, far faster than the
  // engine), so no pipeline carries the corners beside a search.
  val ready = new SettledFifo(AngleQuery(Waiting()), d.readyQueueDepth)
  ready.io.push.valid := io.corners.valid
  ready.io.push.item.assignSomeByName(io.corners.payload)
  ready.io.push.item.startRow := io.corners.rowTag + OrbDescriptorConfig.startRowOffset
  ready.io.push.m10 := io.corners.m10
  ready.io.push.m01 := io.corners.m01
  val queueDrop = io.corners.valid && !ready.io.push.ready
  val search = new AngleSearch(Waiting(), d)
  search.io.input << ready.io.pop

  /** cos and sin of a bin from a quarter of the table (`OrbDescriptorConfig.cosSin`): the magnitudes of the bin
    * within its quadrant (sin read from the table backwards: no subtraction), in three registered steps (each
    * part's word at the bin, the two words of the part's half, the part with the quadrant's swap and signs). */
  val quarterIndexWidth = log2Up(d.binsPerQuadrant)
  val cosTable =
    Arith.SplitTable(d.quarterCos.take(d.binsPerQuadrant).map(BigInt(_)), magnitudeWidth, DescriptorUnit.tableParts)
  val sinTable = Arith.SplitTable(
    d.quarterCos.reverse.take(d.binsPerQuadrant).map(BigInt(_)),
    magnitudeWidth,
    DescriptorUnit.tableParts
  )

  /** A bin with a copy of its index within the quadrant per part of the cos/sin tables (kept apart): no one
    * register drives every part's lookup. */
  case class IndexedBin() extends Bundle {
    val quadrant = UInt(2 bits)
    val within = Vec(UInt(quarterIndexWidth bits), DescriptorUnit.tableParts)
  }
  def indexed(bin: UInt): IndexedBin = {
    val o = IndexedBin()
    o.quadrant := bin(d.binWidth - 1 downto d.binWidth - 2)
    o.within.foreach(_ := bin.resize(quarterIndexWidth))
    o
  }
  case class CosSinLookup() extends Bundle {
    val quadrant = UInt(2 bits)
    val cosWords, sinWords = Vec(UInt(magnitudeWidth bits), DescriptorUnit.tableParts)

    /** the part, a copy per half of each table (from the index copies of its words): no one register narrows all
      * four halves */
    val cosParts, sinParts = Vec(UInt(log2Up(DescriptorUnit.tableParts) bits), 2)
  }
  def lookupCosSin(i: IndexedBin): CosSinLookup = {
    val o = CosSinLookup()
    o.quadrant := i.quadrant
    o.cosWords := cosTable.wordsEach(i.within.toSeq)
    o.sinWords := sinTable.wordsEach(i.within.toSeq)
    // the half u of a table is read with the index copies u * parts / 2 onwards: its part from the first two
    require(DescriptorUnit.tableParts >= 4, "two index copies per half")
    for (u <- 0 until 2) {
      o.cosParts(u) := cosTable.part(i.within(u * DescriptorUnit.tableParts / 2))
      o.sinParts(u) := sinTable.part(i.within(u * DescriptorUnit.tableParts / 2 + 1))
    }
    o
  }

  /** the bin's magnitudes within its quadrant, each half of the parts narrowed to its word (`SplitTable.halves`),
    * and the part's top bit, which picks the half */
  case class CosSinNarrowed() extends Bundle {
    val quadrant = UInt(2 bits)
    val cosPair, sinPair = Vec(UInt(magnitudeWidth bits), 2)
    val upper = Bool()
  }
  def narrowCosSin(l: CosSinLookup): CosSinNarrowed = {
    val o = CosSinNarrowed()
    o.quadrant := l.quadrant
    o.cosPair := cosTable.halves(l.cosWords, l.cosParts.toSeq)
    o.sinPair := sinTable.halves(l.sinWords, l.sinParts.toSeq)
    o.upper := l.cosParts.head.msb
    o
  }

  /** the part picked, then the quadrant's swap, quadrant 0: (c, s), 1: (-s, c), 2: (-c, -s), 3: (s, -c) (both on
    * registers: one 4-way choice per bit) */
  def rotationOf(l: CosSinNarrowed): Rotation = {
    val o = Rotation()
    val odd = l.quadrant.lsb
    val c = cosTable.pickHalf(l.cosPair, l.upper)
    val s = sinTable.pickHalf(l.sinPair, l.upper)
    o.cos := Mux(odd, s, c)
    o.sin := Mux(odd, c, s)
    o.cosNegative := l.quadrant === 1 || l.quadrant === 2
    o.sinNegative := l.quadrant.msb
    o
  }

  /** The search's result is the queue's head: its rotation looked up from its bin by registers that run every clock
    * while the search holds it (no handshake between them, no copy of the corner in them), offered once they hold
    * the head's (`rotationLatency` clocks after the search's result). One corner at a time: the next is searched for
    * after the head leaves, far sooner than the engine can take it. */
  val headOf = new Area {
    val o = search.io.output
    val bin = o.bin
    val indexedBin = RegNext(indexed(bin))
    indexedBin.within.foreach(keptApart(_))
    val lookedUp = RegNext(lookupCosSin(indexedBin))
    val narrowed = RegNext(narrowCosSin(lookedUp))
    val rotation = RegNext(rotationOf(narrowed))
    // the score's rank in three registered steps (`Arith.leadOf`), as the rotation's lookups, while the search holds
    // its result
    val score = o.item.corner.score
    val rankBits = MatcherConfig.rankFracBits
    val lead = RegNext(Arith.leadOf(score))
    val coarse = RegNext(Arith.afterLeadCoarse(score, lead, rankBits))
    val rank = RegNext(Arith.rankFrom(coarse, RegNext(lead), rankBits, MatcherConfig.rankWidth(h)))
    require(DescriptorUnit.rotationLatency >= 3, "the rank is ready when the rotation is")
    val head = Stream(PreparedCorner())
    // the result held (and not taken) in each of the last `rotationLatency` clocks: the registers hold its (held
    // in the last clock, the search still holds it). The clocks before the last ANDed a clock ahead into a register.
    val waited = History(o.valid && !head.fire, 1 until DescriptorUnit.rotationLatency, init = False)
    val waitedBefore = RegNext(waited.reduce(_ && _)) init False
    head.valid := waited.head && waitedBefore
    head.item.assignSomeByName(o.item)
    head.item.bin := bin
    head.item.rank := rank
    head.rotation := rotation
    o.ready := head.fire

    /** what the dispatch's decisions read of the head, copied beside them (the search lies apart): right whenever
      * the head is offered, `rotationLatency` clocks after the result */
    case class Tags() extends Bundle {
      val startRow = f.rowTag()
      val frameTag = f.frameTag()
      val end = FrameEndMark()
    }
    val tags = RegNext {
      val t = Tags()
      t.assignSomeByName(o.item)
      t
    }

    /** the head's start row, and the row from which it is late (`slackRows` on), in registers of their own (kept
      * apart) beside the dispatch's subtractions: no one register drives them and the history's choice */
    val sinceRow = keptApart(RegNext(o.item.startRow))
    val lateRow = keptApart(RegNext(o.item.startRow + d.slackRows))

    /** the rows' history entry of the head's start row as it is after this clock (the row a row start writes into
      * it now, if one does), registered beside `tags`: the dispatch's test of the head's rows compares two
      * registers, with no choice among the entries after the frame tag */
    val startRowInfo = RegNext {
      val entry = o.item.startRow.resize(log2Up(historyRows))
      Mux(ring.writesEntry(ring.startsRowCopy(), entry), ring.thisRow, ring.history(entry))
    }
  }

  /** The oldest slot's feature or a frame's end, offered to the output register (`leaving`). */
  val output = Stream(FeatureHw(f, h, d))

  val engine = new DescriptorEngine

  /** Hands the queue's head to the engine. The decision is taken on registered values: the rows since the head's
    * patch was complete and the tests on them (early, late, the rows' data good) are registered first, the decision
    * on them next, and the head starts a clock later unless it changed or a row starts in between. */
  val dispatch = new Area {
    // the queue's RAM through its output register and a register behind it, the bin's search (its state register
    // the queue's readiness: no decision reaches the read pointer), the rotation's lookups (`headOf`)
    val head = headOf.head
    val c = headOf.tags
    // rows since the patch was complete (negative: not yet), for the head of the clock before: it is the head's
    // now unless the head left then or a row started since (the rows and their history then moved on)
    val difference = (ring.clock.row - headOf.sinceRow).asSInt
    val since = RegNext(difference)
    val computed = RegNext(head.valid && !c.end.now && !head.fire) init False
    val current = computed && !ring.rowStartCopy()
    // the tests on the rows since, registered beside them: the start decision only combines registers
    val early = RegNext(difference.msb) init True
    // late: `slackRows` rows since or more, as the sign of the rows since the late row (one subtraction; it differs
    // from that comparison only while the head is early, when no decision reads it)
    val late = RegNext(!(ring.clock.row - headOf.lateRow).asSInt.msb) init False
    // the test of the row the head's start row names against the head's frame (the same entry as the row
    // `difference` rows back whenever that is within the slack: otherwise `early` or `late` decides)
    val startRow = headOf.startRowInfo
    val dataOk = RegNext(startRow.active && startRow.frame === c.frameTag) init False
    val due = current && !early
    // the head's frame is over at the ring (a frame started since): a head not yet due never will be (its start
    // row was not processed: the ring stood still from a fault to the frame's end)
    val over = RegNext(c.frameTag =/= ring.clock.frame) init False
    // the engine free for a corner, a clock late (never right after a start, which takes the slot)
    val free = Reg(Bool()) init False
    // the decisions registered; a row start in the clock of a start (known a clock ahead) holds it. A head that is
    // due is a corner (no frame's end), so it leaves now only by these decisions: no other way out (the output's
    // readiness, the engine's idleness) reaches them.
    val start, refuse = Reg(Bool()) init False
    val decided = start || refuse
    val rowStarts = ring.startsRowCopy()
    val starts = due && !late && dataOk && free && !decided && !rowStarts
    // kept apart from its copies below (each a register of the same value), which serve the slots and the counts
    keptApart(start)
    start := starts
    refuse := current && Mux(early, over, late || !dataOk) && !decided
    // a copy of `start` per engine slot (kept apart): each turns its slot's turn flag
    val slotStarts = Seq.fill(2) {
      keptApart(RegNext(starts) init False)
    }
    // the newest patch row (cy + 18) is in the slot of raw row cy + 21, `since + 1` rows back; the oldest 36 more
    // (registered before it is wrapped into the ring: the wrap is formed as a start takes it)
    val back =
      RegNext(ring.slot.resize(slotWidth + 2).asSInt - since.resize(slotWidth + 2) - S(patchRows, slotWidth + 2 bits))
    val base = Mux(back.msb, back + S(rows, slotWidth + 2 bits), back).asUInt.resize(slotWidth)
    val leftWidth = log2Up(d.slackRows + 1)
    val left = (S(d.slackRows, leftWidth + 1 bits) - since.resize(leftWidth + 1)).asUInt.resize(leftWidth)
    val rowsLeft = RegNext(left)
    // whether it is one, with `starts` (a slot registers both as it takes the corner)
    val oneRowLeftNext = left === 1
    free := engine.canBegin && !start
    // A frame end leaves when every corner before it has: the engine idle, tested a clock ahead into a register (the
    // output's validity follows registers; no corner starts while a frame end is the head, so the engine stays idle)
    // It leaves the queue a clock after it left the engine (`markerLeft`), so the output's readiness reaches no
    // queue or search state; it is not offered in that clock.
    val marker = Reg(Bool()) init False
    val markerLeft = RegNext(marker && output.ready) init False
    marker := head.valid && c.end.now && engine.idle && !head.fire && !(marker && output.ready)
    head.ready := start || refuse || markerLeft
    engine.begin(head.payload, base, rowsLeft, oneRowLeftNext, start, starts, slotStarts)
  }

  /** One corner in the engine, from its start until its feature is handed on: the corner, what the front end's later
    * stages need of it (the patch's base slot, the column; the rotation is the front end's own), its rows' deadline,
    * and its collected tests. */
  class EngineSlot(val tag: Boolean) extends Area {
    val state = RegInit(EngineState.IDLE)
    val corner = Reg(ReadyCorner())
    val base = Reg(UInt(slotWidth bits))
    val rowsLeft = Reg(UInt(log2Up(d.slackRows + 1) bits))

    /** groups collected, and whether the next one is the last (a register beside the count) */
    val done = Reg(UInt(log2Up(groups + 1) bits)) init 0
    val lastGroup = Reg(Bool()) init False
    val descriptor = Reg(Bits(OrbDescriptorConfig.descriptorBits bits))

    /** `state` is RUN, in a register of its own whose next value no release reaches (a release frees a finished or
      * an abandoned slot, never a running one, and never in the clock the slot begins: it begins only when idle two
      * clocks before), so the output's readiness does not reach `atRisk` */
    val runs = RegInit(False)

    /** the next corner to start takes this slot, and this slot's feature leaves next: the slots take turns, each
      * with its own flags (kept apart), so no one tag drives both slots' registers */
    val takesNext = keptApart(RegInit(Bool(!tag)))
    val leavesNext = keptApart(RegInit(Bool(!tag)))

    /** it runs, not abandoned, on its last row: its patch's oldest row goes at the next row start (`rowsLeft` is 1),
      * or at the one after when a row starts now (2) */
    val atRisk = Bool()

    /** the slot takes a corner in this clock with one row left (a register: see `DescriptorEngine.begin`) */
    val beginsOnLastRow = Bool()

    /** the slot's last group is collected in this clock (unless abandoned in it): a register (see `collected`) */
    val collectsLast = Bool()

    /** A row start overwrites the oldest row before the descriptor is complete: decided a clock ahead (the row start
      * is known then) into a register, so the front end's enables do not wait for the slot's state. The decision
      * combines four registers: the row start, a start with one row left, `atRisk` (the slot runs on its last row:
      * decided a clock before from the next values of what it tests) and whether its last group is collected now.
      * (A slot takes a corner only when idle, so a start and `atRisk` never meet.) `abandonCopies` (kept apart)
      * serve the front end's copies of `advance`; the fetch chooses its own copy from `abandonNext`. */
    val abandon = Reg(Bool()) init False
    val rowStarts = ring.startsRowCopy()
    // the slot's own copy of the row start (its row count and abandonment lie with it)
    val rowStart = ring.rowStartCopy()
    val abandonNext = rowStarts && (beginsOnLastRow || (atRisk && !collectsLast))
    abandon := abandonNext
    val abandonCopies = Seq.fill(DescriptorUnit.advanceCopies / DescriptorUnit.advanceCopiesPerAbandon) {
      keptApart(RegNext(abandonNext) init False)
    }

    def begin(c: PreparedCorner, b: UInt, left: UInt): Unit = {
      state := EngineState.RUN
      runs := True
      corner := c.item
      base := b
      rowsLeft := left
      done := 0
      lastGroup := Bool(groups == 1)
    }

    /** A group's results collected when `enables` (copies of one flag: the first for the count and the state, each
      * of the others for a part of the descriptor): the descriptor is complete after the last (unless abandoned in
      * that clock). */
    def collected(results: Bits, enables: Seq[Bool]): Unit = {
      val shifted = results ## descriptor(descriptor.high downto testsPerGroup)
      val partBits = descriptor.getWidth / enables.tail.size
      for ((enable, p) <- enables.tail.zipWithIndex) {
        when(enable) {
          descriptor(p * partBits, partBits bits) := shifted(p * partBits, partBits bits)
        }
      }
      collectsLast := keptApart(RegNext(enables.head.getAheadValue() && lastGroup.getAheadValue()) init False)
      when(enables.head) {
        done := done + 1
        lastGroup := done === groups - 2
        when(lastGroup && !abandon) {
          state := EngineState.FINISHED
          runs := False
        }
      }
    }

    /** The finished feature was handed on, or the abandoned corner counted: free for a corner. */
    def release(): Unit = {
      state := EngineState.IDLE
    }

    when(rowStart && runs) {
      rowsLeft := rowsLeft - 1
    }
    when(abandon) {
      state := EngineState.ABANDONED
      runs := False
    }
    // from the next values of what it tests
    val rowsLeftNext = rowsLeft.getAheadValue()
    atRisk := RegNext(
      runs.getAheadValue() && !abandonNext &&
        Mux(rowStart.getAheadValue(), rowsLeftNext === 2, rowsLeftNext === 1)
    ) init False
  }

  /** The engine: `begin` takes a corner into the next slot, `handOn` frees the slot whose feature left; the rest it
    * decides itself. */
  class DescriptorEngine extends Area {
    val slots = Seq(new EngineSlot(tag = false), new EngineSlot(tag = true))

    /** a field of the slot named by `tag` */
    def pick[T <: Data](tag: Bool)(field: EngineSlot => T): T = Mux(tag, field(slots(1)), field(slots(0)))

    /** the slot named by `tag` is abandoned in this clock */
    def abandons(tag: Bool): Bool = pick(tag)(_.abandon)

    /** the slot whose feature leaves next (the oldest corner in the engine), and copies of it (kept apart), each
      * choosing a part of the descriptor for the output register: the copies follow a clock late (`leftLast`) */
    val outTag = RegInit(False)
    val outTags = Seq.fill(DescriptorUnit.outputParts) {
      keptApart(RegInit(False))
    }

    /** a feature or an abandonment left in the last clock: the copies of `outTag` move now, so the output takes
      * nothing in this clock (a taken feature's output register is full now anyway) */
    val leftLast = RegInit(False)

    /** A corner starts when `start` (`starts` a clock ahead) with `left` rows left (`oneLeft`: one, with `starts`);
      * `slotStarts` are copies of it (kept apart), one per slot, each turning that slot's turn flag (the slot's
      * registers load by a register of their own, `starts` in the slot's turn). */
    def begin(
        c: PreparedCorner,
        b: UInt,
        left: UInt,
        oneLeft: Bool,
        start: Bool,
        starts: Bool,
        slotStarts: Seq[Bool]
    ): Unit = {
      for ((s, slotStart) <- slots.zip(slotStarts)) {
        // whether the corner starts in this slot, and with one row left, registers of its own (kept apart): the
        // slot's turn flag does not change in the clock after a start (starts are at least two clocks apart), so
        // no turn flag is tested on the way to the slot's state and registers
        val beginsHere = keptApart(RegNext(starts && s.takesNext) init False)
        s.beginsOnLastRow := keptApart(RegNext(starts && s.takesNext && oneLeft) init False)
        when(beginsHere) {
          s.begin(c, b, left)
        }
        when(slotStart) {
          s.takesNext := !s.takesNext
        }
      }
      fetch.restartOn(starts)
      when(start) {
        fetch.tag := nextTag
        rotation.fetched := c.rotation
      }
    }

    /** The oldest corner's feature is handed on when `taken` (the output takes it), or its abandonment counted: each
      * slot decides on its own turn flag and state (`leavesNext` is set in the oldest slot only: no choice by
      * `outTag` before a slot's release). */
    def handOn(taken: Bool): Unit = {
      val leaving = slots.map { s =>
        val leaves = s.leavesNext && ((s.state === EngineState.FINISHED && taken) || s.state === EngineState.ABANDONED)
        when(leaves) {
          s.release()
        }
        leaves
      }
      val any = leaving.reduce(_ || _)
      when(any) {
        for (s <- slots) {
          s.leavesNext := !s.leavesNext
        }
        outTag := !outTag
      }
      leftLast := any
      when(leftLast) {
        for (t <- outTags) {
          t := !t
        }
      }
    }

    /** Advances the front end: low while the issue stage repeats a group (registered: see `issue`). */
    // kept apart from its copies: it stays beside the issue stage's control, the copies beside what they enable
    val advance = keptApart(RegInit(True))

    /** copies of `advance` (kept apart), each enabling a share of the front end's registers: no one flag drives
      * them all; made with the issue stage (`issue.advanceCopies`) */
    private val enableRequests = scala.collection.mutable.ArrayBuffer[(Bool, Int)]()

    /** enables of registers that lie apart from the registers made before and after them, by site: a copy of
      * `advance` per site (`issue.advanceCopy`), which lies there. A point's registers beside its multipliers in
      * three sites (its operands, its products, their plain copies: about a hundred registers each), a table part's
      * of a pattern slice beside that part (`stepAt`); the fetch's count, the pattern's parts and pick, the
      * rotation's first steps beside the dispatch each a site of its own (`stepApart`). */
    private val siteEnables =
      scala.collection.mutable.LinkedHashMap[String, scala.collection.mutable.ArrayBuffer[Bool]]()
    private def siteEnable(site: String): Bool = {
      val e = Bool()
      siteEnables.getOrElseUpdate(site, scala.collection.mutable.ArrayBuffer[Bool]()) += e
      e
    }

    /** an enable of a site of its own */
    private def ownEnable(): Bool = siteEnable(s"apart${siteEnables.size}")

    /** an enable for `bits` more of the front end's registers: a copy of `advance` chosen once the front end is
      * built (`shareEnables`) */
    private def enable(bits: Int): Bool = {
      val e = Bool()
      enableRequests += e -> bits
      e
    }

    /** Each copy of `advance` enables registers made one after the other (a stage's, a table part's: registers
      * that lie together), about an equal share of the bits each (a copy's share is what is left over the copies
      * left, so the last takes no more than the others), so no copy's wires span the front end. */
    def shareEnables(): Unit = {
      val copies = issue.advanceCopies
      var left = enableRequests.map(_._2).sum
      var copy = 0
      var load = 0
      for ((e, bits) <- enableRequests) {
        val share = (load + left) / (copies.size - copy)
        if (load > 0 && load + bits / 2 > share && copy < copies.size - 1) {
          copy += 1
          load = 0
        }
        e := copies(copy)
        load += bits
        left -= bits
      }
      val abandonCopies = DescriptorUnit.advanceCopies / DescriptorUnit.advanceCopiesPerAbandon
      for (((_, enables), i) <- siteEnables.zipWithIndex) {
        val copy = issue.advanceCopy(i % abandonCopies)
        enables.foreach(_ := copy)
      }
    }
    def step[T <: Data](v: T): T = RegNextWhen(v, enable(widthOf(v)))

    /** `step` enabled by a copy of `advance` of its own */
    def stepApart[T <: Data](v: T): T = RegNextWhen(v, ownEnable())

    /** `step` enabled by the copy of `advance` of `site` (`siteEnables`) */
    def stepAt[T <: Data](site: String)(v: T): T = RegNextWhen(v, siteEnable(site))

    /** Whether a front-end stage holds a group, and of which slot. */
    case class Token() extends Bundle {
      val valid, tag = Bool()
    }

    /** `t` into a register of the front end; a group whose slot is abandoned as it loads is void. */
    def stepToken(t: Token): Token = {
      val r = Reg(Token())
      val enabled = enable(widthOf(r))
      r.valid.init(False)
      val loaded = Mux(enabled, t, r)
      r.tag := loaded.tag
      r.valid := loaded.valid && !abandons(loaded.tag)
      r
    }

    // ---- front end: depends on nothing read ----
    val fetch = new Area {

      /** the slot of the corner fetched last */
      val tag = RegInit(True)

      /** the group fetched now: the one count of the front end (its stages take it from here, a stage a clock) */
      val group = Reg(UInt(log2Up(groups + 1) bits)) init groups
      val valid = group < groups
      when(ownEnable() && valid) {
        group := group + 1
      }
      // the fetched corner's slot's `abandon`, chosen a clock ahead by the next tag into one register (kept
      // apart): the count's reset is then one register, not a choice between two
      val abandoned = keptApart(
        RegNext(Mux(tag.getAheadValue(), slots(1).abandonNext, slots(0).abandonNext)) init False
      )
      when(valid && abandoned) {
        group := groups
      }

      /** a corner starts (`starts`, a clock ahead): the count from its first group, by a copy of the start of its
        * own (kept apart) */
      def restartOn(starts: Bool): Unit = {
        when(keptApart(RegNext(starts) init False)) {
          group := 0
        }
      }
      val token = Token()
      token.valid := valid
      token.tag := tag
    }

    /** the slot the next corner takes */
    val nextTag = !fetch.tag

    /** a corner may start: the front end has fetched the previous corner's groups and the next slot is free */
    val canBegin = !fetch.valid && slots.map(s => s.takesNext && s.state === EngineState.IDLE).orR

    /** no corner in the engine, a clock late (registered: the frame end it lets out then waits a clock more, and
      * no corner starts in the clock before a frame end is at the queue's head, which takes clocks after a start) */
    val idle = RegNext(!fetch.valid && slots.map(_.state === EngineState.IDLE).reduce(_ && _)) init True

    /** The pattern as magnitudes and signs: the multipliers see only non-negative operands (no sign extension). */
    val pattern = new Area {

      /** a group's points, |x| and x < 0 then |y| and y < 0 each, the first point in the low bits */
      val fieldWidth = patternWidth + 1
      val rom: Seq[BigInt] = (0 until groups).map { g =>
        val values = (0 until testsPerGroup).flatMap { k =>
          val t = Pattern.tests(testsPerGroup * g + k)
          Seq(t.x1, t.y1, t.x2, t.y2)
        }
        require(values.forall(_.abs < (1 << patternWidth)))
        values.zipWithIndex.map { case (v, i) =>
          (BigInt(v.abs) + (if (v < 0) BigInt(1) << patternWidth else BigInt(0))) << (i * fieldWidth)
        }.sum
      }
      // the table in slices of its points, each read in parts: each part's word registered beside it, then the
      // part picked into a register, then a copy of the whole word that feeds only the multipliers (their input
      // registers, across the chip); every slice with its own copies of the group (kept apart, a stage behind the
      // count: no restart or abandonment reaches them), one per part and one for the pick: no one register drives
      // a whole word's lookups or picks
      val token = stepToken(stepToken(stepToken(stepToken(fetch.token))))
      val sliceWidth = pointsPerGroup / DescriptorUnit.patternSlices * 2 * fieldWidth
      require(pointsPerGroup % DescriptorUnit.patternSlices == 0, "a slice holds whole points")
      val slices = (0 until DescriptorUnit.patternSlices).map { sl =>
        new Area {
          val table = Arith.SplitTable(
            rom.map(w => (w >> (sl * sliceWidth)) & ((BigInt(1) << sliceWidth) - 1)),
            sliceWidth,
            DescriptorUnit.tableParts
          )
          // each table part's index copy and word a site of their own (a copy of `advance` each: one slice's
          // words are hundreds of registers)
          def site(q: Int): String = s"slice${sl}part$q"
          // (only the bits each copy's lookup reads: a kept copy's unused bits would be kept too)
          val indexCopies = (0 until DescriptorUnit.tableParts).map { q =>
            keptApart(stepAt(site(q))(table.within(fetch.group.resize(log2Up(groups)))))
          }
          val words = Vec(table.wordsEach(indexCopies).zipWithIndex.map { case (w, q) => stepAt(site(q))(w) })
          // the part, a copy per point's coordinate (kept apart), from a copy of the count's part of its own
          val partCount = keptApart(stepApart(table.part(fetch.group.resize(log2Up(groups)))))
          val parts = Seq.fill(sliceWidth / fieldWidth)(keptApart(stepApart(partCount)))
        }
      }
      // Cat of a sequence puts its first element in the low bits: slice 0 there, as in the table's words
      val picked = stepApart(Cat(slices.map(sl => sl.table.pickEach(sl.words, sl.parts))))
      // a register per point, enabled by its point's operands' copy of `advance`: each lies beside its point's
      // multipliers, which lie apart across the chip
      val pointWidth = 2 * fieldWidth
      val points = (0 until pointsPerGroup).map(i => stepAt(s"point$i")(picked(i * pointWidth, pointWidth bits)))
      private def field(k: Int): Bits = points(k / 2)((k % 2) * fieldWidth, fieldWidth bits)

      /** point i: |x|, x < 0, |y|, y < 0 */
      def x(i: Int): UInt = field(2 * i).resize(patternWidth).asUInt
      def xNegative(i: Int): Bool = field(2 * i).msb
      def y(i: Int): UInt = field(2 * i + 1).resize(patternWidth).asUInt
      def yNegative(i: Int): Bool = field(2 * i + 1).msb
    }

    // the rotation of the corner being fetched, carried beside the pattern (the multipliers' other operands: the
    // last step becomes their input registers)
    val rotation = new Area {

      /** loaded as a corner starts (`begin`, with the fetch's tag): the front end fetches one corner's groups at a
        * time, so its rotation needs no register in every slot and no choice by the tag */
      val fetched = Reg(Rotation())
      // two steps before the copies: the pattern's lookups are a stage behind the count
      val first = stepApart(stepApart(fetched))
      // a copy per point (kept apart), each feeding only its point's four multipliers
      val copies = (0 until pointsPerGroup).map { i =>
        keptApart(stepAt(s"point$i")(first))
      }
      val values = copies.zipWithIndex.map { case (c, i) => stepAt(s"point$i")(c) }
    }
    val productWidth = patternWidth + magnitudeWidth

    /** |x cos|, |y sin|, |x sin|, |y cos|; x' = x cos - y sin = sx (|x cos| -+ |y sin|) and y' = x sin + y cos =
      * sy (|x sin| +- |y cos|), with the signs of the terms */
    case class Products() extends Bundle {
      val xc, ys, xs, yc = UInt(productWidth bits)
      val xSubtract, ySubtract, xNegative, yNegative = Bool()
    }
    val products = new Area {
      val token = stepToken(pattern.token)
      val p = (0 until pointsPerGroup).map { i =>
        val o = Products()
        val cosM = rotation.values(i).cos
        val sinM = rotation.values(i).sin
        val cosNegative = rotation.values(i).cosNegative
        val sinNegative = rotation.values(i).sinNegative
        o.xc := pattern.x(i) * cosM
        o.ys := pattern.y(i) * sinM
        o.xs := pattern.x(i) * sinM
        o.yc := pattern.y(i) * cosM
        val xcNegative = pattern.xNegative(i) ^ cosNegative
        val ysNegative = pattern.yNegative(i) ^ sinNegative
        val xsNegative = pattern.xNegative(i) ^ sinNegative
        val ycNegative = pattern.yNegative(i) ^ cosNegative
        o.xSubtract := xcNegative === ysNegative
        o.ySubtract := xsNegative =/= ycNegative
        o.xNegative := xcNegative
        o.yNegative := xsNegative
        stepAt(s"point${i}products")(o)
      }
    }
    // |x'| and |y'| rounded half to even: the quotient's bits with the sign folded in (ones' complement) and the
    // carry that completes the rounding and the two's complement, in the register after the sum (rounding is
    // symmetric, so the sign comes after the magnitude's rounding), the adder a step later
    val fb = d.rotationFracBits
    val sumWidth = productWidth + 2
    case class Rounding() extends Bundle {
      val folded = Bits(offsetWidth bits)
      val carry = Bool()
    }

    /** a + b or a - b in one adder: (2a + 1) + (2 (b xor s) + s), halved */
    def addSub(a: UInt, b: UInt, subtract: Bool): SInt = {
      val ext = (a.resize(sumWidth) ## True).asUInt
      val other = ((b.resize(sumWidth).asBits ^ B(sumWidth bits, default -> subtract)) ## subtract).asUInt
      (ext + other)(sumWidth downto 1).asSInt
    }

    /** floor(|v| / 2^fb) + 1 when the rest is above the half, or exactly the half and the floor odd (cvRound), then
      * the sign: (q + up) or -(q + up) = ~q + !up, as the folded quotient and the carry in */
    def rounding(v: SInt, negative: Bool): Rounding = {
      val high = v(v.high downto fb - 1)
      val q = high(high.high downto 1).resize(offsetWidth)
      val up = high(0) && (v(fb - 2 downto 0).orR || q.lsb)
      val o = Rounding()
      o.folded := q.asBits ^ B(offsetWidth bits, default -> negative)
      o.carry := up ^ negative
      o
    }

    /** the sum, registered beside the multipliers, then its rounding bits */
    case class Total() extends Bundle {
      val value = SInt(sumWidth bits)
      val negative = Bool()
    }
    def total(v: SInt, negative: Bool): Total = {
      val o = Total()
      o.value := v
      o.negative := negative
      o
    }
    // the products once more in plain registers: the multipliers' own output registers lie apart from the adders
    val near = new Area {
      val token = stepToken(products.token)
      val p = products.p.zipWithIndex.map { case (p, i) => stepAt(s"point${i}near")(p) }
    }
    val totals = new Area {
      val token = stepToken(near.token)
      val x = near.p.map(p => step(total(addSub(p.xc, p.ys, p.xSubtract), p.xNegative)))
      val y = near.p.map(p => step(total(addSub(p.xs, p.yc, p.ySubtract), p.yNegative)))
    }
    val sums = new Area {
      val token = stepToken(totals.token)
      val x = totals.x.map(t => step(rounding(t.value, t.negative)))
      val y = totals.y.map(t => step(rounding(t.value, t.negative)))
    }

    /** the rounded value plus `plus`: the low `width` bits of its two's complement; the carry in as the low bit of
      * both operands (2a + 1 + 2b + c = 2 (a + b + c) + 1), so that `plus` takes no second adder */
    def round(r: Rounding, plus: Int, width: Int): UInt = {
      val folded = r.folded.asSInt.resize(width).asUInt
      val sum = (folded @@ True) + (U(plus, width bits) @@ r.carry)
      sum(width downto 1)
    }
    val rotated = new Area {
      val token = stepToken(sums.token)
      val rx = sums.x.map(s => step(round(s, 0, offsetWidth).asSInt))
      // ry + 18, in [0, 36]
      val rowOffset = sums.y.map(s => step(round(s, sampleReach, rowOffsetWidth)))
    }

    /** A point on its way to the issue stage: its ring slot and column. */
    case class Located() extends Bundle {
      val slot = UInt(slotWidth bits)
      val column = UInt(colWidth bits)
    }
    // the patch's base slot (and it less the ring's rows) and the corner's column, of the group's slot: picked as
    // the group enters `rotated` and registered beside it, so the slot's tag does not reach the sums below
    val entering = sums.token.tag
    val base = step(pick(entering)(_.base).resize(slotWidth + 2))
    val baseBack = step(pick(entering)(_.base).resize(slotWidth + 2).asSInt - S(rows, slotWidth + 2 bits))
    val column = step(pick(entering)(_.corner.corner.x))
    val located = new Area {
      val token = stepToken(rotated.token)
      val points = (0 until pointsPerGroup).map { i =>
        val o = Located()
        // the slot and the slot less the ring's rows, side by side: the second's sign picks
        val offset = rotated.rowOffset(i).resize(slotWidth + 2)
        val near = base + offset
        val wrapped = baseBack + offset.asSInt
        o.slot := Mux(wrapped.msb, near, wrapped.asUInt).resize(slotWidth)
        o.column := (column.intoSInt + rotated.rx(i)).asUInt.resize(colWidth)
        step(o)
      }
      val portB =
        (0 until pointsPerGroup).map(i => step(rotated.rowOffset(i) === 0 || rotated.rowOffset(i) === 2 * sampleReach))
    }
    val planner = new GroupPlanner(bankWidth)
    for ((advance, bits) <- planner.io.advance.zip(planner.stepBits)) advance := enable(bits)
    for (i <- 0 until pointsPerGroup) {
      planner.io.points(i).bank := bankOf(located.points(i).slot)
      planner.io.points(i).portB := located.portB(i)
    }
    val planned = new Area {
      val token = (0 until GroupPlanner.latency).foldLeft(located.token)((v, _) => stepToken(v))
      val points = (0 until GroupPlanner.latency).foldLeft(Vec(located.points))((v, _) => step(v))
      val plan = planner.io.plan
      val single = plan.single
    }

    // ---- issue: a group's clocks one after the other ----
    /** What a clock's reads mean for the tests of the group: per test, whether it completes, through which lanes
      * its points come, and whether its first point was read a clock earlier (held). */
    case class Reads() extends Bundle {
      val valid = Bool()

      /** the slot of the group */
      val tag = Bool()
      val completes, held = Bits(testsPerGroup bits)
      val lane1, lane2 = Vec(UInt(GroupPlanner.laneWidth bits), testsPerGroup)

      /** a test's first point read alone (through the first B lane): keep it for the next clock */
      val hold = Bool()

      /** the group's last clock */
      val last = Bool()
    }

    /** A lane's read: ring slot and column. */
    case class LaneRead() extends Bundle {
      val valid = Bool()
      val slot = UInt(slotWidth bits)
      val column = UInt(colWidth bits)
    }
    val issue = new Area {
      val token = Reg(Token())
      token.valid.init(False)
      val loaded = Mux(advance, planned.token, token)
      token := loaded
      val valid = token.valid
      val points = step(planned.points)
      val plan = step(planned.plan)
      val clock = Reg(UInt(GroupPlanner.issueWidth bits)) init 0

      /** the group's next clock is its last (`clock` + 2 == `issues`), compared a clock ahead from the next values
        * of both (a new group's plan when the front end advances, else the same plan a clock on) */
      val lastNext = RegNext(
        Mux(
          advance,
          planned.plan.double,
          (clock.resize(GroupPlanner.issuesWidth + 1) + 3) === plan.issues.resize(GroupPlanner.issuesWidth + 1)
        )
      ) init False
      // The front end advances in the clock after a group's last: registered, from the group that comes next.
      val continues = Mux(advance, !planned.token.valid || planned.single, lastNext)
      advance := continues
      when(advance) {
        clock := 0
      } otherwise {
        clock := clock + 1
      }
      when(abandons(loaded.tag)) {
        token.valid := False
        advance := True
      }

      /** The next value of `advance` for the copies served by copy `j` of the slots' abandonment, as a choice by
        * `advance` between two registers (`Advancing`): what it would be if the front end advances now (the planned
        * group's tag, validity and plan) and if it does not (the group's own tag and `lastNext`), each registered
        * from the next values of what it reads. So a copy, which lies beside what it enables, is one LUT from
        * registers, and no logic shared by every copy lies before the wires to them. */
      case class Advancing(j: Int) extends Area {
        val ab1Next = slots(1).abandonCopies(j).getAheadValue()
        val ab0Next = slots(0).abandonCopies(j).getAheadValue()
        // after reset no group is planned (it advances) and no slot is abandoned (`lastNext` low): the registers'
        // initial values are the choices' values then, whatever the tags hold. Kept apart: every `j`'s are the same
        // values, meant to lie with their copies.
        val ifAdvancing = keptApart(
          RegNext(
            Mux(planned.token.tag.getAheadValue(), ab1Next, ab0Next) || !planned.token.valid.getAheadValue() ||
              planner.io.singleNext
          ) init True
        )
        val ifHolding = keptApart(
          RegNext(Mux(token.tag.getAheadValue(), ab1Next, ab0Next) || lastNext.getAheadValue()) init False
        )
      }
      val advancing =
        (0 until DescriptorUnit.advanceCopies / DescriptorUnit.advanceCopiesPerAbandon).map(Advancing(_))

      /** a copy of `advance` (kept apart) served by copy `j` of the slots' abandonment */
      def advanceCopy(j: Int): Bool = {
        keptApart(RegNext(Mux(advance, advancing(j).ifAdvancing, advancing(j).ifHolding)) init True)
      }
      // the copies of `advance`, a few at a time from their own copies of the slots' abandonment
      val advanceCopies = (0 until DescriptorUnit.advanceCopies).map { i =>
        advanceCopy(i / DescriptorUnit.advanceCopiesPerAbandon)
      }
      val now = (0 until pointsPerGroup).map(i => plan.issue(i) === clock)
      // which point each lane reads now, registered with the points (the lanes' choice comes from registers)
      val hits = RegNext(Vec((0 until 2 * lanesPerPort).map { l =>
        Vec((0 until pointsPerGroup).map(i => valid && now(i) && plan.lane(i) === l))
      }))
      hits.foreach(_.foreach(_.init(False)))
      val hitPoints = RegNext(points)
      val lanes = Vec(hits.map { laneHits =>
        val o = LaneRead()
        o.valid := laneHits.orR
        val slots = laneHits.zip(hitPoints).map { case (hit, p) => Mux(hit, p.slot, U(0, slotWidth bits)) }
        val columns = laneHits.zip(hitPoints).map { case (hit, p) => Mux(hit, p.column, U(0, colWidth bits)) }
        o.slot := slots.reduceBalancedTree(_ | _)
        o.column := columns.reduceBalancedTree(_ | _)
        o
      })
      val reads = Reads()
      reads.valid := valid
      reads.tag := token.tag
      for (t <- 0 until testsPerGroup) {
        reads.completes(t) := valid && now(2 * t + 1)
        reads.held(t) := plan.issue(2 * t) =/= plan.issue(2 * t + 1)
        reads.lane1(t) := plan.lane(2 * t)
        reads.lane2(t) := plan.lane(2 * t + 1)
      }
      reads.hold := valid && (0 until testsPerGroup).map(t => now(2 * t) && !now(2 * t + 1)).orR
      reads.last := valid && (clock +^ 1) === plan.issues
    }

    // ---- reads ----
    /** A lane's read: its bank and the address within the bank. */
    case class LaneAddress() extends Bundle {
      val valid = Bool()
      val bank = UInt(bankWidth bits)
      val address = UInt(addrWidth bits)
    }

    /** A lane as a cluster of four banks sees it: which of its banks it reads (none when idle), and where. */
    case class ClusterPort() extends Bundle {
      val hits = Bits(4 bits)
      val address = UInt(addrWidth bits)
    }

    /** `r` a clock later; an abandoned corner's reads in flight are void */
    def delayed(r: Reads): Reads = {
      val o = RegNext(r)
      o.valid.init(False)
      when(abandons(r.tag)) {
        o.valid := False
      }
      o
    }
    val clusters = (banks + 3) / 4
    val read = new Area {
      val lanes = RegNext(issue.lanes)
      lanes.foreach(_.valid.init(False))
      // the reads as the lanes leave the issue stage's registers
      val reads0 = delayed(issue.reads)
      val reads1 = delayed(reads0)
      // bank and column, once per lane
      val located = Vec(lanes.map { l =>
        val o = LaneAddress()
        o.valid := l.valid
        o.bank := bankOf(l.slot)
        o.address := (l.slot.lsb ## l.column).asUInt
        val r = RegNext(o)
        r.valid.init(False)
        r
      })
      val reads2 = delayed(reads1)
      // A registered copy of every lane per cluster, decoded for its banks: the long wires to the banks end here,
      // and each bank port picks its address from beside it. The addresses kept apart: every cluster's is the same
      // value, which synthesis would otherwise merge into one register driving every bank.
      val ports = Vec((0 until clusters).map { k =>
        Vec(located.map { l =>
          val o = ClusterPort()
          o.hits := B((0 until 4).map(j => l.valid && l.bank === 4 * k + j))
          o.address := l.address
          val r = RegNext(o)
          r.hits.init(0)
          keptApart(r.address)
          r
        })
      })
      val reads3 = delayed(reads2)
      // the bank number goes on with the reads, to pick the data on the way back
      val bank3 = RegNext(Vec(located.map(_.bank)))
    }

    /** A bank port's read this clock: the first lanes on port A, the others on port B (at most one each). */
    def portRead(bank: Int, portB: Boolean): (Bool, UInt) = {
      val ls = if (portB) lanesPerPort until 2 * lanesPerPort else 0 until lanesPerPort
      val ports = ls.map(read.ports(bank / 4)(_))
      val address = ports.map(p => Mux(p.hits(bank % 4), p.address, U(0, addrWidth bits))).reduceBalancedTree(_ | _)
      (ports.map(_.hits(bank % 4)).orR, address)
    }
    // the data of every bank port, registered (the RAM's output register), three clocks after the cluster copies
    // (the bank port's registers beside the RAM, the RAM, its output register)
    val portA = Vec(UInt(8 bits), banks)
    val portBData = Vec(UInt(8 bits), banks)
    val back = new Area {
      // the reads as the RAMs give their data (a clock more than the numbers say: the bank ports' registers)
      val reads4 = delayed(delayed(read.reads3))
      val reads5 = delayed(reads4)
      val bank4 = RegNext(RegNext(read.bank3))
      // level 1: within each cluster, by the bank's low bits (beside the banks), zero unless the lane reads the
      // cluster
      def dataOf(l: Int): Vec[UInt] = if (l < lanesPerPort) portA else portBData
      // each cluster picks with its own copy of the lane's bank (kept apart: one register would reach every cluster)
      val level1 = Vec(read.lanes.indices.map { l =>
        Vec((0 until clusters).map { k =>
          val members = (4 * k until (4 * k + 4 min banks)).map(dataOf(l)(_))
          val padded = members ++ Seq.fill(4 - members.size)(U(0, 8 bits))
          val low = keptApart(RegNext(bank4(l).resize(2)))
          val here = keptApart(RegNext(bank4(l)(bankWidth - 1 downto 2) === k))
          RegNext(Mux(here, Vec(padded)(low), U(0, 8 bits)))
        })
      })
      val reads6 = delayed(reads5)
      // level 2: the clusters' bytes ORed (one is the lane's, the others zero): no selection where every cluster's
      // data meet
      val value = Vec(read.lanes.indices.map { l =>
        RegNext(level1(l).reduceBalancedTree(_ | _))
      })
      val reads7 = delayed(reads6)
    }

    // ---- compare and collect ----
    val collect = new Area {
      val r = back.reads7
      val held = Reg(UInt(8 bits))
      when(r.valid && r.hold) {
        held := back.value(lanesPerPort)
      }
      val first = Vec((0 until testsPerGroup).map(t => Mux(r.held(t), held, back.value(r.lane1(t)))))
      val second = Vec((0 until testsPerGroup).map(t => back.value(r.lane2(t))))
      val firsts = RegNext(first)
      val seconds = RegNext(second)
      val reads8 = delayed(r)
      // the comparisons registered before a test's result is chosen (its own, or the one held from an earlier clock
      // of the group): no comparison's carry chain reaches the slots' descriptors
      val less = RegNext(Vec((0 until testsPerGroup).map(t => firsts(t) < seconds(t))))
      val reads9 = delayed(reads8)
      val bits = Reg(Bits(testsPerGroup bits))
      val results = Vec((0 until testsPerGroup).map(t => Mux(reads9.completes(t), less(t), bits(t))))
      when(reads9.valid) {
        bits := results.asBits
      }
      // a slot's group complete (`reads9` valid, last and of that slot), decided beside `reads9` into copies of its
      // own (kept apart), each enabling a part of the slot's descriptor
      for (s <- slots) {
        val enables = Seq.fill(1 + DescriptorUnit.collectCopies) {
          keptApart(
            RegNext(reads8.valid && reads8.last && reads8.tag === Bool(s.tag) && !abandons(reads8.tag)) init False
          )
        }
        s.collected(results.asBits, enables)
      }
    }
    shareEnables()
  }

  // The store: bank b holds ring slots 2b and 2b + 1 at (slot & 1) ## column (a single slot has no such bit).
  // Port A writes the stream, which has priority (no point reads the written row's bank through port A: see
  // `DescriptorSchedule`), or reads the A lanes; port B reads the B lanes.
  // the written data a clock later, as the bank ports' registers delay the writes (one copy per cluster)
  val writeData = ring.writeData.map(RegNext(_))
  val store =
    for (b <- 0 until banks) yield new Area {
      val pair = 2 * b + 1 < rows
      val depth = (if (pair) 2 else 1) << colWidth
      val ram = Mem(UInt(8 bits), depth)
      val w = ring.writeBank(b)
      val (enableA, addressA) = engine.portRead(b, portB = false)
      val (enableB, addressB) = engine.portRead(b, portB = true)
      def local(a: UInt): UInt = a.resize(log2Up(depth))
      // every port's address and enable registered beside the RAM, the write with them (reads and writes keep their
      // order): the RAM's inputs come from plain registers, not through the lanes' choice
      val writing = RegNext(w) init False
      val portA = new Area {
        val address = RegNext(local(Mux(w, ring.writeAddress(b / 4), addressA)))
        val enable = RegNext(w || enableA) init False
      }
      val portB = new Area {
        val address = RegNext(local(addressB))
        val enable = RegNext(enableB) init False
      }
      val a = ram.readWriteSync(portA.address, writeData(b / 4), portA.enable, writing)
      val bRead = ram.readSync(portB.address, portB.enable)
      engine.portA(b) := RegNext(a)
      engine.portBData(b) := RegNext(bRead)
    }

  // The oldest corner's finished feature, or a frame's end.
  def oldest[T <: Data](field: EngineSlot => T): T = engine.pick(engine.outTag)(field)
  val finished = oldest(_.state === EngineState.FINISHED)
  output.valid := finished || dispatch.marker
  output.end.now := !finished
  output.end.info := dispatch.c.end.info
  output.x := oldest(_.corner.corner.x)
  output.y := oldest(_.corner.corner.y)
  output.bin := oldest(_.corner.bin)
  output.score := oldest(_.corner.corner.score)
  output.rank := oldest(_.corner.rank)
  output.keyframe := Mux(finished, oldest(_.corner.keyframe), dispatch.c.end.info.keyframe)
  output.descriptor := oldest(_.descriptor)
  engine.handOn(output.ready)
  val engineDrop = oldest(_.state === EngineState.ABANDONED)

  /** The features leave through an output register whose valid, whose readiness to the engine and whose load enables
    * are all registers, so the matcher's readiness does not reach the engine's state or the 256-bit payload through
    * logic. The position, score, rank and tags load in the clock a feature or a frame's end leaves (`loadNow`); the
    * descriptor a clock later, in parts (each by its own copy of `!full` from the clock before: a register straight
    * from a register, so no decision drives the wires to the parts), from the slot its copy of the oldest slot's tag
    * names: the copies follow the tag a clock late (`DescriptorEngine.leftLast`) and a finished slot's descriptor
    * stays until it runs a corner again. The output is offered once the descriptor is in (`shown`, a clock after
    * `full`): a feature reaches the matcher `DescriptorUnit.handOnClocks` after it leaves the engine at the
    * earliest, one per three clocks, where they come at most one per descriptor. A taken item's fields load again
    * no earlier than a clock after the take (its descriptor two), and nothing is offered in those two clocks: the
    * matcher's input contract (`Matcher`), which lets it read the taken feature there instead of copying it. */
  val leaving = new Area {
    val full = RegInit(False)
    val shown = RegInit(False)
    val payload = Reg(FeatureHw(f, h, d))
    output.ready := !full && !engine.leftLast
    when(output.fire) {
      full := True
    }
    when(io.features.fire) {
      full := False
    }
    shown := full && !io.features.fire
    val loadNow = RegNext(!full.getAheadValue()) init True
    when(loadNow) {
      payload.x := output.x
      payload.y := output.y
      payload.bin := output.bin
      payload.score := output.score
      payload.rank := output.rank
      payload.keyframe := output.keyframe
      payload.end := output.end
    }
    val partLoads = Seq.fill(DescriptorUnit.outputParts) {
      keptApart(RegNext(!full) init True)
    }
    val partBits = OrbDescriptorConfig.descriptorBits / partLoads.size
    for (((load, tag), p) <- partLoads.zip(engine.outTags).zipWithIndex) {
      when(load) {
        payload.descriptor(p * partBits, partBits bits) := engine.pick(tag)(_.descriptor(p * partBits, partBits bits))
      }
    }
    io.features.valid := shown
    io.features.payload := payload
  }

  // Every cause registered, then their sum (the count a few clocks late): no counter waits for the queue's
  // pointers, the dispatch's decision or the oldest slot's state.
  val dropCauses = RegNext(Vec(queueDrop, dispatch.refuse && !dispatch.c.end.now, engineDrop))
  dropCauses.foreach(_.init(False))
  val dropsNow = RegNext(dropCauses.map(U(_, 2 bits)).reduce(_ + _)) init 0
  val drops = Reg(f.counter()) init 0
  drops := drops + dropsNow.resize(f.counterWidth)
  io.dropped := drops
}

object DescriptorUnit {

  /** Clocks from a corner's release (its row start), or from the engine becoming free for it, to the engine
    * starting it, at most: the rows since, the row test and the engine's freedom are registered, and a row start in
    * between costs two more. */
  val dispatchClocks: Int = 5

  /** Clocks from a corner's start to its first read issue when no earlier group is ahead of it in the front end:
    * the fetch and the front end's 15 registered stages. */
  val frontLatency: Int = 16

  /** Clocks from a corner's last read issue to its finished descriptor: the reads, the comparison and the
    * collection. */
  val backLatency: Int = 12

  /** Clocks from a corner's start to its finished descriptor beyond its read issues, with no earlier group ahead of
    * it in the front end. */
  val engineLatency: Int = frontLatency + backLatency - 1

  /** The most clocks the previous corner's groups still in the front end when a corner starts (at most
    * `frontLatency` of them, the last) can delay its first issue: their clocks beyond one a group. */
  def maxTailClocks(d: OrbDescriptorConfig): Int = DescriptorSchedule.maxTailExtraClocks(frontLatency, d)

  /** parts of the constant tables (the test pattern, cos and sin), each read with a small index into a register
    * before the part is picked */
  val tableParts: Int = 8

  /** slices of the test pattern's word (whole points each), each looked up and picked by copies of its own */
  val patternSlices: Int = 2

  /** registers from the searched bin to its rotation: the index copies, the words, the parts narrowed to two, the
    * pick and swap */
  val rotationLatency: Int = 4

  /** Clocks from the head leaving to the next head's start or refusal, at most, when the next corner waits in the
    * queue: its bin's search (`AngleSearch.clocks`), its rotation, the dispatch's decision. */
  def headClocks(d: OrbDescriptorConfig): Int = AngleSearch.clocks(d) + rotationLatency + dispatchClocks

  /** Clocks from a feature leaving the engine (its slot handed on) to the matcher's scan taking it, at the earliest:
    * the output register offers it two clocks later (its descriptor loads a clock late, see `leaving`), the matcher
    * takes it a clock after it is first offered (its kind registered: `Matcher`'s input). */
  val handOnClocks: Int = 3

  /** copies of the front end's `advance`, each enabling a share of its registers */
  val advanceCopies: Int = 24

  /** copies of `advance` served by one copy of a slot's abandonment */
  val advanceCopiesPerAbandon: Int = 4

  /** copies of a slot's "group collected" flag, each enabling a part of its descriptor (and one more for its count
    * and state) */
  val collectCopies: Int = 4

  /** parts of the output register's descriptor, each loaded by its own copy of the load enable and the slot's tag */
  val outputParts: Int = 8

  /** Clocks the engine takes for a corner of bin `bin` whose patch's oldest row is in ring slot `base`, from its
    * start to its finished descriptor, when no earlier group is ahead of it in the front end; up to
    * `maxTailClocks` more when the previous corner's last groups are. */
  def clocks(bin: Int, base: Int, d: OrbDescriptorConfig): Int =
    engineLatency + DescriptorSchedule.issueClocks(bin, base, d)

  /** The most clocks from a corner's start to its finished descriptor, over all bins and ring positions. */
  def maxClocks(d: OrbDescriptorConfig): Int = engineLatency + DescriptorSchedule.maxIssueClocks(d) + maxTailClocks(d)

  /** The most clocks from a corner's start until the front end has fetched its last group (and can take the next
    * corner): its last issue comes at most `frontLatency - 1 + maxTailClocks + issues` clocks after the start, and
    * its last group was fetched at least `frontLatency - 1` clocks before (then seen a clock later). */
  def fetchClocks(d: OrbDescriptorConfig): Int = DescriptorSchedule.maxIssueClocks(d) + maxTailClocks(d) + 1
}
