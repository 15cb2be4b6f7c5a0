package orb

import spinal.core._
import spinal.lib._
import spinal.lib.misc.pipeline._
import Arith._

/** A corner with its intensity moments and orientation bin. */
case class OrientedCorner(f: FrameConfig, h: HarrisConfig, d: OrbDescriptorConfig) extends Bundle {
  val corner = HarrisCorner(f, h)
  val m10, m01 = SInt(OrientationUnit.momentWidth bits)
  val bin = UInt(d.binWidth bits)
  /** rows are counted from reset, across frames: the row whose start means the corner's smoothed patch is complete */
  val startRow = UInt(OrientationUnit.rowCountWidth bits)
  /** the corner's frame, counted from reset (wrapping) */
  val frameTag = UInt(OrientationUnit.frameTagWidth bits)
  /** the corner's frame is a keyframe */
  val keyframe = Bool()
  /** not a corner: the end of a processed frame, after all of its corners (`end` says how it ended) */
  val frameEnd = Bool()
  val end = FrameEndInfo()
}

/** Orientation by intensity centroid (OpenCV's IC_Angle) without storing any patch.
  *
  * A corner (cx, cy) waits in a queue until the raw column stream reaches row cy + 15: then the shared raw line
  * buffer (>= 31 rows) holds its whole radius-15 disc, and the columns cx-15 .. cx+15 pass one per valid pixel.
  * For every column, sums over the rows |v| <= d around row cy are formed once (for the 10 distinct disc heights
  * d), shared by all corners of that row; each corner, in one of `orientationSlots` slots, picks the sums of its
  * column offset u and accumulates m01 += sum v I and, through two running sums, m10 = sum u I. The finished
  * moments go through a pipelined binary search over the bin-boundary tangents (one multiplier per step), so one
  * corner per clock can leave. A corner that finds the queue full or no free slot is dropped and counted. */
class OrientationUnit(f: FrameConfig, h: HarrisConfig, d: OrbDescriptorConfig, columnRows: Int) extends Component {
  import OrbDescriptorConfig._
  import OrientationUnit._
  require(columnRows >= 2 * patchRadius + 1)
  val io = new Bundle {
    val columns = slave Flow (LineColumn(f, columnRows))
    val corners = slave Flow (HarrisCorner(f, h))
    val oriented = master Flow (OrientedCorner(f, h, d))
    val dropped = out UInt (f.counterWidth bits)
  }
  val cw = f.coordWidth
  val R = patchRadius

  val queue = StreamFifo(HarrisCorner(f, h), d.cornerQueueDepth)
  queue.io.push.valid := io.corners.valid
  queue.io.push.payload := io.corners.payload
  val queueDrop = io.corners.valid && !queue.io.push.ready

  // Shared per-column sums around the centre row (column index R = R rows above the newest), for the 10 distinct disc
  // heights dh: T(dh) = sum over |v| <= dh of I(v), TV(dh) = sum over |v| <= dh of v I(v). Both are prefix sums over
  // v of I(v) + I(-v) and v (I(v) - I(-v)), formed in registered levels (`Arith.prefixSums`) and shared by every
  // corner of the row; the beat travels beside them.
  val sums = new Area {
    val col = io.columns.column
    def at(v: Int): UInt = col(R - v) // the pixel v rows below the centre
    val heights = (0 to R).map(vmax).distinct.sorted
    val pairs = RegNext(Vec((1 to R).map(v => at(v).resize(sumWidth) + at(-v).resize(sumWidth))))
    val centre = RegNext(at(0).resize(sumWidth))
    val differences = RegNext(Vec((1 to R).map(v => at(v).intoSInt.resize(sumWidth) - at(-v).intoSInt.resize(sumWidth))))
    // v (I(v) - I(-v)) by shifts and adds
    val weighted = RegNext(Vec((1 to R).map(v => constMulSigned(differences(v - 1), v, sumWidth))))
    val (t, tLatency) = prefixSums((centre +: pairs).map(_.asSInt), heights, sumWidth, 2)
    val (tv, tvLatency) = prefixSums(weighted, heights.map(_ - 1), sumWidth, 2)
    /** clocks from the column to the sums */
    val latency = 2 + tvLatency
    require(1 + tLatency <= latency)
    val T = Vec(heights.map(dh => Delay(t(dh).asUInt, latency - 1 - tLatency)))
    val TV = Vec(heights.map(dh => tv(dh - 1)))
    val valid = Delay(io.columns.valid, latency, init = False)
    val x = Delay(io.columns.pixel.x, latency)
    val y = Delay(io.columns.pixel.y, latency)
    val active = Delay(io.columns.pixel.active, latency)
    val keyframe = Delay(io.columns.pixel.keyframe, latency)
    val ends = Delay(io.columns.pixel.ends, latency)
    val end = Delay(io.columns.pixel.end, latency)
    // compared at the input and delayed with the beat: a register, not a comparison, where it is used
    val frameStart = Delay(io.columns.valid && io.columns.pixel.x === 0 && io.columns.pixel.y === 0, latency, init = False)
    // Rows and frames counted since reset, the same way the descriptor unit counts them on its stream.
    val rowCount = Reg(UInt(rowCountWidth bits)) init 0
    val frame = Reg(UInt(frameTagWidth bits)) init 0
    val rowNow = Mux(valid && x === 0, rowCount + 1, rowCount)
    val frameNow = Mux(frameStart, frame + 1, frame)
    when(valid && x === 0) { rowCount := rowCount + 1 }
    when(frameStart) { frame := frameNow }
    /** the disc height of column u, one-hot over `heights` (a slot selects its sums with an AND-OR, no mux tree) */
    def heightOnehot(k: Int): Bits = B(BigInt(1) << heights.indexOf(vmax(k.abs)), heights.size bits)
    /** the disc height of the column after u, one-hot over `heights` (a slot selects its sums with an AND-OR, no
      * mux tree), looked up in a table indexed by u's bits (no adder, no comparison) */
    def heightAfter(u: SInt): Bits = {
      val table = Vec((0 until (1 << u.getWidth)).map { bits =>
        val v = if (bits >= (1 << (u.getWidth - 1))) bits - (1 << u.getWidth) else bits
        if (v >= -R && v < R) heightOnehot(v + 1) else B(0, heights.size bits)
      })
      table(u.asUInt)
    }
  }

  // The beat one clock after `sums`: the slots accumulate on it, so that the start decision (queue head against the
  // stream position, free-slot choice) is registered before it reaches the adders.
  val beat = new Area {
    val T = RegNext(sums.T)
    val TV = RegNext(sums.TV)
    val valid = RegNext(sums.valid) init False
    val frameStart = RegNext(sums.frameStart) init False
    val active = RegNext(sums.active)
    val keyframe = RegNext(sums.keyframe)
    val ends = RegNext(sums.ends) init False
    val end = RegNext(sums.end)
    val rowNow = RegNext(sums.rowNow)
    val frameNow = RegNext(sums.frameNow)
  }

  // Slots: a corner starts when the stream is at (cx - R, cy + R) and leaves after (cx + R, cy + R).
  // The queue's head through a register: a RAM's output is too slow to decide on in the same clock.
  // Its start position is computed as it loads (corners lie at least `border` > R from the left edge).
  case class Waiting() extends Bundle {
    val corner = HarrisCorner(f, h)
    val startX, startY = UInt(cw bits)
  }
  // The queue's RAM read through a register first (its output register), then the start position.
  val popped = queue.io.pop.m2sPipe(flush = sums.frameStart)
  val head = popped.map { c =>
    val w = Waiting()
    w.corner := c
    w.startX := c.x - R
    w.startY := c.y + R
    w
  }.m2sPipe(flush = sums.frameStart)
  // The head against the stream position, compared a clock ahead (the position `sums` shows next) into registers. A
  // head loaded in the last clock has no comparisons of its own yet and waits a clock: its start is at least two
  // pixels after the head before it (the 3x3 suppression), and corners reach the queue rows before their start.
  val ahead = new Area {
    val x = Delay(io.columns.pixel.x, sums.latency - 1)
    val y = Delay(io.columns.pixel.y, sums.latency - 1)
    val at = RegNext(y === head.startY && x === head.startX) init False
    val past = RegNext(y > head.startY || (y === head.startY && x > head.startX)) init False
    /** the head is the one the comparisons were made with */
    val compared = RegNext(head.valid && !head.ready) init False
  }
  val startHere = sums.valid && head.valid && ahead.compared && ahead.at
  val slots = for (s <- 0 until d.orientationSlots) yield new Area {
    val busy = Reg(Bool()) init False
    val corner = Reg(HarrisCorner(f, h))
    val u = Reg(SInt(6 bits))
    val height = Reg(Bits(sums.heights.size bits)) // the disc height of column u, one-hot, looked up a clock early
    val acc1 = Reg(UInt(acc1Width bits))
    val acc2 = Reg(UInt(acc2Width bits))
    val m01 = Reg(SInt(momentWidth bits))
  }
  // The start decision is registered before it reaches the slots: the chosen slot accumulates the beat of its first
  // column with zero sums (no adder waits for the decision, only a registered select). Starts are at least two
  // pixels apart after the 3x3 suppression, so a slot is never chosen twice in one clock.
  // The free slot is chosen a clock ahead, from the slots' next busy flags: a slot chosen at the last decision is
  // not busy yet then, but no start follows a start in the next clock.
  val starting = Vec(slots.map(_ => Reg(Bool()) init False))
  val freeNext = Vec(slots.map(slot => !slot.busy.getAheadValue()))
  val chosen = RegNext(OHMasking.first(freeNext.asBits)) init 0
  val anyFree = RegNext(freeNext.orR) init False
  val startOk = startHere && anyFree
  val slotDrop = startHere && !anyFree
  val startCorner = RegNextWhen(head.corner, startOk)
  for (i <- slots.indices) starting(i) := startOk && chosen(i)
  head.ready := startHere || (head.valid && sums.valid && ahead.compared && ahead.past)
  val staleDrop = head.fire && !startHere // its start column went by (a frame ended early, or the queue was late)
  // A new frame: what is still queued or accumulating belongs to a frame that ended before its rows came.
  queue.io.flush := sums.frameStart
  // (a corner pushed on that very clock is lost with the flush, so it counts too; the slots are cleared a clock
  // later, with the beat, and counted then)
  /** the most corners one clock can drop: the queue and its two head registers flushed, the one pushed then, the
    * slots */
  val dropWidth = log2Up(d.cornerQueueDepth + 3 + d.orientationSlots + 4 + 1)
  // What a frame start flushes is registered first (the queue's count, the slots' busy flags) and counted in the
  // clocks after (see `dropsNow`): the slots lie apart, and their count is no path of the frame start's clock.
  val queueFlushed = RegNext(Mux(sums.frameStart,
    queue.io.occupancy.resize(dropWidth) + U(io.corners.valid).resize(dropWidth) + U(popped.valid).resize(dropWidth) +
      U(head.valid).resize(dropWidth),
    U(0, dropWidth bits))) init 0
  val slotsBusy = Vec(slots.zip(starting).map { case (sl, st) => sl.busy || st }).asBits
  val slotsFlushed = RegNext(Mux(beat.frameStart, slotsBusy, B(0, slots.size bits))) init 0

  val heightOfFirst = sums.heightOnehot(-R)
  // Each slot picks its column's sums (by the column's disc height) into registers of its own, then accumulates them a
  // clock later: the wide sums fan out to the slots' selections, and no adder waits for a selection.
  case class Pick() extends Bundle {
    val valid, first, last, active, frameStart = Bool()
    val t = UInt(sumWidth bits)
    val tv = SInt(sumWidth bits)
  }
  case class Patch() extends Bundle {
    val corner = HarrisCorner(f, h)
    val m01 = SInt(momentWidth bits)
    val a1 = UInt(acc1Width bits)
    val a2 = UInt(acc2Width bits)
  }
  /** copies of a slot's finished flag, one per `gatherChunk` bits of its patch */
  val gatherCopies: Int = (Patch().getBitsWidth + gatherChunk - 1) / gatherChunk
  val accumulate = for ((slot, i) <- slots.zipWithIndex) yield new Area {
    val first = starting(i)
    // An idle slot holds its first column's position and height (an enable from its own register, not from the
    // start decision); the first column's advance below takes over.
    when(!slot.busy) {
      slot.u := -R
      slot.height := heightOfFirst
    }
    val u = slot.u
    val last = u === R
    val advancing = beat.valid && (slot.busy || first)
    when(first) { slot.corner := startCorner }
    when(beat.frameStart) {
      slot.busy := False
    } elsewhen (advancing) {
      slot.u := u + 1
      slot.height := sums.heightAfter(u)
      slot.busy := !last
    }
    val pick = Pick()
    pick.valid := advancing && !beat.frameStart
    pick.first := first
    pick.last := last
    pick.active := beat.active
    pick.frameStart := beat.frameStart
    pick.t := MuxOH.or(slot.height.asBools, beat.T)
    pick.tv := MuxOH.or(slot.height.asBools, beat.TV)
    val picked = RegNext(pick)
    picked.valid.init(False)
    val p = picked
    val acc1 = Mux(p.first, U(0, acc1Width bits), slot.acc1)
    val acc2 = Mux(p.first, U(0, acc2Width bits), slot.acc2)
    val m01 = Mux(p.first, S(0, momentWidth bits), slot.m01)
    when(p.valid) {
      slot.acc1 := acc1 + p.t.resize(acc1Width)
      // the running sum of the columns before this one (a2 lags a column behind): no adder waits for acc1's
      slot.acc2 := acc2 + acc1.resize(acc2Width)
      slot.m01 := m01 + p.tv.resize(momentWidth)
    }
    // The last column completes the patch: emitted (from the registers, a clock later) only if no fault came
    // before it in the frame. One copy of the flag per `gatherChunk` bits of the patch (kept apart): each selects
    // its own part of the patch in the gather, no flag fans out to the whole patch.
    val emitNow = p.valid && p.last && p.active
    val emit = RegNext(emitNow) init False
    val emitCopies = Vec.fill(gatherCopies)(RegNext(emitNow) init False)
    emitCopies.addAttribute("preserve")
  }
  // The finished patch, a clock after its last column: m10 = 16 a1 - a2 = 15 a1 - a2' (a2' = acc2, a column
  // behind) is formed in the stage after.
  case class Finished() extends Bundle {
    val oriented = OrientedCorner(f, h, d)
    val a1 = UInt(acc1Width bits)
    val a2 = UInt(acc2Width bits)
  }
  val emits = accumulate.map(_.emit)
  val patches = slots.map { slot =>
    val p = Patch()
    p.corner := slot.corner
    p.m01 := slot.m01
    p.a1 := slot.acc1
    p.a2 := slot.acc2
    p
  }
  // At most one slot finishes per pixel (finishing corners are at distinct x of one row): a one-hot selection, in
  // two registered levels (the slots lie apart): each pair of slots, then the pairs. Each part of the patch is
  // selected by its own copy of the slots' flags.
  /** each slot's patch in parts of `gatherChunk` bits, each ANDed with its own copy of the slot's flag */
  val masked = slots.indices.map { i =>
    patches(i).asBits.subdivideIn(gatherChunk bits, strict = false).toSeq.zipWithIndex.map { case (part, j) =>
      part & B(part.getWidth bits, default -> accumulate(i).emitCopies(j))
    }
  }
  val pairs = slots.indices.grouped(2).toIndexedSeq.map { k =>
    val parts = masked(k.head).indices.map(j => RegNext(k.map(i => masked(i)(j)).reduce(_ | _)))
    val p = Patch()
    p.assignFromBits(parts.reverse.reduce(_ ## _))
    (RegNext(k.map(emits).orR) init False, p)
  }
  val emitted = pairs.map(_._1).orR
  // a pair's part is zero unless one of its slots finished: the pairs are simply ORed
  val patch = Patch()
  patch.assignFromBits(pairs.map(_._2.asBits).reduce(_ | _))
  val beatD = new Area {
    /** clocks from the beat of a patch's last column to the gathered patch: the pick, the slot's finished flag, the
      * pairs' level */
    val gatherClocks = 3
    // The beat of the last column (with its patch), in row cy + R; the descriptor's 37 smoothed rows are complete
    // when row cy + 22 starts.
    val startRow = Delay(beat.rowNow + (OrbDescriptorConfig.startRowOffset - R), gatherClocks)
    val frameTag = Delay(beat.frameNow, gatherClocks)
    val keyframe = Delay(beat.keyframe, gatherClocks)
    val ends = Delay(beat.valid && beat.ends, gatherClocks, init = False)
    val end = Delay(beat.end, gatherClocks)
  }
  // A frame's end follows its corners: no corner of a good frame finishes on its last pixel (the last corners
  // finish 7 rows earlier), and on a fault no corner finishes (it would be dropped).
  val finishing = Flow(Finished())
  finishing.valid := emitted || beatD.ends
  val o = finishing.oriented
  o.corner := patch.corner
  o.m01 := patch.m01
  o.m10.assignDontCare()
  o.bin.assignDontCare()
  o.startRow := beatD.startRow
  o.frameTag := beatD.frameTag
  o.keyframe := beatD.keyframe
  o.frameEnd := beatD.ends
  o.end := beatD.end
  finishing.a1 := patch.a1
  finishing.a2 := patch.a2
  val moments = finishing.stage().map { p =>
    val o = OrientedCorner(f, h, d)
    o := p.oriented
    o.m10.allowOverride() := ((p.a1.resize(momentWidth) |<< 4) - p.a1.resize(momentWidth) - p.a2.resize(momentWidth)).asSInt
    o
  }
  val bins = new AngleSearch(f, h, d)
  bins.io.input << moments.stage()
  io.oriented << bins.io.output

  val faultDrop = slots.map(slot => slot.busy && slot.u === R).orR && beat.valid && !beat.frameStart && !beat.active
  // The clock's drops registered where they arise, summed into a register of their own, then counted (the counter
  // lags the drops by three clocks).
  val singleDrops = RegNext(Vec(queueDrop, slotDrop, staleDrop, faultDrop).asBits) init 0
  val dropsNow = RegNext(CountOne(singleDrops).resize(dropWidth) + CountOne(slotsFlushed).resize(dropWidth) +
    queueFlushed) init 0
  val drops = Reg(UInt(f.counterWidth bits)) init 0
  drops := drops + dropsNow.resize(f.counterWidth)
  io.dropped := drops
}

object OrientationUnit {
  // Column sums of up to 31 pixels: 13 bits; v-weighted sums up to 255 * (1 + .. + 15) = 30600 per side: 16 bits signed.
  val sumWidth: Int = 17
  val acc1Width: Int = 18 // 31 columns of 13-bit sums
  val acc2Width: Int = 23 // 31 partial sums of acc1
  /** |m10|, |m01| <= 255 * sum |u| over the disc < 2^21 */
  val momentWidth: Int = 24
  /** rows counted since reset, wrapping: only differences of a few rows are ever used */
  val rowCountWidth: Int = 12
  /** frames counted since reset, wrapping: tells a corner's frame from the next few */
  val frameTagWidth: Int = 4
  /** bits of a finished patch selected by one copy of its slot's flag in the gather */
  val gatherChunk: Int = 16
}
