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
  val frames, badFrames, badLines = Reg(UInt(c.counterWidth bits)) init 0

  val input = io.pixels.stage()
  val b = input.payload
  val fire = input.valid

  // Closing the previous frame on a start of frame.
  val close = new Area {
    val good = !bad && x === 0 && y =/= 0 && (!processed || done)
    val fault = fire && b.sof && inFrame && !good
    val endsFrame = fault && !bad && processed && !done
    val countLine = fault && x =/= 0 && !lineFaulted
    val countFrame = fault && !bad
  }

  // The frame state this pixel is checked against (after a start of frame, the new frame's).
  val cur = new Area {
    val start = fire && b.sof
    val nowLocked = Mux(start && inFrame, close.good, locked)
    val nowExpW = Mux(start && inFrame && close.good, lineW, expW)
    val nowExpH = Mux(start && inFrame && close.good, y, expH)
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
  }

  // Checks on this pixel.
  val check = new Area {
    import cur._
    val limitW = Mux(widthKnownNow, lineWNow, U(c.maxWidth, cw bits))
    val limitH = Mux(processedNow, nowExpH, U(c.maxHeight, cw bits))
    val lineFault = xNow >= limitW || (widthKnownNow && b.eol && xNow =/= lineWNow - 1)
    val fault = lineFault || yNow >= limitH
    val first = fault && !badNow
    val endsFrame = first && processedNow && !doneNow
    val complete = processedNow && !badNow && !fault && b.eol && yNow === nowExpH - 1
  }

  when(fire) {
    when(b.sof) {
      inFrame := True
      locked := cur.nowLocked; expW := cur.nowExpW; expH := cur.nowExpH
      key := b.keyframe
      frames := frames + 1
    }
    when(cur.inFrameNow) {
      processed := cur.processedNow
      active := cur.activeNow && !check.fault && !check.complete
      bad := cur.badNow || check.fault
      done := cur.doneNow || check.complete
      when(b.eol) {
        widthKnown := cur.widthKnownNow || !(cur.lineFaultedNow || check.lineFault)
        lineW := Mux(cur.widthKnownNow || cur.lineFaultedNow || check.lineFault, cur.lineWNow, cur.xNow + 1)
        x := 0
        y := Mux(cur.yNow === c.maxHeight, cur.yNow, cur.yNow + 1)
        lineFaulted := False
      } otherwise {
        widthKnown := cur.widthKnownNow
        lineW := cur.lineWNow
        x := Mux(cur.xNow === c.maxWidth, cur.xNow, cur.xNow + 1)
        y := cur.yNow
        lineFaulted := cur.lineFaultedNow || check.lineFault
      }
    }
  }
  // The fault counters count a clock late: their increments are registered, so no adder waits for the checks.
  val lineFaults = RegNext(U(fire && close.countLine, 2 bits) + U(fire && cur.inFrameNow && check.lineFault && !cur.lineFaultedNow, 2 bits)) init 0
  val frameFaults = RegNext(U(fire && close.countFrame, 2 bits) + U(fire && cur.inFrameNow && check.first, 2 bits)) init 0
  badLines := badLines + lineFaults.resize(c.counterWidth)
  badFrames := badFrames + frameFaults.resize(c.counterWidth)

  io.tracked.valid := RegNext(fire && cur.inFrameNow) init False
  val t = io.tracked.payload
  t.luma := RegNext(b.luma)
  t.x := RegNext(cur.xNow)
  t.y := RegNext(cur.yNow)
  t.active := RegNext(cur.activeNow && !check.fault) init False
  t.keyframe := RegNext(cur.keyNow)
  t.ends := RegNext(fire && (close.endsFrame || (cur.inFrameNow && (check.endsFrame || check.complete)))) init False
  t.end.ok := RegNext(check.complete && !close.endsFrame)
  t.end.keyframe := RegNext(Mux(close.endsFrame, key, cur.keyNow))
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
