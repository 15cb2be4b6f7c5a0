package orb

import spinal.core._
import spinal.lib._
import orb.Pipes.keptApart

/** Positions every pixel, learns the frame geometry and polices it; see `orb.model.FrameTrackerModel` for the
  * rules (the model is the specification, this is a register-for-register mirror). The pixel beat is registered on
  * the way in, so the checks start from flip-flops, not from the camera's pins. Latency: `FrameTracker.latency`. */
class FrameTracker(c: FrameConfig, xCopies: Int = 0) extends Component {
  val io = new Bundle {
    val pixels = slave Flow (PixelBeat())
    val tracked = master Flow (TrackedPixel(c))

    /** `xCopies` copies of the tracked pixel's x (registers kept apart), for readers that lie apart (the line
      * buffer's RAMs: `LineBuffer.readCopies`) */
    val xCopies = out Vec (c.coord(), FrameTracker.this.xCopies)

    /** expected geometry of the frame being processed */
    val geometry = out(FrameGeometry(c))
    val counters = out(FrameCountersHw(c))
  }
  val cw = c.coordWidth
  val inFrame, locked, processed, active, bad, done, widthKnown, lineFaulted, key = Reg(Bool()) init False
  val x, y, lineW, expW, expH = Reg(UInt(cw bits)) init 0

  /** x + 1, kept beside x (loaded wherever x is), so that no incrementer lies before x's loads */
  val xPlusOne = Reg(UInt(cw bits)) init 1
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

  /** A start of frame, decoded into a register on the way in: `starts` loads the frame's fields (kept apart from
    * the beat kinds' copies below, which would otherwise take its loads across the tracker). */
  val starts = keptApart(RegNext(io.pixels.valid && io.pixels.sof) init False)

  /** A beat's kind, decoded into registers on the way in, one copy (kept apart) per group of registers it drives:
    * `opens` a start of frame, `runs` any other beat inside a frame (a frame is entered at the first start of
    * frame and never left), so neither waits for the input register's valid or `inFrame`. */
  class BeatKind extends Area {
    val opens = keptApart(RegNext(io.pixels.valid && io.pixels.sof) init False)
    val runs = keptApart(RegNext(io.pixels.valid && !io.pixels.sof && (inFrame || starts)) init False)

    /** the beat's end of line, a copy of the input register's (kept apart; the output side reads none) */
    val eol = keptApart(RegNext(io.pixels.eol))
  }

  /** the column side (x), the width side (the line's width and x's comparisons with it), the height side (y), the
    * frame's flags and counts, the output: each its own copies, so no decoded beat drives more than a side */
  val xSide, wSide, ySide, flagSide, outSide = new BeatKind

  /** The frame so far is good and would lock the geometry if a start of frame came now: in a frame, no fault, at
    * the start of a line after at least one line, and completed if processed. Kept in registers from the state's
    * next values in both cases below, so a start of frame decides from flip-flops; `learnt` loads the frame's
    * fields, `learntBeat` (a copy kept apart) the beat's. Before the first start of frame nothing is locked, so
    * at a start `learnt` is also the new frame's `locked`. */
  val learnt = Reg(Bool()) init False
  val learntBeat = keptApart(Reg(Bool()) init False)

  /** copies of `learntBeat` (kept apart; the same next value) for the width and the height side */
  val learntX, learntY = keptApart(Reg(Bool()) init False)

  /** A start of frame closes the frame before it (the same decisions in both copies' terms). */
  val close = new Area {
    val fault = inFrame && !learntBeat
    val endsFrame = fault && !bad && processed && !done
    val countLine = fault && !known.xZero && !lineFaulted
    val countFrame = fault && !bad
  }

  /** The first beat of a frame, at x = y = 0, checked against the geometry it locks (`learnt`) or against the
    * limits while measuring: every value from a register or two, without the running case's logic. */
  val opening = new Area {
    val l = learntBeat
    val lineFault = l && (known.lineW0 || (b.eol && !known.lineW1))
    val fault = l && (known.lineW0 || known.yZero || (b.eol && !known.lineW1))
    val complete = l && b.eol && known.yOne && known.lineW1
    val endsFrame = close.endsFrame || fault || complete
    val learntAfter = b.eol && (!l || (known.lineW1 && known.yOne))
  }

  /** A beat inside a frame: the comparisons come from the `known` registers beside the state. */
  val running = new Area {
    val lineFault = known.wOver || (widthKnown && b.eol && !known.wLast)
    val fault = lineFault || known.hOver
    val first = fault && !bad
    val endsFrame = first && processed && !done
    val complete = processed && !bad && !fault && b.eol && known.hLast

    /** the line's width is kept (known, or not learnt from a faulty line); else it is learnt as x + 1 */
    val keep = widthKnown || lineFaulted || known.wOver
    val knownAfter = widthKnown || !keep
    val learntAfter = !(bad || fault) && (b.eol || (known.xMax && known.xZero && !known.yZero)) &&
      (!processed || done || complete)
  }

  when(starts) {
    inFrame := True
    locked := learnt
    key := b.keyframe
    frames := frames + 1
    when(learnt) {
      expW := lineW
      expH := y
      known.expW0 := known.lineW0
      known.expW1 := known.lineW1
      known.expW2 := known.lineW2
      known.expWm1 := known.lineWm1
      known.expH0 := known.yZero
      known.expH1 := known.yOne
      known.expH2 := known.yTwo
      known.expHm1 := y - 1
    }
  }

  // The frame's flags: the first beat against the locked geometry, the others against the comparisons.
  when(flagSide.opens) {
    val l = opening.l
    processed := l
    active := l && !opening.fault && !opening.complete
    bad := opening.fault
    done := opening.complete
    learntBeat := opening.learntAfter
    when(flagSide.eol) {
      lineFaulted := False
    } otherwise {
      lineFaulted := opening.lineFault
    }
  }
  when(flagSide.runs) {
    active := active && !running.fault && !running.complete
    bad := bad || running.fault
    done := done || running.complete
    learntBeat := running.learntAfter
    when(flagSide.eol) {
      lineFaulted := False
    } otherwise {
      lineFaulted := lineFaulted || running.lineFault
    }
  }

  // The column side: x, its increment and its own tests.
  when(xSide.opens) {
    known.xMax := False
    when(xSide.eol) {
      // the next line, x = 0
      x := 0
      xPlusOne := 1
      known.xZero := True
    } otherwise {
      // x = 1 on the first line
      x := 1
      xPlusOne := 2
      known.xZero := False
    }
  }
  when(xSide.runs) {
    when(xSide.eol) {
      // the next line: x = 0
      x := 0
      xPlusOne := 1
      known.xZero := True
      known.xMax := False
    } elsewhen (!known.xMax) {
      // the next pixel of the line: x one more (saturating at maxWidth)
      x := xPlusOne
      xPlusOne := xPlusOne + 1
      known.xZero := False
      known.xMax := x === c.maxWidth - 1
    }
  }

  // The width side: the line's width and x's comparisons with it.
  when(wSide.opens) {
    val l = learntX
    when(wSide.eol) {
      // the next line, x = 0: the width is the locked one, or learnt as 1
      widthKnown := True
      lineW := Mux(l, lineW, U(1, cw bits))
      known.lineW0 := l && known.lineW0
      known.lineW1 := !l || known.lineW1
      known.lineW2 := l && known.lineW2
      known.lineWm1 := Mux(l, known.lineWm1, U(0, cw bits))
      known.remW := Mux(l, lineW, U(1, cw bits)).resize(remWidth).asSInt
      known.wOver := l && known.lineW0
      known.wLast := !l || known.lineW1
    } otherwise {
      // x = 1 on the first line, against the locked width or the limits
      widthKnown := l
      when(!l) {
        lineW := expW
        known.lineW0 := known.expW0
        known.lineW1 := known.expW1
        known.lineW2 := known.expW2
        known.lineWm1 := known.expWm1
      }
      known.remW := Mux(l, known.lineWm1, U(c.maxWidth - 1, cw bits)).resize(remWidth).asSInt
      known.wOver := l && (known.lineW0 || known.lineW1)
      known.wLast := l && known.lineW2
    }
  }
  when(wSide.runs) {
    when(wSide.eol) {
      // the next line: x = 0 against the (possibly learnt) width
      val keep = running.keep
      widthKnown := running.knownAfter
      when(!keep) {
        lineW := xPlusOne
        known.lineW0 := False
        known.lineW1 := known.xZero
        known.lineW2 := x === 1
        known.lineWm1 := x
      }
      known.remW := Mux(running.knownAfter, Mux(keep, lineW, xPlusOne), U(c.maxWidth, cw bits))
        .resize(remWidth)
        .asSInt
      known.wOver := running.knownAfter && keep && known.lineW0
      known.wLast := running.knownAfter && Mux(keep, known.lineW1, known.xZero)
    } elsewhen (!known.xMax) {
      // the next pixel of the line: one fewer to the limit
      known.remW := known.remW - 1
      known.wOver := known.remW <= 1
      known.wLast := known.remW === 2
    }
  }

  // The height side: y and its comparisons.
  when(ySide.opens) {
    val l = learntY
    known.yMax := False
    when(ySide.eol) {
      // the next line, y = 1
      y := 1
      known.remH := Mux(l, y - 1, U(c.maxHeight - 1, cw bits)).resize(remWidth).asSInt
      known.hOver := l && (known.yZero || known.yOne)
      known.hLast := l && known.yTwo
      known.yZero := False
      known.yOne := True
      known.yTwo := False
    } otherwise {
      y := 0
      known.remH := Mux(l, y, U(c.maxHeight, cw bits)).resize(remWidth).asSInt
      known.hOver := l && known.yZero
      known.hLast := l && known.yOne
      known.yZero := True
      known.yOne := False
      known.yTwo := False
    }
  }
  when(ySide.runs && ySide.eol) {
    // y one more (saturating at maxHeight)
    when(!known.yMax) {
      y := y + 1
      known.remH := known.remH - 1
      known.hOver := known.remH <= 1
      known.hLast := known.remH === 2
      known.yOne := known.yZero
      known.yMax := y === c.maxHeight - 1
    } otherwise {
      known.yOne := False
    }
    known.yZero := False
    known.yTwo := known.yOne
  }
  // `learnt` follows `learntBeat` (the same next value, a separate register for the frame's fields)
  learnt := learntBeat.getAheadValue()
  learntX := learntBeat.getAheadValue()
  learntY := learntBeat.getAheadValue()

  // The fault counters count two clocks late: the checks registered first, the increments formed from them a clock
  // later, so neither the increments' adders nor the counters wait for the checks.
  case class FaultChecks() extends Bundle {
    val opens, closingLine, openingLine, runningLine, closingFrame, openingFrame, runningFrame = Bool()
  }
  val checks = Reg(FaultChecks())
  checks.init(FaultChecks().getZero)
  checks.opens := flagSide.opens
  checks.closingLine := close.countLine
  checks.openingLine := opening.lineFault
  checks.runningLine := flagSide.runs && running.lineFault && !lineFaulted
  checks.closingFrame := close.countFrame
  checks.openingFrame := opening.fault
  checks.runningFrame := flagSide.runs && running.first
  val lineFaults = RegNext(
    Mux(
      checks.opens,
      U(checks.closingLine, 2 bits) + U(checks.openingLine, 2 bits),
      U(checks.runningLine, 2 bits)
    )
  ) init 0
  val frameFaults = RegNext(
    Mux(
      checks.opens,
      U(checks.closingFrame, 2 bits) + U(checks.openingFrame, 2 bits),
      U(checks.runningFrame, 2 bits)
    )
  ) init 0
  badLines := badLines + lineFaults.resize(c.counterWidth)
  badFrames := badFrames + frameFaults.resize(c.counterWidth)

  val opens = outSide.opens
  io.tracked.valid := RegNext(opens || outSide.runs) init False
  val t = io.tracked.payload
  t.luma := RegNext(b.luma)
  t.x := RegNext(Mux(opens, U(0, cw bits), x))
  for (copy <- io.xCopies) copy := keptApart(RegNext(Mux(opens, U(0, cw bits), x)))
  t.y := RegNext(Mux(opens, U(0, cw bits), y))
  t.active := RegNext(Mux(opens, opening.l && !opening.fault, active && !running.fault)) init False
  t.keyframe := RegNext(Mux(opens, b.keyframe, key))
  t.end.now := RegNext(
    Mux(opens, opening.endsFrame, outSide.runs && (running.endsFrame || running.complete))
  ) init False
  t.end.info.ok := RegNext(Mux(opens, opening.complete && !close.endsFrame, running.complete))
  t.end.info.keyframe := RegNext(Mux(opens && !close.endsFrame, b.keyframe, key))
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
