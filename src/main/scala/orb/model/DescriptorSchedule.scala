package orb.model

import orb.OrbDescriptorConfig

/** The descriptor engine's read schedule (`orb.DescriptorUnit`): in which clock, and through which of its 4 read
  * lanes, each point of a group of 2 tests is read from the banked store of smoothed rows.
  *
  * It does not change what the core computes (the descriptor is `OrbModel.descriptor` whatever the schedule), but
  * it fixes how many clocks a descriptor takes, and so the feature budget's service bound
  * (`OrbConfig.budgetService`). `orb.DescriptorPlannerSpec` checks the hardware planner against `plan`, and
  * `orb.DescriptorSpec` the engine's clocks per descriptor against `issueClocks`.
  *
  * The store: ring slot s (one smoothed row) lives in bank s / 2; each bank has two ports. Lanes 0-1 read through
  * port A of their bank, lanes 2-3 through port B. The stream writes the newest row through port A of its bank,
  * whose other row can only be a patch's newest or oldest row (|ry| = 18): such points always read through port B.
  *
  * A group goes in one clock when its 4 points fit the lanes (no bank read three times, no bank's port B read
  * twice, at most 2 points per port); otherwise its tests one at a time (a test whose two points both need port B
  * of one bank in two clocks). */
object DescriptorSchedule {
  val testsPerGroup: Int = 2
  val pointsPerGroup: Int = 2 * testsPerGroup
  val lanesPerPort: Int = 2
  val groups: Int = OrbDescriptorConfig.descriptorBits / testsPerGroup

  /** A point of a group: its bank, and whether it must read through port B. */
  final case class Point(bank: Int, portB: Boolean)

  /** Per point of a group (p1 of test k at 2k, p2 at 2k + 1): the clock within the group and the lane it reads
    * through; `issues` clocks in all. */
  final case class Plan(issue: IndexedSeq[Int], lane: IndexedSeq[Int], issues: Int)

  def bankOf(slot: Int): Int = slot / 2
  def banks(cfg: OrbDescriptorConfig): Int = (cfg.smoothedRows + 1) / 2

  /** Port B only: a point in a patch's newest or oldest row. */
  def portBOnly(ry: Int): Boolean = ry.abs == OrbDescriptorConfig.sampleReach

  /** The ring slot of a point `ry` rows from the corner, for a patch whose oldest row is in slot `base`. */
  def slotOf(base: Int, ry: Int, cfg: OrbDescriptorConfig): Int =
    (base + ry + OrbDescriptorConfig.sampleReach) % cfg.smoothedRows

  /** The lanes of the points `set` read in one clock, or None when they do not fit. Port B takes the points that
    * must read through it, the second of two points of one bank (the first when the second must use port B), and
    * the points alone in their bank that do not fit port A's 4 lanes after the others; ranks in point order. */
  def lanes(points: IndexedSeq[Point], set: Seq[Int]): Option[Map[Int, Int]] = {
    def partners(i: Int) = set.filter(j => j != i && points(j).bank == points(i).bank)
    val tripled = set.exists(i => partners(i).size > 1)
    val portBTwice = set.exists(i => points(i).portB && partners(i).exists(points(_).portB))
    if (tripled || portBTwice) None
    else {
      val forcedA = set.filter { i =>
        !points(i).portB && partners(i).nonEmpty && (partners(i).exists(points(_).portB) || partners(i).forall(_ > i))
      }
      val free = set.filter(i => !points(i).portB && partners(i).isEmpty)
      val room = lanesPerPort - forcedA.size
      val onA = (forcedA ++ free.take(room max 0)).toSet
      val a = set.filter(onA)
      val b = set.filterNot(onA)
      if (a.size > lanesPerPort || b.size > lanesPerPort) None
      else Some(a.zipWithIndex.toMap ++ b.zipWithIndex.map { case (i, r) => i -> (lanesPerPort + r) })
    }
  }

  /** The schedule of one group. */
  def plan(points: IndexedSeq[Point]): Plan = {
    require(points.size == pointsPerGroup)
    val issue = Array.fill(pointsPerGroup)(0)
    val lane = Array.fill(pointsPerGroup)(0)
    var clock = 0
    def take(set: Seq[Int], l: Map[Int, Int]): Unit = {
      for (i <- set) { issue(i) = clock; lane(i) = l(i) }
      clock += 1
    }
    lanes(points, 0 until pointsPerGroup) match {
      case Some(l) => take(0 until pointsPerGroup, l)
      case None =>
        for (t <- 0 until testsPerGroup) {
          val testSet = Seq(2 * t, 2 * t + 1)
          lanes(points, testSet) match {
            case Some(l) => take(testSet, l)
            case None => for (i <- testSet) take(Seq(i), lanes(points, Seq(i)).get)
          }
        }
    }
    Plan(issue.toIndexedSeq, lane.toIndexedSeq, clock)
  }

  /** The points of the groups of a bin's tests, for a patch whose oldest row is in slot `base`. */
  def groupPoints(bin: Int, base: Int, cfg: OrbDescriptorConfig): IndexedSeq[IndexedSeq[Point]] =
    OrbModel.rotatedTests(bin, cfg).grouped(testsPerGroup).map { tests =>
      tests.flatMap { case (_, y1, _, y2) =>
        Seq(y1, y2).map(ry => Point(bankOf(slotOf(base, ry, cfg)), portBOnly(ry)))
      }.toIndexedSeq
    }.toIndexedSeq

  /** Clocks of reads for a descriptor: the groups' issues, one after the other. */
  def issueClocks(bin: Int, base: Int, cfg: OrbDescriptorConfig): Int =
    groupPoints(bin, base, cfg).map(plan(_).issues).sum

  private val maxCache = scala.collection.concurrent.TrieMap[OrbDescriptorConfig, Int]()

  /** The most clocks of reads any descriptor takes: over every bin and every ring position of its patch. */
  def maxIssueClocks(cfg: OrbDescriptorConfig): Int = maxCache.getOrElseUpdate(
    cfg,
    (0 until cfg.angleBins).map(bin => (0 until cfg.smoothedRows).map(issueClocks(bin, _, cfg)).max).max
  )

  /** Clocks beyond one a group of a descriptor's last `n` groups take, together: the most the groups of one corner
    * still in the engine's front end can hold up the next corner's first group. */
  def tailExtraClocks(bin: Int, base: Int, n: Int, cfg: OrbDescriptorConfig): Int =
    groupPoints(bin, base, cfg).takeRight(n).map(plan(_).issues - 1).sum

  private val tailCache = scala.collection.concurrent.TrieMap[(OrbDescriptorConfig, Int), Int]()

  /** The most of `tailExtraClocks` over every bin and ring position. */
  def maxTailExtraClocks(n: Int, cfg: OrbDescriptorConfig): Int = tailCache.getOrElseUpdate(
    (cfg, n),
    (0 until cfg.angleBins).map(bin => (0 until cfg.smoothedRows).map(tailExtraClocks(bin, _, n, cfg)).max).max
  )
}
