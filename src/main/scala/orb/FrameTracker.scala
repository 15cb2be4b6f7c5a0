package orb

import spinal.core._
import spinal.lib._

/** Positions every pixel, learns the frame geometry and polices it; see `orb.model.FrameTrackerModel` for the
  * rules (the model is the specification, this is a register-for-register mirror). The pixel beat is registered on
  * the way in, so the checks start from flip-flops, not from the camera's pins. Latency: `FrameTracker.latency`. */
class FrameTracker(c: FrameConfig) extends Component {
  val io = new Bundle {
    val pixels = slave Flow (PixelBeat())
    val tracked = master Flow (TrackedPixel(c))

    /** expected geometry of the frame being processed */
    val geometry = out(FrameGeometry(c))
    val counters = out(FrameCountersHw(c))
  }
  val cw = c.coordWidth
  val inFrame, locked, processed, active, bad, done, widthKnown, lineFaulted, key = Reg(Bool()) init False
  val x, y, lineW, expW, expH = Reg(UInt(cw bits)) init 0
  val frames, badFrames, badLines = Reg(c.counter()) init 0

  /** The comparisons a beat needs, kept in registers beside the state they describe, so that no comparator lies in
    * the loop from one beat's state to the next (a beat can come every clock). `remW` = limitW - x and
    * `remH` = limitH - y count down to the limits (the learnt width or maxWidth, the expected height or maxHeight). */
  val remWidth = cw + 2
  case class Known() extends Bundle {
    val remW, remH = SInt(remWidth bits)

    /** x >= limitW, x == limitW - 1, y >= limitH, y == limitH - 1 */
    val wOver, wLast, hOver, hLast = Bool()
    val xZero, xMax, yZero, yOne, yTwo, yMax = Bool()

    /** lineW, expW, expH: == 0, 1, 2, and the value less one */
    val lineW0, lineW1, lineW2, expW0, expW1, expW2, expH0, expH1, expH2 = Bool()
    val lineWm1, expWm1, expHm1 = UInt(cw bits)
  }
  val known = Reg(Known())
  known.remW.init(c.maxWidth)
  known.remH.init(c.maxHeight)
  for (
    b <- Seq(
      known.wOver,
      known.wLast,
      known.hOver,
      known.hLast,
      known.xMax,
      known.yOne,
      known.yTwo,
      known.yMax,
      known.lineW1,
      known.lineW2,
      known.expW1,
      known.expW2,
      known.expH1,
      known.expH2
    )
  ) b.init(False)
  for (b <- Seq(known.xZero, known.yZero, known.lineW0, known.expW0, known.expH0)) b.init(True)
  // 0 - 1
  for (v <- Seq(known.lineWm1, known.expWm1, known.expHm1)) v.init(U((1 << cw) - 1, cw bits))

  val input = io.pixels.stage()
  val b = input.payload
  val fire = input.valid

  /** a start of frame, decoded into its own register on the way in: it decides most of the state */
  val starts = RegNext(io.pixels.valid && io.pixels.sof) init False

  // Closing the previous frame on a start of frame. Whether it would close well is kept in a register, from the
  // state's next values: the decision fans out to every field on a start of frame, and starts from a flip-flop.
  val close = new Area {
    val good = RegNext(!bad.getAheadValue() && known.xZero.getAheadValue() && !known.yZero.getAheadValue() &&
      (!processed.getAheadValue() || done.getAheadValue())) init False
    val fault = starts && inFrame && !good
    val endsFrame = fault && !bad && processed && !done
    val countLine = fault && !known.xZero && !lineFaulted
    val countFrame = fault && !bad
  }

  // The frame state this pixel is checked against (after a start of frame, the new frame's).
  val cur = new Area {
    // a copy of `starts` (kept apart) for this beat's checks and the next state's comparisons: `starts` itself
    // loads the frame's fields
    val start = RegNext(io.pixels.valid && io.pixels.sof) init False
    start.addAttribute("preserve")

    /** the frame before was good: its geometry becomes the expected one */
    val learnt = inFrame && close.good
    val nowLocked = Mux(start && inFrame, close.good, locked)
    val nowExpW = Mux(start && learnt, lineW, expW)
    val nowExpH = Mux(start && learnt, y, expH)
    val inFrameNow = inFrame || start
    val processedNow = Mux(start, nowLocked, processed)
    val activeNow = Mux(start, nowLocked, active)
    val badNow = !start && bad
    val doneNow = !start && done
    val widthKnownNow = Mux(start, nowLocked, widthKnown)
    val lineWNow = Mux(start, nowExpW, lineW)
    val lineFaultedNow = !start && lineFaulted
    val keyNow = Mux(start, b.keyframe, key)
    val xNow = Mux(start, U(0, cw bits), x)
    val yNow = Mux(start, U(0, cw bits), y)
    // xNow + 1 and yNow + 1, the adders on the registers beside the start's choice (not behind it)
    val xNowPlusOne = Mux(start, U(1, cw bits), x + 1)
    val yNowPlusOne = Mux(start, U(1, cw bits), y + 1)
    // the comparisons for this beat: after a start of frame x = y = 0 against the new frame's limits
    val expW0 = Mux(learnt, known.lineW0, known.expW0)
    val expW1 = Mux(learnt, known.lineW1, known.expW1)
    val expW2 = Mux(learnt, known.lineW2, known.expW2)
    val expH0 = Mux(learnt, known.yZero, known.expH0)
    val expH1 = Mux(learnt, known.yOne, known.expH1)
    val expH2 = Mux(learnt, known.yTwo, known.expH2)
    val expWm1 = Mux(learnt, known.lineWm1, known.expWm1)
    val expHm1 = Mux(learnt, y - 1, known.expHm1)
    val wOver = Mux(start, nowLocked && expW0, known.wOver)
    val wLast = Mux(start, nowLocked && expW1, known.wLast)
    val hOver = Mux(start, nowLocked && expH0, known.hOver)
    val hLast = Mux(start, nowLocked && expH1, known.hLast)
    val xZero = start || known.xZero
    val xMax = !start && known.xMax
    val yZero = start || known.yZero
    val yOne = !start && known.yOne
    val yTwo = !start && known.yTwo
    val yMax = !start && known.yMax
    val lineW0 = Mux(start, expW0, known.lineW0)
    val lineW1 = Mux(start, expW1, known.lineW1)
    val lineW2 = Mux(start, expW2, known.lineW2)
    val lineWm1 = Mux(start, expWm1, known.lineWm1)
  }

  // Checks on this pixel.
  val check = new Area {
    import cur._
    val lineFault = wOver || (widthKnownNow && b.eol && !wLast)
    val fault = lineFault || hOver
    val first = fault && !badNow
    val endsFrame = first && processedNow && !doneNow
    val complete = processedNow && !badNow && !fault && b.eol && hLast
  }

  // The comparisons of the state after this beat.
  val next = new Area {
    import cur._

    /** x - limitW, y - limitH now (after a start of frame: the new limits, x = y = 0) */
    val remW = Mux(start, Mux(nowLocked, nowExpW, U(c.maxWidth, cw bits)).resize(remWidth).asSInt, known.remW)
    val remH = Mux(start, Mux(nowLocked, nowExpH, U(c.maxHeight, cw bits)).resize(remWidth).asSInt, known.remH)

    /** remW <= 1, remW == 2 (likewise remH): where the next pixel stands */
    val wNear = Mux(start, nowLocked && (expW0 || expW1), known.remW <= 1)
    val wNext = Mux(start, nowLocked && expW2, known.remW === 2)
    val hNear = Mux(start, nowLocked && (expH0 || expH1), known.remH <= 1)
    val hNext = Mux(start, nowLocked && expH2, known.remH === 2)
    val remWm1 = Mux(start, Mux(nowLocked, expWm1, U(c.maxWidth - 1, cw bits)).resize(remWidth).asSInt, known.remW - 1)
    val remHm1 = Mux(start, Mux(nowLocked, expHm1, U(c.maxHeight - 1, cw bits)).resize(remWidth).asSInt, known.remH - 1)
    val xIsMaxM1 = !start && x === c.maxWidth - 1
    val yIsMaxM1 = !start && y === c.maxHeight - 1
    val xIsOne = !start && x === 1

    /** the line's width is kept (known, or not learnt from a faulty line) */
    val keep = widthKnownNow || lineFaultedNow || check.lineFault
  }

  when(fire) {
    when(starts) {
      inFrame := True
      locked := cur.nowLocked
      expW := cur.nowExpW
      expH := cur.nowExpH
      known.expW0 := cur.expW0
      known.expW1 := cur.expW1
      known.expW2 := cur.expW2
      known.expWm1 := cur.expWm1
      known.expH0 := cur.expH0
      known.expH1 := cur.expH1
      known.expH2 := cur.expH2
      known.expHm1 := cur.expHm1
      key := b.keyframe
      frames := frames + 1
    }
    when(cur.inFrameNow) {
      processed := cur.processedNow
      active := cur.activeNow && !check.fault && !check.complete
      bad := cur.badNow || check.fault
      done := cur.doneNow || check.complete
      when(b.eol) {
        // the next line: x = 0 against the (possibly learnt) width; y one more (saturating at maxHeight)
        val learns = !next.keep
        widthKnown := cur.widthKnownNow || learns
        lineW := Mux(next.keep, cur.lineWNow, cur.xNowPlusOne)
        known.lineW0 := next.keep && cur.lineW0
        known.lineW1 := Mux(next.keep, cur.lineW1, cur.xZero)
        known.lineW2 := Mux(next.keep, cur.lineW2, next.xIsOne)
        known.lineWm1 := Mux(next.keep, cur.lineWm1, cur.xNow)
        val knownAfter = cur.widthKnownNow || learns
        known.remW := Mux(knownAfter, Mux(next.keep, cur.lineWNow, cur.xNowPlusOne), U(c.maxWidth, cw bits)).resize(
          remWidth
        ).asSInt
        known.wOver := knownAfter && next.keep && cur.lineW0
        known.wLast := knownAfter && Mux(next.keep, cur.lineW1, cur.xZero)
        x := 0
        known.xZero := True
        known.xMax := False
        y := Mux(cur.yMax, cur.yNow, cur.yNowPlusOne)
        known.remH := Mux(cur.yMax, next.remH, next.remHm1)
        known.hOver := Mux(cur.yMax, cur.hOver, next.hNear)
        known.hLast := Mux(cur.yMax, cur.hLast, next.hNext)
        known.yZero := False
        known.yOne := cur.yZero && !cur.yMax
        known.yTwo := cur.yOne
        known.yMax := cur.yMax || next.yIsMaxM1
        lineFaulted := False
      } otherwise {
        // the next pixel of the line: x one more (saturating at maxWidth)
        widthKnown := cur.widthKnownNow
        lineW := cur.lineWNow
        known.lineW0 := cur.lineW0
        known.lineW1 := cur.lineW1
        known.lineW2 := cur.lineW2
        known.lineWm1 := cur.lineWm1
        x := Mux(cur.xMax, cur.xNow, cur.xNowPlusOne)
        known.remW := Mux(cur.xMax, next.remW, next.remWm1)
        known.wOver := Mux(cur.xMax, cur.wOver, next.wNear)
        known.wLast := Mux(cur.xMax, cur.wLast, next.wNext)
        known.xZero := cur.xMax && cur.xZero
        known.xMax := cur.xMax || next.xIsMaxM1
        y := cur.yNow
        known.remH := next.remH
        known.hOver := cur.hOver
        known.hLast := cur.hLast
        known.yZero := cur.yZero
        known.yOne := cur.yOne
        known.yTwo := cur.yTwo
        known.yMax := cur.yMax
        lineFaulted := cur.lineFaultedNow || check.lineFault
      }
    }
  }
  // The fault counters count a clock late: their increments are registered, so no adder waits for the checks.
  val lineFaults = RegNext(U(fire && close.countLine, 2 bits) + U(
    fire && cur.inFrameNow && check.lineFault && !cur.lineFaultedNow,
    2 bits
  )) init 0
  val frameFaults =
    RegNext(U(fire && close.countFrame, 2 bits) + U(fire && cur.inFrameNow && check.first, 2 bits)) init 0
  badLines := badLines + lineFaults.resize(c.counterWidth)
  badFrames := badFrames + frameFaults.resize(c.counterWidth)

  io.tracked.valid := RegNext(fire && cur.inFrameNow) init False
  val t = io.tracked.payload
  t.luma := RegNext(b.luma)
  t.x := RegNext(cur.xNow)
  t.y := RegNext(cur.yNow)
  t.active := RegNext(cur.activeNow && !check.fault) init False
  t.keyframe := RegNext(cur.keyNow)
  t.end.now := RegNext(fire && (close.endsFrame || (cur.inFrameNow && (check.endsFrame || check.complete)))) init False
  t.end.info.ok := RegNext(check.complete && !close.endsFrame)
  t.end.info.keyframe := RegNext(Mux(close.endsFrame, key, cur.keyNow))
  io.geometry.width := expW
  io.geometry.height := expH
  io.counters.frames := frames
  io.counters.badFrames := badFrames
  io.counters.badLines := badLines
}

object FrameTracker {

  /** clocks from a beat to its tracked pixel: the input register and the checks */
  val latency: Int = 2
}
