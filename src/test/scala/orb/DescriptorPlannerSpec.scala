package orb

import orb.model.DescriptorSchedule
import orb.model.DescriptorSchedule.{Plan, Point, lanesPerPort, pointsPerGroup}
import org.scalatest.funsuite.AnyFunSuite
import spinal.core._
import spinal.core.sim._

/** The descriptor engine's read schedule: the model's rule keeps every read conflict-free, and the hardware planner
  * (`GroupPlanner`) gives exactly the model's plan, for every group of the real pattern and for random groups. */
class DescriptorPlannerSpec extends AnyFunSuite {
  import TestSupport._
  val d: OrbDescriptorConfig = config.descriptor
  val banks: Int = DescriptorSchedule.banks(d)

  def randomGroup(r: scala.util.Random, banksUsed: Int): IndexedSeq[Point] =
    IndexedSeq.fill(pointsPerGroup)(Point(r.nextInt(banksUsed), r.nextInt(5) == 0))

  /** What a plan must guarantee: every point read once, per clock no lane used twice, lanes 0-3 on port A and 4-7
    * on port B of distinct banks, points that must use port B on it. */
  def conflicts(points: IndexedSeq[Point], p: Plan): Seq[String] = {
    val perClock = (0 until p.issues).map(c => (0 until pointsPerGroup).filter(p.issue(_) == c))
    perClock.zipWithIndex.flatMap { case (set, c) =>
      val lanes = set.map(p.lane)
      val ports = set.map(i => (points(i).bank, p.lane(i) >= lanesPerPort))
      Seq(
        if (set.isEmpty) Some(s"clock $c reads nothing") else None,
        if (lanes.distinct.size != lanes.size) Some(s"clock $c: a lane twice") else None,
        if (ports.distinct.size != ports.size) Some(s"clock $c: a bank port twice") else None,
        set.find(i => points(i).portB && p.lane(i) < lanesPerPort).map(i => s"clock $c: point $i must use port B")
      ).flatten
    }
  }

  test("the model's schedule never reads a bank port twice in a clock, on the pattern and on random groups") {
    val r = rng("schedule")
    val groups =
      (for (bin <- 0 until d.angleBins by 3; base <- 0 until d.smoothedRows by 4)
        yield DescriptorSchedule.groupPoints(bin, base, d)).flatten ++ Seq.fill(20000)(randomGroup(
        r,
        1 + r.nextInt(banks)
      ))
    for (g <- groups) {
      val p = DescriptorSchedule.plan(g)
      val bad = conflicts(g, p)
      assert(bad.isEmpty, s"$g -> $p: ${bad.mkString("; ")}")
      assert(p.issues >= 1 && p.issues <= pointsPerGroup)
    }
    val clocks = for (bin <- 0 until d.angleBins by 7; base <- 0 until d.smoothedRows)
      yield DescriptorSchedule.issueClocks(bin, base, d)
    println(
      f"[orb] schedule: ${clocks.sum.toDouble / clocks.size}%.1f clocks of reads per descriptor on average, " +
        s"${clocks.min} to ${clocks.max} (sampled); at most ${DescriptorSchedule.maxIssueClocks(d)} over every bin and ring position"
    )
    assert(
      DescriptorSchedule.maxIssueClocks(d) <= 2 * DescriptorSchedule.groups,
      "the schedule's worst case is the two-clocks-a-group bound"
    )
  }

  lazy val planner = SimConfig.withConfig(Generate.spinalConfig("simWorkspace/planner/rtl").includeSimulation)
    .withVerilator.workspacePath("simWorkspace/planner").compile(new GroupPlanner(log2Up(banks)))

  test("GroupPlanner == DescriptorSchedule.plan: every bin's groups at several ring positions, random groups") {
    val r = rng("planner")
    val vectors =
      (for (bin <- 0 until d.angleBins; base <- Seq(0, 1, d.smoothedRows - 1))
        yield DescriptorSchedule.groupPoints(bin, base, d)).flatten ++ Seq.fill(30000)(randomGroup(
        r,
        1 + r.nextInt(banks)
      ))
    planner.doSim("planner", seed.toInt) { dut =>
      dut.io.advance.foreach(_ #= true)
      for (p <- dut.io.points) {
        p.bank #= 0
        p.portB #= false
      }
      dut.clockDomain.forkStimulus(10)
      dut.clockDomain.waitSampling()
      val lag = GroupPlanner.latency
      for ((g, n) <- vectors.zipWithIndex) {
        for ((p, pt) <- dut.io.points.zip(g)) {
          p.bank #= pt.bank
          p.portB #= pt.portB
        }
        dut.clockDomain.waitSampling()
        if (n >= lag) {
          val expected = DescriptorSchedule.plan(vectors(n - lag))
          val got = Plan(
            dut.io.plan.issue.map(_.toInt).toIndexedSeq,
            dut.io.plan.lane.map(_.toInt).toIndexedSeq,
            dut.io.plan.issues.toInt
          )
          assert(got == expected, s"group ${n - lag}: ${vectors(n - lag)}: model $expected, RTL $got")
        }
      }
    }
  }
}
