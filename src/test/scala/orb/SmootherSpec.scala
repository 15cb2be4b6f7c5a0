package orb

import orb.model._
import orb.testbench._
import org.scalatest.funsuite.AnyFunSuite
import spinal.core._
import spinal.core.sim._
import spinal.lib._

/** The tracker, a 7-row line buffer and the smoother, as the descriptor stage will use them. */
class SmootherHarness(f: FrameConfig) extends Component {
  val io = new Bundle {
    val pixels = slave Flow (PixelBeat())
    val smoothed = master Flow (SmoothedPixel(f))
  }
  val tracker = new FrameTracker(f, LineBuffer.readCopies(f, 7))
  val lines = new LineBuffer(f, 7)
  val smoother = new Smoother(f, 7)
  tracker.io.pixels << io.pixels
  lines.follow(tracker)
  smoother.io.columns << lines.io.columns
  io.smoothed << smoother.io.smoothed
}

class SmootherSpec extends AnyFunSuite {
  import TestSupport._
  lazy val harness = {
    println(s"[orb] compiling the smoother harness; seed = $seed")
    CoreSim.simConfig("simWorkspace/test").compile(new SmootherHarness(config.frame))
  }

  def check(name: String, img: GrayImage, blanking: Blanking): Unit = {
    val expected = OrbModel.smooth(img)
    val beats = Beat.frame(img) ++ Beat.frame(img) // the second frame is processed
    var mismatches = Vector[String](); var checked = 0
    harness.doSim(name, seed.toInt) { dut =>
      CoreSim.idlePixels(dut.io.pixels)
      CoreSim.startClock(dut.clockDomain)
      var row = 0 // the beat's row, counted from the frame and row starts the smoother flags
      dut.clockDomain.onSamplings {
        val s = dut.io.smoothed
        if (s.valid.toBoolean) {
          if (s.frameStart.toBoolean) row = 0
          else if (s.rowStart.toBoolean) row += 1
        }
        if (s.valid.toBoolean && s.active.toBoolean) {
          val (x, y) = (s.x.toInt - 3, row - 3)
          if (x >= 3 && y >= 3) {
            checked += 1
            if (s.smoothed.toInt != expected(x, y))
              mismatches :+= s"($x,$y): RTL ${s.smoothed.toInt}, model ${expected(x, y)}"
          }
        }
      }
      CoreSim.drivePixels(dut.io.pixels, dut.clockDomain, beats, blanking, rng(name))
      dut.clockDomain.waitSampling(Smoother.latency + 8)
    }
    assert(checked == (img.width - 6) * (img.height - 6), s"$name: every inner pixel checked")
    assert(mismatches.isEmpty, s"$name: ${mismatches.size} pixels differ, first ${mismatches.take(5).mkString("; ")}")
    println(s"[orb] smoother $name: $checked pixels equal to the model")
  }

  test("smoothed image == model: noise with gaps, a real photograph") {
    check("smooth-noise", Patterns.noise(64, 40, rng("smooth")), Blanking.random)
    check("smooth-graf1", image("graf1.png").crop(200, 150, 200, 120), Blanking.none)
  }
}
