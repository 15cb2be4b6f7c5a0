package orb

import orb.model._
import orb.testbench._
import java.io.File
import scala.util.Random

/** Shared by the suites: one compiled Verilator model per test run, seeds, test images. */
object TestSupport {

  /** Every suite's random choices derive from this; override with ORB_SEED=n. */
  val seed: Long = sys.env.get("ORB_SEED").flatMap(_.toLongOption).getOrElse(20261123L)
  def rng(salt: String): Random = new Random(seed ^ salt.hashCode.toLong)

  val config: OrbConfig = OrbConfig.default
  val threshold: Long = config.harris.defaultThreshold

  /** The detector after reset: Harris threshold and segment test */
  val cornerParams: CornerParams = config.defaultParams

  /** Pure Harris maxima (segment test off) at half the threshold, which gives them about the corner rate of the
    * default on the photographs; also for patterns whose corners are crossings, which no segment test passes */
  val harrisOnly: CornerParams = CornerParams(threshold / 2, None)

  lazy val core = {
    println(s"[orb] compiling the Verilator model of OrbCore (default config); seed = $seed (override with ORB_SEED)")
    CoreSim.compile(config, workspace = "simWorkspace/test")
  }

  /** The engine's runs that break what the budget's service bound counts on (`OrbConfig.windowClocks`): exactly the
    * schedule's clocks when a corner started alone, at most the previous corner's tail more when it started behind
    * it, its last group fetched within `issues + tail + 1` clocks. */
  def engineOffSchedule(rtl: orb.testbench.RtlResult): Seq[String] = {
    val d = config.descriptor
    val tail = DescriptorUnit.maxTailClocks(d)
    rtl.engineRuns.flatMap { r =>
      val exact = DescriptorUnit.clocks(r.bin, r.base, d)
      val fetchBy = orb.model.DescriptorSchedule.issueClocks(r.bin, r.base, d) + tail + 1
      val clocksOk = if (r.overlapped) r.clocks >= exact && r.clocks <= exact + tail else r.clocks == exact
      if (clocksOk && r.fetched >= 0 && r.fetched <= fetchBy) None
      else Some(s"$r: schedule $exact (+ up to $tail behind another), fetched by $fetchBy")
    }
  }

  def dataFile(name: String): File = {
    val f = new File("data", name)
    require(f.isFile, s"missing test image ${f.getPath}: run the tests from the project root")
    f
  }
  def image(name: String): GrayImage = GrayImage.load(dataFile(name))

  object Patterns {
    def blank(w: Int, h: Int, v: Int = 128): GrayImage = GrayImage.tabulate(w, h)((_, _) => v)
    def edges(w: Int, h: Int): GrayImage = GrayImage.tabulate(w, h)((x, y) => if (x > w / 2 || y > h / 3) 200 else 40)
    def checkerboard(w: Int, h: Int, square: Int): GrayImage =
      GrayImage.tabulate(w, h)((x, y) => if (((x / square) + (y / square)) % 2 == 0) 30 else 220)
    def noise(w: Int, h: Int, rng: Random): GrayImage = GrayImage.tabulate(w, h)((_, _) => rng.nextInt(256))

    /** Bright rectangles of random size and level on a dark ground: corners of every contrast. */
    def boxes(w: Int, h: Int, rng: Random, n: Int = 12): GrayImage = {
      val px = Array.fill(w * h)(20 + rng.nextInt(10))
      for (_ <- 0 until n) {
        val bw = 6 + rng.nextInt(w / 3); val bh = 6 + rng.nextInt(h / 3)
        val x0 = rng.nextInt(w - bw); val y0 = rng.nextInt(h - bh); val v = 60 + rng.nextInt(190)
        for (y <- y0 until y0 + bh; x <- x0 until x0 + bw) px(y * w + x) = v
      }
      GrayImage(w, h, px)
    }
  }
}
