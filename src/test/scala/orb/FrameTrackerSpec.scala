package orb

import orb.model._
import org.scalatest.funsuite.AnyFunSuite
import spinal.core._
import spinal.core.sim._
import scala.collection.mutable.ArrayBuffer
import scala.util.Random

/** The frame tracker alone against its model, beat by beat (every output field) and counter by counter, on long
  * random streams of well-formed and malformed frames in a small geometry (16 x 16 limits). */
class FrameTrackerSpec extends AnyFunSuite {
  import TestSupport._
  val small = FrameConfig(maxWidth = 16, maxHeight = 16, coordWidth = 5)
  lazy val tracker = {
    println(s"[orb] compiling the frame tracker alone; seed = $seed")
    orb.testbench.CoreSim.simConfig("simWorkspace/test").compile(new FrameTracker(small))
  }

  /** Frames of a few geometries; about a third of them broken in one of the ways a camera link breaks. */
  def randomStream(r: Random, frames: Int): Seq[Beat] = {
    val out = ArrayBuffer[Beat]()
    var (w, h) = (1 + r.nextInt(18), 1 + r.nextInt(18))
    for (_ <- 0 until frames) {
      if (r.nextDouble() < 0.15) { w = 1 + r.nextInt(18); h = 1 + r.nextInt(18) }
      var frame = (for (y <- 0 until h; x <- 0 until w)
        yield Beat(r.nextInt(256), sof = x == 0 && y == 0, eol = x == w - 1, keyframe = r.nextBoolean())).toVector
      if (r.nextDouble() < 0.35 && frame.size > 1) {
        val i = r.nextInt(frame.size)
        frame = r.nextInt(5) match {
          case 0 => frame.updated(i, frame(i).copy(eol = !frame(i).eol)) // a missing or extra end of line
          case 1 => frame.take(i) // cut short by the next start of frame
          case 2 => frame ++ frame.takeRight(w) // one line too many
          case 3 => frame.patch(i, Seq.fill(1 + r.nextInt(20))(Beat(7, sof = false, eol = false)), 0) // a long line
          case _ => frame.patch(i, Nil, 1 + r.nextInt(3)) // pixels lost
        }
      }
      if (r.nextDouble() < 0.03) out ++= Seq.fill(r.nextInt(10))(Beat(1, sof = false, eol = r.nextBoolean())) // junk
      out ++= frame
    }
    out.toSeq
  }

  test("every tracked field and counter == model on random malformed streams") {
    for (run <- 0 until 4) {
      val r = rng(s"tracker-$run")
      val beats = randomStream(r, 300)
      val model = new FrameTrackerModel(small)
      val expected = beats.flatMap(model.step)
      val got = ArrayBuffer[TrackedBeat]()
      var counters: FrameCounters = null
      tracker.doSim(s"tracker-$run", seed.toInt) { dut =>
        orb.testbench.CoreSim.idlePixels(dut.io.pixels)
        orb.testbench.CoreSim.startClock(dut.clockDomain)
        dut.clockDomain.onSamplings {
          val t = dut.io.tracked
          if (t.valid.toBoolean) {
            val end =
              if (t.end.now.toBoolean) Some(FrameEnd(t.end.info.ok.toBoolean, t.end.info.keyframe.toBoolean)) else None
            got += TrackedBeat(t.luma.toInt, t.x.toInt, t.y.toInt, t.active.toBoolean, end)
          }
        }
        orb.testbench.CoreSim.drivePixels(dut.io.pixels, dut.clockDomain, beats, orb.testbench.Blanking.random, r)
        // the counters count the last beat's faults a few clocks after it (registered checks, then increments)
        dut.clockDomain.waitSampling(5)
        counters = FrameCounters(
          dut.io.counters.frames.toLong,
          dut.io.counters.badFrames.toLong,
          dut.io.counters.badLines.toLong
        )
      }
      orb.testbench.Scoreboard.describe(s"run $run", "tracked beats", expected, got.toSeq).foreach(msg => fail(msg))
      assert(counters == model.stats, s"run $run: counters")
      val processed = expected.count(_.end.isDefined)
      println(s"[orb] tracker run $run: ${beats.size} beats, ${model.stats}, $processed processed frames ended")
      assert(processed > 10 && model.stats.badFrames > 10, "the stream should mix good and faulty frames")
    }
  }
}
