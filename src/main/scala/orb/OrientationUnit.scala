package orb

import spinal.core._
import spinal.lib._
import orb.Pipes.{delayApart, keptApart}
import Arith._

/** Orientation by intensity centroid (OpenCV's IC_Angle) without storing any patch or keeping any per-corner state
  * while its disc passes.
  *
  * The shared raw line buffer (>= 31 rows) gives a column per valid pixel. For every column, sums over the rows
  * |v| <= h around the row 15 rows above the newest are formed once, for the 10 distinct disc heights h: T(h) = sum
  * I(v) and TV(h) = sum v I(v). The moments of the disc centred on every column c of that row then come out of three
  * transposed FIR chains of 31 taps that advance with the valid pixels: tap j adds the sum of its own, fixed disc
  * height h(15 - j) of the column passing it (a wire, no selection), so when column c + 15 passes, the chains hold
  * m01 = sum over the disc of v I, sum T and sum j T, from which m10 = sum u I = 15 sum T - sum j T. A selected
  * corner (cx, cy) waits in a queue until the stream is at (cx + 15, cy + 15) and takes the chains' moments there;
  * its bin is found from them at the descriptor unit's queue (`AngleSearch`, one corner at a time). Any number of corners of a row can be
  * oriented (corners come at least two pixels apart). A corner that finds the queue full, whose last column went by
  * (its frame ended early) or whose last column is not processed (a fault before it) is dropped and counted. */
class OrientationUnit(f: FrameConfig, h: HarrisConfig, d: OrbDescriptorConfig, columnRows: Int) extends Component {
  import OrbDescriptorConfig._
  import OrientationUnit._
  require(columnRows >= 2 * patchRadius + 1)
  val io = new Bundle {
    val columns = slave Flow (LineColumn(f, columnRows))
    val corners = slave Flow (CornerHw(f, h))
    val oriented = master Flow (OrientedCorner(f, h))
    val dropped = out(f.counter())
  }
  val cw = f.coordWidth
  val R = patchRadius
  require(isPow2(R + 1), "m10 = R sum T - sum j T is formed with R t = 2^s t - t")

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
    val differences =
      RegNext(Vec((1 to R).map(v => at(v).intoSInt.resize(sumWidth) - at(-v).intoSInt.resize(sumWidth))))
    // v (I(v) - I(-v)) by shifts and adds
    val weighted = RegNext(Vec((1 to R).map(v => constMulSigned(differences(v - 1), v, sumWidth))))
    val (t, tLatency) = prefixSums((centre +: pairs).map(_.asSInt), heights, sumWidth, sumLevelsPerStage)
    val (tv, tvLatency) = prefixSums(weighted, heights.map(_ - 1), sumWidth, sumLevelsPerStage)

    /** clocks from the column to the sums */
    val latency = 2 + tvLatency
    require(1 + tLatency <= latency)
    // narrowed to their ranges before they fan out to the chains' taps
    val T = Vec(heights.map(dh => Delay(t(dh).asUInt.resize(columnSumWidth), latency - 1 - tLatency)))
    val TV = Vec(heights.map(dh => tv(dh - 1).resize(weightedSumWidth)))
    // the column stream's valid and position delayed by registers of this block's own (`Pipes.delayApart`)
    require(latency >= 3)
    val validFirst = keptApart(RegNext(io.columns.valid) init False)
    // (the pixel's place only: its value is in the column, and kept registers are kept even when nothing reads them)
    val pixelFirst = keptApart(RegNext(io.columns.pixel.place))
    val validAhead = delayApart(validFirst, latency - 2, init = False)
    val valid = keptApart(RegNext(validAhead) init False)

    /** a copy of `valid` (its last register kept apart) for a consumer apart from the chains */
    def validCopy(): Bool = keptApart(RegNext(validAhead) init False)
    // the beat's pixel beside its sums, a clock before (`pixelAhead`) and two (`pixelBefore`; the head is compared
    // two clocks ahead with its position's copy, `positionEarly`)
    require(latency >= 4, "the head's comparisons branch from the pixel's delay two clocks before `pixel`")
    val pixelEarlier = delayApart(pixelFirst, latency - 4)
    val pixelBefore = keptApart(RegNext(pixelEarlier))
    val pixelAhead = keptApart(RegNext(pixelBefore))
    val pixel = RegNext(pixelAhead)

    /** the position of `pixelBefore` beside the head's comparisons: its column in a copy of its own (kept apart; the
      * register that serves the row's start lies apart from them), its row `pixelBefore`'s (the beat's delay carries
      * the row on to nothing that reads it) */
    val positionEarly = new Area {
      val x = keptApart(RegNext(pixelEarlier.x))
      val y = pixelBefore.y
    }
    val x = pixel.x
    val y = pixel.y
    val active = pixel.active
    val keyframe = pixel.keyframe
    val end = pixel.end
    // tested from the first registers of the beat's delay (the line buffer's register lies apart), the column and the
    // row apart, and delayed with the beat: a register, not a comparison, where it is used
    val xZero = RegNext(pixelFirst.x === 0)
    val yZero = RegNext(pixelFirst.y === 0)
    val validSecond = RegNext(validFirst) init False
    // (latency >= 3, required above: the frame start's copies branch a clock before it)
    val frameStartAhead = Delay(validSecond && xZero && yZero, latency - 3, init = False)
    val frameStart = RegNext(frameStartAhead) init False

    /** a copy of `frameStart` (kept apart) for a consumer that lies apart from the sums */
    def frameStartCopy(): Bool = keptApart(RegNext(frameStartAhead) init False)
    // the row's start compared a clock ahead, from the registers before `valid` and `pixel`; only processed rows
    // count, as on the descriptor unit's ring (a corner's tags name rows the ring counts)
    val rowStart = RegNext(validAhead && pixelAhead.x === 0 && pixelAhead.active) init False
    val clock = new RowClock(f, rowStart, frameStart)
  }

  // A corner waits by its patch's last column (cx + R, cy + R modulo 2^cw, which the stream position is compared
  // with), formed before the queue: no adder lies between the queue's RAM and the head's comparisons. Its own
  // position is that less R again as it finishes.
  case class Waiting() extends Bundle {
    val lastX, lastY = UInt(cw bits)
    val score = UInt(h.scoreWidth bits)
  }

  // The budget's corners through a register of their own first (the budget lies apart from the queue's pointers):
  // a corner reaches the queue a clock later, rows before its last column. A frame start flushes it with the queue.
  val arriving = RegNext(io.corners.valid && !sums.frameStart) init False
  val arrivingCorner = Reg(Waiting())
  arrivingCorner.lastX := io.corners.payload.x + R
  arrivingCorner.lastY := io.corners.payload.y + R
  arrivingCorner.score := io.corners.payload.score
  val queue = new CreditFifo(Waiting(), d.cornerQueueDepth)
  queue.io.push.valid := arriving
  queue.io.push.payload := arrivingCorner
  val queueDrop = arriving && !queue.io.push.ready && !sums.frameStart

  // The beat one clock after `sums`: the chains add its sums.
  val beat = new Area {
    val T = RegNext(sums.T)
    val TV = RegNext(sums.TV)
    val valid = RegNext(sums.valid) init False
    val keyframe = RegNext(sums.keyframe)
    val end = RegNext(sums.end)
    end.now.init(False)
    val rowNow = RegNext(sums.clock.rowNext)
    val frameNow = RegNext(sums.clock.frameNext)
  }

  // The chains: tap j (0 .. 2R) adds the sums of the column R - j columns right of a disc's centre when the disc's
  // last column passes tap 0. On a valid beat every tap takes its right neighbour's value plus its own column sum, so
  // after the beat of column c + R, tap 0 holds the sums over the columns c - R .. c + R. `ts` is a second chain over
  // the first one's taps: sum j T(h(R - j)) of the column j beats back, the weight of a column growing by one per
  // beat it waits.
  val chains = new Area {
    val taps = 2 * R + 1

    /** each group of `chainGroup` taps advances by its own copy of the beat's valid (kept apart) */
    val advance = (0 until (taps + chainGroup - 1) / chainGroup).map { _ =>
      keptApart(RegNext(sums.valid) init False)
    }
    def heightOf(j: Int): Int = sums.heights.indexOf(vmax((R - j).abs))
    // each tap as wide as the most it can hold: the columns from it to the chain's end
    def columnT(j: Int): BigInt = BigInt(2 * vmax((R - j).abs) + 1) * 255
    def columnTV(j: Int): BigInt = BigInt(vmax((R - j).abs)) * (vmax((R - j).abs) + 1) / 2 * 255
    val tMax = (0 until taps).map(j => (j until taps).map(columnT).sum)
    val tsMax = (0 until taps).map(j => (j + 1 until taps).map(tMax).sum)
    val tvMax = (0 until taps).map(j => (j until taps).map(columnTV).sum)
    val t = (0 until taps).map(j => Reg(UInt(log2Up(tMax(j) + 1) bits)))
    val ts = (0 until taps).map(j => Reg(UInt(log2Up(tsMax(j) + 1) max 1 bits)))
    val tv = (0 until taps).map(j => Reg(SInt(log2Up(tvMax(j) + 1) + 1 bits)))
    for (j <- 0 until taps) {
      when(advance(j / chainGroup)) {
        if (j == taps - 1) {
          t(j) := beat.T(heightOf(j)).resize(t(j).getWidth)
          ts(j) := 0
          tv(j) := beat.TV(heightOf(j)).resize(tv(j).getWidth)
        } else {
          t(j) := t(j + 1).resize(t(j).getWidth) + beat.T(heightOf(j)).resize(t(j).getWidth)
          ts(j) := ts(j + 1).resize(ts(j).getWidth) + t(j + 1).resize(ts(j).getWidth)
          tv(j) := tv(j + 1).resize(tv(j).getWidth) + beat.TV(heightOf(j)).resize(tv(j).getWidth)
        }
      }
    }
    require(t.head.getWidth <= acc1Width && ts.head.getWidth <= acc2Width && tv.head.getWidth <= momentWidth)
  }

  // The queue's head: the queue reads ahead into registers of its own (its RAM's data through a plain register
  // first, its reads decided from registers: no decision on the head reaches the queue's RAM and pointers), then the
  // corner after the head, which takes one only when empty (its readiness a register: the head's decision reaches
  // no further back). The head passes a corner at most every other clock (corners' last columns come two pixels
  // apart at least, and a head waits a clock for its comparisons), so that is fast enough: the corner after the
  // head is in place again in the clock the head can next fire.
  val popped = Pipes.halfPipe(queue.io.pop, flush = sums.frameStart)
  val head = popped.m2sPipe(flush = sums.frameStart)
  // The head against the stream position: compared two clocks ahead (the position `sums` shows in the next clock
  // but one) into registers, with the head and with the corner after it, and the comparisons of the one the head
  // holds in the next clock chosen then (a head loaded in the last clock has its own from the corner after it).
  // A head loaded in the last clock still waits a clock: its last column is at least two pixels after the head
  // before it (the 3x3 suppression), and corners reach the queue rows before it.
  val ahead = new Area {
    // the position as one number, row above column (x < 2^cw): "reached" is one comparison, one carry chain
    val position = sums.positionEarly.y @@ sums.positionEarly.x

    /** whether the stream has reached `w`'s last column (or gone past it: the row and the column compared side by
      * side, two short carry chains, not one through both), and whether it is there, a clock later: the parts'
      * results registered, combined after the register (a carry chain and the combination not in one clock) */
    class Compared(w: Waiting) extends Area {
      val last = w.lastY @@ w.lastX
      val reachedParts = RegNext(Arith.comparedInParts(position, last, orEqual = true, parts = 2))
      val reached = Arith.combineParts(reachedParts)
      val atParts = RegNext(Cat(sums.positionEarly.x === w.lastX, sums.positionEarly.y === w.lastY))
      val at = atParts.andR
    }
    val ofHead = new Compared(head.payload)
    val ofNext = new Compared(popped.payload)

    /** the head took the corner after it in the last clock */
    val loaded = RegNext(popped.fire) init False
    val reached = Mux(loaded, ofNext.reached, ofHead.reached)
    val at = RegNext(Mux(loaded, ofNext.at, ofHead.at)) init False

    /** the head is the one the comparisons were made with, and the stream has reached its last column: the pop
      * needs no comparison of its own, so the queue's enables follow two registers */
    val due = RegNext(head.valid && !head.ready && reached) init False
  }
  // When `sums` shows the head's last column: the chains add it a clock later (at the beat) and hold the head's
  // moments the clock after that. Emitted only when that column was processed (no fault before it in the frame).
  // (the beat's valid from a copy of its own: the queue's registers lie apart from the chains)
  val beatValid = sums.validCopy()
  head.ready := head.valid && beatValid && ahead.due
  val finishHere = head.ready && ahead.at
  val staleDrop = head.fire && !finishHere // its last column went by (a frame ended early, or the queue was late)
  val faultDrop = finishHere && !sums.active
  // A new frame: what is still queued belongs to a frame that ended before its rows came.
  // the queue's pointers lie apart from the sums: a copy of the frame start of their own
  queue.io.flush := sums.frameStartCopy()

  // the corners held beside the queue's RAM: the one in front of the queue and the one arriving, the queue's reads
  // (and its places, `placed`), the corner after the head and the head
  val held = Vec(Seq(io.corners.valid, arriving) ++ queue.io.held.asBools ++ Seq(popped.valid, head.valid))

  /** the most corners one clock can drop: the queue's RAM and places and every corner held beside them flushed, and
    * the clock's single drops (`singleDrops`) */
  val dropWidth = log2Up(d.cornerQueueDepth + queue.buffer + held.size + 3 + 1)
  // What a frame start flushes is registered first, the queue's count apart from the corners held around it
  // (no adder behind the count's register), and counted in the clocks after (see `dropsNow`).
  val flushedQueued = RegNext(Mux(sums.frameStart, queue.io.stored.resize(dropWidth), U(0, dropWidth bits))) init 0
  val heldWidth = log2Up(held.size + queue.buffer + 1)
  val flushedHeld = RegNext(
    Mux(sums.frameStart, CountOne(held).resize(heldWidth) + queue.io.placed.resize(heldWidth), U(0, heldWidth bits))
  ) init 0

  // The finished corner, a clock after its last column's beat: m10 = sum u I = R sum T - sum j T, formed in the
  // stage after.
  case class Finished() extends Bundle {
    val oriented = OrientedCorner(f, h)
    val t = UInt(acc1Width bits)
    val ts = UInt(acc2Width bits)
  }
  val finishing = Flow(Finished())
  val emit = Delay(finishHere && sums.active, 2, init = False)
  val finished = RegNextWhen(head.payload, finishHere)
  val beatD = new Area {
    // The beat of the last column, in row cy + R: the corner's own row is R rows back.
    val rowTag = RegNext(beat.rowNow - R)
    val frameTag = RegNext(beat.frameNow)
    val keyframe = RegNext(beat.keyframe)
    val end = Reg(FrameEndMark())
    end.now.init(False)
    end.now := beat.valid && beat.end.now
    end.info := beat.end.info
  }
  // A frame's end follows its corners: no corner of a good frame finishes on its last pixel (the last corners finish
  // 7 rows earlier), and on a fault no corner finishes (it would be dropped).
  finishing.valid := emit || beatD.end.now
  val o = finishing.oriented
  o.corner.x := finished.lastX - R
  o.corner.y := finished.lastY - R
  o.corner.score := finished.score
  o.m01 := chains.tv(0).resize(momentWidth)
  o.m10.assignDontCare()
  o.rowTag := beatD.rowTag
  o.frameTag := beatD.frameTag
  o.keyframe := beatD.keyframe
  o.end := beatD.end
  finishing.t := chains.t(0).resize(acc1Width)
  finishing.ts := chains.ts(0).resize(acc2Width)
  val moments = finishing.stage().map { p =>
    val o = OrientedCorner(f, h)
    o := p.oriented
    // R t - ts = 2^s t - t - ts (R + 1 = 2^s) = (2^s t + 1) + ~t + ~ts + 1: one carry-save step into one adder
    // (2^s t has its low bit free for the first one, the carry word for the second)
    val t = p.t.resize(momentWidth).asSInt
    val ts = p.ts.resize(momentWidth).asSInt
    o.m10.allowOverride() :=
      carrySaveSumSigned(Seq((t |<< log2Up(R + 1)) | S(1, momentWidth bits), ~t, ~ts), momentWidth, plusOne = true)
    o
  }
  io.oriented << moments.stage()

  // The clock's drops registered where they arise, summed in two registered steps (one adder each), then counted
  // (the counter lags the drops by four clocks).
  val singleDrops = RegNext(Vec(queueDrop, staleDrop, faultDrop).asBits) init 0
  val singleAndHeld = RegNext(CountOne(singleDrops).resize(dropWidth) + flushedHeld.resize(dropWidth)) init 0
  val queuedLater = RegNext(flushedQueued) init 0
  val dropsNow = RegNext(singleAndHeld + queuedLater) init 0
  val drops = Reg(f.counter()) init 0
  drops := drops + dropsNow.resize(f.counterWidth)
  io.dropped := drops
}

object OrientationUnit {
  private val r = OrbDescriptorConfig.patchRadius

  /** a column's sum over its disc height: at most 2r + 1 pixels of 255 */
  val columnSumWidth: Int = log2Up((2 * r + 1) * 255 + 1)

  /** a column's v-weighted sum: |sum| <= 255 * (1 + .. + r), signed */
  val weightedSumWidth: Int = log2Up(255 * r * (r + 1) / 2 + 1) + 1

  /** the column sums' working width, signed, for both kinds */
  val sumWidth: Int = (columnSumWidth + 1) max weightedSumWidth

  /** sum T over a disc: 2r + 1 column sums */
  val acc1Width: Int = log2Up((2 * r + 1) * ((2 * r + 1) * 255) + 1)

  /** sum j T over a disc, j = 0 .. 2r */
  val acc2Width: Int = log2Up(r * (2 * r + 1) * ((2 * r + 1) * 255) + 1)

  /** |m10| <= 255 * sum of |u| over the disc, |m01| <= 255 * sum of |v|, signed (the sums modulo 2^width on the
    * way: only the moment itself has to fit) */
  val momentWidth: Int = {
    val halfWidths = (-r to r).map(v => OrbDescriptorConfig.umax(v.abs))
    val sumU = halfWidths.map(u => u * (u + 1)).sum
    val sumV = (-r to r).zip(halfWidths).map { case (v, u) => v.abs * (2 * u + 1) }.sum
    log2Up(255 * (sumU max sumV) + 1) + 1
  }

  /** adder levels of the column sums' prefix sums between registers: one (every column sum a register after each
    * adder; the flip-flops share the adders' logic elements) */
  val sumLevelsPerStage: Int = 1

  /** taps of the moment chains that share one copy of the beat's valid */
  val chainGroup: Int = 2
}
