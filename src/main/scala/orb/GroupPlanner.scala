package orb

import spinal.core._
import spinal.lib._
import orb.model.DescriptorSchedule
import orb.model.DescriptorSchedule.{lanesPerPort, pointsPerGroup, testsPerGroup}

/** A point of a group of tests as the planner sees it: its bank, and whether it must read through port B. */
case class PlannedPoint(bankWidth: Int) extends Bundle {
  val bank = UInt(bankWidth bits)
  val portB = Bool()
}

/** The schedule of a group: per point the clock within the group and the read lane, and the group's clocks. */
case class GroupPlan() extends Bundle {
  val issue = Vec(UInt(GroupPlanner.issueWidth bits), pointsPerGroup)
  val lane = Vec(UInt(GroupPlanner.laneWidth bits), pointsPerGroup)
  val issues = UInt(GroupPlanner.issuesWidth bits)

  /** `issues` == 1, and == 2: the issue stage's decisions read these registers, not a comparison */
  val single, double = Bool()
}

/** `DescriptorSchedule.plan` in hardware: the read schedule of a group of tests from its points' banks, in
  * `GroupPlanner.latency` registered steps that advance with `advance` (one enable per step, each a copy of the
  * descriptor engine's front end's: it holds while a group takes more than one clock). It depends on nothing read, so it runs ahead of the reads.
  *
  * Steps: (1) which points share a bank; (2) per candidate set (the group, each test) the port rule's flags: forced
  * to port A, alone in its bank, and whether the set can go in one clock at all; (3) counts: which points go through
  * port A, and whether the whole group fits; (4) ranks within each port, the mode (group, test or point at a time)
  * and each point's clock. */
class GroupPlanner(bankWidth: Int) extends Component {
  import GroupPlanner._
  val io = new Bundle {
    val advance = in Vec (Bool(), latency)
    val points = in Vec (PlannedPoint(bankWidth), pointsPerGroup)
    val plan = out(GroupPlan())

    /** the next value of `plan.single` (what its register loads now) */
    val singleNext = out(Bool())
  }
  def step[T <: Data](v: T, s: Int): T = RegNextWhen(v, io.advance(s))

  val all: Seq[Int] = 0 until pointsPerGroup
  val tests: Seq[Seq[Int]] = (0 until testsPerGroup).map(t => Seq(2 * t, 2 * t + 1))
  val sets: Seq[Seq[Int]] = all +: tests

  // (1) pairs in one bank
  val shared = new Area {
    val same = step(Vec(for (i <- all; j <- all if i < j) yield io.points(i).bank === io.points(j).bank), 0)
    val portB = step(Vec(io.points.map(_.portB)), 0)
    def apply(i: Int, j: Int): Bool = {
      val (a, b) = (i min j, i max j)
      same(all.filter(_ < a).map(k => pointsPerGroup - 1 - k).sum + (b - a - 1))
    }
  }

  // (2) the port rule's flags, per set (DescriptorSchedule.lanes)
  case class SetFlags(n: Int) extends Bundle {
    val forcedA, free = Bits(n bits)
    val fits = Bool()
  }
  val flags = new Area {
    def of(set: Seq[Int]): SetFlags = {
      val o = SetFlags(set.size)
      for ((i, k) <- set.zipWithIndex) {
        val others = set.filter(_ != i)
        val partner = others.map(j => shared(i, j)).orR
        val partnerB = others.map(j => shared(i, j) && shared.portB(j)).orR
        val partnerBefore = others.filter(_ < i).map(j => shared(i, j)).foldLeft(False)(_ || _)
        o.forcedA(k) := !shared.portB(i) && partner && (partnerB || !partnerBefore)
        o.free(k) := !shared.portB(i) && !partner
      }
      val triples = for (i <- set; j <- set; k <- set if i < j && j < k) yield shared(i, j) && shared(j, k)
      val portBTwice = for (i <- set; j <- set if i < j) yield shared(i, j) && shared.portB(i) && shared.portB(j)
      o.fits := !(triples ++ portBTwice).foldLeft(False)(_ || _)
      o
    }
    val bySet = sets.map(set => step(of(set), 1))
  }

  // (3) port A or B per point of each set; whether the whole group fits (at most 4 per port)
  case class SetPorts(n: Int) extends Bundle {
    val onA = Bits(n bits)
    val fits = Bool()
  }
  val ports = new Area {
    def of(s: SetFlags, n: Int): SetPorts = {
      val o = SetPorts(n)
      if (n <= lanesPerPort) {
        // every point alone in its bank fits port A
        o.onA := s.forcedA | s.free
        o.fits := s.fits
      } else {
        val forced = CountOne(s.forcedA)
        val free = CountOne(s.free)
        for (k <- 0 until n) {
          val freeBefore = if (k == 0) U(0) else CountOne(s.free(k - 1 downto 0))
          o.onA(k) := s.forcedA(k) || (s.free(k) && (freeBefore.resize(4 bits) + forced.resize(4 bits) < lanesPerPort))
        }
        o.fits := s.fits && forced <= lanesPerPort && (forced.resize(5 bits) + free.resize(5 bits)) >= lanesPerPort
      }
      o
    }
    val bySet = sets.zip(flags.bySet).map { case (set, s) => step(of(s, set.size), 2) }
  }

  // (4) lanes, the mode and each point's clock
  val schedule = new Area {
    def lanesOf(p: SetPorts, n: Int): Vec[UInt] = Vec((0 until n).map { k =>
      val before = if (k == 0) B(0, 1 bits) else p.onA(k - 1 downto 0)
      val rankA = CountOne(before).resize(laneWidth bits)
      val rankB = (U(k, laneWidth bits) - rankA).resize(laneWidth bits)
      Mux(p.onA(k), rankA, U(lanesPerPort, laneWidth bits) + rankB)
    })
    val group = ports.bySet(0)
    val test = (0 until testsPerGroup).map(t => ports.bySet(1 + t))
    val groupLanes = lanesOf(group, pointsPerGroup)
    val testLanes = test.map(lanesOf(_, 2))
    // clocks per test (a test that does not fit goes point by point), and where each test starts
    val testClocks = test.map(t => Mux(t.fits, U(1, issuesWidth bits), U(2, issuesWidth bits)))
    val testStart = testClocks.scanLeft(U(0, issuesWidth bits))(_ + _)
    val plan = GroupPlan()
    for (i <- all) {
      val t = i / 2
      val second =
        if (i % 2 == 1) Mux(test(t).fits, U(0, issuesWidth bits), U(1, issuesWidth bits)) else U(0, issuesWidth bits)
      plan.issue(i) := Mux(group.fits, U(0, issueWidth bits), (testStart(t) + second).resize(issueWidth))
      // a point read alone must read through port B (two such points of a test in one bank): the first B lane
      val alone = U(lanesPerPort, laneWidth bits)
      plan.lane(i) := Mux(group.fits, groupLanes(i), Mux(test(t).fits, testLanes(t)(i % 2), alone))
    }
    plan.issues := Mux(group.fits, U(1, issuesWidth bits), testStart.last)
    plan.single := plan.issues === 1
    plan.double := plan.issues === 2
    val registered = step(plan, 3)
    io.plan := registered
    io.singleNext := registered.single.getAheadValue()
  }

  /** the bits each step's enable loads */
  def stepBits: Seq[Int] = Seq(
    widthOf(shared.same) + widthOf(shared.portB),
    flags.bySet.map(widthOf(_)).sum,
    ports.bySet.map(widthOf(_)).sum,
    widthOf(io.plan)
  )
}

object GroupPlanner {

  /** registered steps from the points to the plan */
  val latency: Int = 4
  val issueWidth: Int = log2Up(pointsPerGroup)
  val issuesWidth: Int = log2Up(pointsPerGroup + 1)
  val laneWidth: Int = log2Up(2 * lanesPerPort)
  require(DescriptorSchedule.pointsPerGroup == 2 * lanesPerPort, "one lane per point of a group")
}
