package orb.sim

import orb._
import orb.model._
import orb.testbench._
import spinal.core.sim._

import java.awt.{BasicStroke, Color, RenderingHints}
import java.awt.image.BufferedImage
import java.io.{File, PrintWriter}
import javax.imageio.ImageIO
import scala.util.Random

/** `sim/runMain orb.sim.Match --key A.png --live B.png --out DIR [options]`: one keyframe and one live image
  * through the core (the golden model or the Verilator RTL), with every output a user wants to look at. */
object Match {
  val app = "orb.sim.Match"
  val usage: String =
    s"""usage: $app --key KEY.png --live LIVE.png --out DIR [options]
       |  --engine model|rtl      the golden model (default; seconds) or the Verilator simulation of OrbTop (minutes)
       |  --homography H.txt      3x3 keyframe -> live homography: inlier ratios in summary.json, coloured matches.png
       |  --hamming N             accept a best match at distance <= N (0..256, default ${OrbConfig.default.matcher
        .defaultHammingThreshold})
       |  --ratio R               ratio test: best < R * second best (0 < R < 2, e.g. 0.8; default off)
       |  --cross-check / --no-cross-check   mutual nearest neighbours only (default ${if (
        OrbConfig.default.matcher.defaultCrossCheck
      ) "on"
      else "off"})
       |  --features N            the feature budget's target: features per frame, 0..${BudgetConfig
        .targetMax} (default ${OrbConfig.default.budget.defaultTarget})
       |  --harris-threshold T    the minimum corner score (default ${OrbConfig.default.harris.defaultThreshold})
       |  --segment-threshold T   the segment test's intensity threshold, 0..255 (default ${OrbConfig.default.harris
        .segment.fold("-")(_.defaultThreshold.toString)})
       |  --no-segment-test       every pixel a corner candidate: pure Harris maxima (CONTROL bit 2 off)
       |  --config NAME           core preset: ${OrbConfig.presets.keys.toSeq.sorted.mkString(", ")} (default: default)
       |  --wave                  (rtl) DIR/wave.fst over the live frame's first rows (or around --trace), DIR/wave.gtkw
       |  --wave-rows N           rows of the live frame in the waveform (default 48)
       |  --trace X,Y             every stage's values for the live feature nearest (X, Y): DIR/trace.txt
       |  --seed N                blanking and back-pressure of the rtl run (default 1)
       |  --help                  this text""".stripMargin

  final case class Options(
      key: String = null,
      live: String = null,
      out: String = null,
      engine: String = "model",
      homography: Option[String] = None,
      params: MatchParams = OrbConfig.default.matcher.defaultParams,
      threshold: Long = OrbConfig.default.harris.defaultThreshold,
      features: Int = OrbConfig.default.budget.defaultTarget,
      /** None: the configuration's default; Some(None): no segment test */
      segment: Option[Option[Int]] = None,
      configName: String = "default",
      wave: Boolean = false,
      waveRows: Int = 48,
      trace: Option[(Int, Int)] = None,
      seed: Long = 1
  ) {
    def config: OrbConfig = OrbConfig.presets(configName)
    def corners: CornerParams =
      CornerParams(threshold, segment.getOrElse(config.harris.defaultParams.segmentThreshold), features)
  }

  private def fail(msg: String): Nothing = CommandLine.fail(msg)

  private val options: Seq[CommandLine.Opt[Options]] = {
    import CommandLine.{flag, valued, whole}
    def segment(o: Options, s: Option[Int]): Options =
      if (o.segment.exists(_.isDefined != s.isDefined))
        fail("--segment-threshold and --no-segment-test contradict each other")
      else o.copy(segment = Some(s))
    Seq(
      valued("--key")((o, v) => o.copy(key = v)),
      valued("--live")((o, v) => o.copy(live = v)),
      valued("--out")((o, v) => o.copy(out = v)),
      valued("--engine")((o, v) => o.copy(engine = CommandLine.choice("--engine", v, Seq("model", "rtl")))),
      valued("--homography")((o, v) => o.copy(homography = Some(v))),
      valued("--hamming")((o, v) =>
        o.copy(params = o.params.copy(hammingThreshold = whole("--hamming", v, 0, 256).toInt))
      ),
      valued("--ratio") { (o, v) =>
        val r = CommandLine.number("--ratio", v, "a number between 0 and 2")(r => r > 0 && r < 2)
        val fracBits = o.config.matcher.ratioFracBits
        val scaled = math.round(r * (1 << fracBits)).toInt min ((2 << fracBits) - 1)
        o.copy(params = o.params.copy(ratio = Some(scaled)))
      },
      flag("--cross-check")(o => o.copy(params = o.params.copy(crossCheck = true))),
      flag("--no-cross-check")(o => o.copy(params = o.params.copy(crossCheck = false))),
      valued("--harris-threshold")((o, v) => o.copy(threshold = whole("--harris-threshold", v, 0, 0xffffffffL))),
      valued("--features")((o, v) => o.copy(features = whole("--features", v, 0, BudgetConfig.targetMax).toInt)),
      valued("--segment-threshold")((o, v) => segment(o, Some(whole("--segment-threshold", v, 0, 255).toInt))),
      flag("--no-segment-test")(o => segment(o, None)),
      valued("--config")((o, v) => o.copy(configName = CommandLine.preset(v))),
      flag("--wave")(_.copy(wave = true)),
      valued("--wave-rows")((o, v) => o.copy(waveRows = whole("--wave-rows", v, 1, 2047).toInt)),
      valued("--trace") { (o, v) =>
        v.split(",").toSeq.map(_.trim.toIntOption) match {
          case Seq(Some(x), Some(y)) if x >= 0 && y >= 0 => o.copy(trace = Some((x, y)))
          case _ => fail(s"--trace takes X,Y (two non-negative whole numbers), not '$v'")
        }
      },
      valued("--seed")((o, v) => o.copy(seed = whole("--seed", v, Long.MinValue, Long.MaxValue)))
    )
  }

  /** Throws `CommandLine.UsageError`. */
  def parse(args: Seq[String]): Options = {
    val o = CommandLine.parse(args, Options(), options)
    if (o.key == null || o.live == null || o.out == null) fail("--key, --live and --out are required (see --help)")
    if (o.wave && o.engine != "rtl") fail("--wave needs --engine rtl")
    if (o.segment.exists(_.isDefined) && o.config.harris.segment.isEmpty)
      fail(s"--config ${o.configName} has no segment test")
    o
  }

  /** Loads an image and checks it against the configuration's limits. */
  def loadImage(path: String, flag: String, cfg: OrbConfig): GrayImage = {
    val img =
      try GrayImage.load(path)
      catch { case e: IllegalArgumentException => fail(s"$flag: ${e.getMessage}") }
    val (maxW, maxH) = (cfg.frame.maxWidth, cfg.frame.maxHeight)
    if (img.width > maxW || img.height > maxH)
      fail(s"$flag $path is ${img.width}x${img.height}; this configuration takes at most ${maxW}x$maxH (see --config)")
    val minSide = 2 * cfg.harris.border + 1
    if (img.width < minSide || img.height < minSide)
      fail(
        s"$flag $path is ${img.width}x${img.height}; features need at least ${minSide}x$minSide (a ${cfg.harris.border}-px border)"
      )
    img
  }

  /** What either engine produced. */
  final case class Outcome(
      featureStream: Seq[Either[FrameEnd, Feature]],
      correspondences: Seq[Correspondence],
      counters: Seq[(String, Long)],
      cycles: Option[Long],
      pixels: Long,
      rtl: Option[TopResult]
  )

  def runModel(o: Options, beats: Seq[Beat]): Outcome = {
    val r = SystemModel.run(o.config, beats, o.corners, o.params)
    val c = r.core
    val counters = RegisterMap.counters.map(reg => reg.key -> reg.model.get(r))
    Outcome(c.featureStream, r.lastLive, counters, None, beats.size.toLong, None)
  }

  def runRtl(o: Options, beats: Seq[Beat], live: GrayImage, dir: File): Outcome = {
    if (!hasVerilator) fail("--engine rtl needs Verilator 5 on the PATH (apt-get install verilator)")
    val cfg = o.config
    val workspace = s"simWorkspace/match-${o.configName}${if (o.wave) "-wave" else ""}"
    System.err.println(s"$app: compiling the Verilator model of OrbTop in $workspace (a few minutes)")
    val compiled = TopSim.compile(cfg, workspace, wave = o.wave)
    var result: TopResult = null
    val total = beats.size
    val liveStart = beats.lastIndexWhere(_.sof)
    // The waveform covers rows [first, last) of the live frame.
    val (firstRow, lastRow) = o.trace match {
      case Some((_, ty)) => ((ty - o.waveRows / 2) max 0, (ty - o.waveRows / 2 max 0) + o.waveRows)
      case None => (0, o.waveRows)
    }
    // Correspondences before this beat belong to the frames before the last: its first corner cannot be described
    // before row border + 22, and the frame before has been matched and swept by then (OrbConfig.budgetService).
    val lastFrameFrom = (liveStart + (cfg.harris.border + OrbDescriptorConfig.startRowOffset) * live.width) min total
    var before = 0
    val waveFrom = (liveStart + firstRow * live.width) min total
    val waveTo = (liveStart + lastRow * live.width) min total
    val started = System.nanoTime()
    compiled.doSim("match", o.seed.toInt) { dut =>
      if (o.wave) disableSimWave()
      val rng = new Random(o.seed)
      val (bus, monitor) = TopSim.start(dut, o.corners, o.params, 1.0, rng)
      // Beats in parts: the waveform is switched on for [waveFrom, waveTo) only; progress between parts.
      val cuts =
        (Seq(0, total, lastFrameFrom) ++ (if (o.wave) Seq(waveFrom, waveTo) else Nil) ++ (0 until total by (1 << 16)))
          .filter(c => c >= 0 && c <= total).distinct.sorted
      var lastReport = System.nanoTime()
      for (Seq(from, to) <- cuts.sliding(2)) {
        if (from == lastFrameFrom) before = monitor.correspondences.size
        if (o.wave && from == waveFrom) enableSimWave()
        if (o.wave && from == waveTo) disableSimWave()
        CoreSim.drivePixels(dut.io.pixels, dut.clockDomain, beats.slice(from, to), Blanking.camera, rng)
        if (System.nanoTime() - lastReport > 3e9) {
          lastReport = System.nanoTime()
          System.err.println(
            f"$app: rtl ${100.0 * to / total}%5.1f%% of ${total / 1000}k pixels, ${(lastReport - started) / 1e9}%.0f s"
          )
        }
      }
      if (o.wave && waveTo >= total) disableSimWave()
      TopSim.drain(dut, monitor, cfg)
      result = TopSim.result(dut, bus, monitor, total.toLong)
    }
    val counters = TopSim.registerNames.map { case (n, _) => n -> result.register(n) }
    if (o.wave) {
      val fst = new File(workspace, "OrbTop/match/wave.fst")
      if (fst.isFile) java.nio.file.Files.copy(
        fst.toPath,
        new File(dir, "wave.fst").toPath,
        java.nio.file.StandardCopyOption.REPLACE_EXISTING
      )
      Waves.writeGtkw(new File(dir, "wave.gtkw"), new File(dir, "wave.fst"), compiled.dut)
    }
    Outcome(
      result.featureStream,
      result.correspondences.drop(before),
      counters,
      Some(result.cycles),
      total.toLong,
      Some(result)
    )
  }

  /** The feature budget of the keyframe and of the live frame (the model's: the rtl engine equals it), and why no
    * corner can be dropped for lack of time. */
  def budgetSummary(o: Options, key: GrayImage, live: GrayImage): Json.Obj = {
    val cfg = o.config
    val core = CoreModel.run(cfg, SystemModel.pairBeats(key, live), o.corners)
    val processed = core.budget
    def frame(i: Int): Json.Obj = processed.lift(i).fold(Json.obj()) { case (cut, sel) =>
      Json.obj(
        "cut_level" -> (if (cut.history) Some(cut.level) else None),
        "cut_remainder" -> (if (cut.history) Some(cut.remainder) else None),
        "selected" -> sel.selected.size,
        "deselected" -> sel.deselected
      )
    }
    // the processed frames: key (cut), keyframe, live (cut), live; with another live size two more frames are not processed
    Json.obj(
      "target" -> o.features,
      "cell" -> s"${cfg.budget.cellWidth}x${cfg.budget.cellHeight}",
      "per_cell" -> Json.obj("key" -> cfg.perCellFor(key.width), "live" -> cfg.perCellFor(live.width)),
      "keyframe" -> frame(1),
      "live" -> frame(processed.size - 1),
      "timing_drops" -> ("none possible: the budget bounds what reaches the engines and the matcher (OrbConfig.budgetService); " +
        "only a correspondence consumer that stalls could cost features, and this run's takes every one")
    )
  }

  def hasVerilator: Boolean =
    try { new ProcessBuilder("verilator", "--version").redirectErrorStream(true).start().waitFor() == 0 }
    catch { case _: Exception => false }

  // ---- outputs ----

  def writeCorrespondences(f: File, cs: Seq[Correspondence]): Unit = Csv.correspondences(f, cs)

  def writeFeatures(f: File, fs: Seq[Feature], cfg: OrbConfig): Unit = write(f) { w =>
    w.println("x,y,angle_deg,score,descriptor")
    fs.foreach(ft =>
      w.println(f"${ft.x},${ft.y},${OrbModel.binDegrees(ft.bin, cfg.descriptor)}%.4f,${ft.score},${ft.hex}")
    )
  }

  def write(f: File)(body: PrintWriter => Unit): Unit = Csv.write(f)(body)

  /** Keyframe left, live right, one line per correspondence: green within 3 px of the homography's prediction,
    * red beyond; yellow without ground truth. */
  def drawMatches(key: GrayImage, live: GrayImage, cs: Seq[Correspondence], h: Option[Array[Double]]): BufferedImage = {
    val gap = 8
    val out = new BufferedImage(key.width + gap + live.width, key.height max live.height, BufferedImage.TYPE_INT_RGB)
    val g = out.createGraphics()
    g.setColor(Color.BLACK); g.fillRect(0, 0, out.getWidth, out.getHeight)
    g.drawImage(key.toBufferedImage, 0, 0, null)
    g.drawImage(live.toBufferedImage, key.width + gap, 0, null)
    g.setRenderingHint(RenderingHints.KEY_ANTIALIASING, RenderingHints.VALUE_ANTIALIAS_ON)
    g.setStroke(new BasicStroke(1.2f))
    // Outliers first, so that the inliers stay visible on top.
    val ordered = h.fold(cs)(m => cs.sortBy(c => -Homography.error(m, c)))
    for (c <- ordered) {
      g.setColor(h match {
        case Some(m) => if (Homography.error(m, c) <= 3) new Color(0, 220, 0) else new Color(230, 30, 30)
        case None => new Color(255, 220, 0)
      })
      g.drawLine(c.keyX, c.keyY, key.width + gap + c.liveX, c.liveY)
      g.drawOval(c.keyX - 2, c.keyY - 2, 4, 4); g.drawOval(key.width + gap + c.liveX - 2, c.liveY - 2, 4, 4)
    }
    g.dispose()
    out
  }

  /** Exit status: 0 done, 2 bad arguments or input files (one line on `err`), 1 an I/O error while writing. */
  def run(args: Seq[String], err: java.io.PrintStream = System.err): Int = {
    val o =
      try parse(args)
      catch { case e: CommandLine.UsageError => err.println(s"$app: ${e.getMessage}"); return 2 }
    try { execute(o); 0 }
    catch {
      case e: CommandLine.UsageError => err.println(s"$app: ${e.getMessage}"); 2
      case e: java.io.IOException => err.println(s"$app: ${e.getMessage}"); 1
    }
  }

  def execute(o: Options): Unit = {
    val cfg = o.config
    val key = loadImage(o.key, "--key", cfg)
    val live = loadImage(o.live, "--live", cfg)
    val h = o.homography.map(p =>
      try Homography.load(p)
      catch { case e: Exception => fail(s"--homography: ${e.getMessage}") }
    )
    val dir = new File(o.out)
    dir.mkdirs()
    if (!dir.isDirectory) fail(s"--out: cannot create the directory $dir")
    val beats = SystemModel.pairBeats(key, live)
    val started = System.nanoTime()
    val outcome = if (o.engine == "model") runModel(o, beats) else runRtl(o, beats, live, dir)
    val wall = (System.nanoTime() - started) / 1e9
    val run = MatcherModel.run(outcome.featureStream, o.params, cfg.matcher) // to split features by frame
    val (keyFeatures, liveFeatures) = SystemModel.keyAndLive(run)
    writeCorrespondences(new File(dir, "correspondences.csv"), outcome.correspondences)
    writeFeatures(new File(dir, "key_features.csv"), keyFeatures, cfg)
    writeFeatures(new File(dir, "live_features.csv"), liveFeatures, cfg)
    ImageIO.write(drawMatches(key, live, outcome.correspondences, h), "png", new File(dir, "matches.png"))
    val inliers = h.map(m => Homography.quality(outcome.correspondences, m))
    val summary = Json.obj(
      "engine" -> o.engine,
      "config" -> o.configName,
      "key" -> Json.obj("path" -> o.key, "width" -> key.width, "height" -> key.height, "features" -> keyFeatures.size),
      "live" -> Json.obj(
        "path" -> o.live,
        "width" -> live.width,
        "height" -> live.height,
        "features" -> liveFeatures.size
      ),
      "params" -> Json.obj(
        "features" -> o.features,
        "harris_threshold" -> o.threshold,
        "segment_threshold" -> o.corners.segmentThreshold,
        "hamming" -> o.params.hammingThreshold,
        "ratio" -> o.params.ratio.map(r => r.toDouble / (1 << cfg.matcher.ratioFracBits)),
        "cross_check" -> o.params.crossCheck
      ),
      // The stream sent (SystemModel.pairBeats): the counters count every frame of it; the correspondences are the
      // last frame's.
      "stream" -> SystemModel.pairDescription(key, live),
      "budget" -> budgetSummary(o, key, live),
      "counters" -> Json.Obj(outcome.counters),
      "correspondences" -> outcome.correspondences.size,
      "cycles" -> outcome.cycles,
      "pixels" -> outcome.pixels,
      "pixels_per_clock" -> outcome.cycles.map(c => outcome.pixels.toDouble / c),
      "wall_seconds" -> wall,
      "inliers_3px" -> inliers.map(_.inliers3),
      "inliers_8px" -> inliers.map(_.inliers8)
    )
    write(new File(dir, "summary.json"))(_.println(Json.render(summary)))
    for (t <- o.trace) {
      val text = Trace.report(t, cfg, key, live, o, run, outcome.rtl)
      write(new File(dir, "trace.txt"))(_.print(text))
      println(text)
    }
    println(
      f"$app: ${o.engine}: ${keyFeatures.size} keyframe features, ${liveFeatures.size} live features, " +
        f"${outcome.correspondences.size} correspondences" + inliers.fold("")(q =>
          f", ${q.inliers3 * 100}%.1f%% within 3 px"
        ) +
        f" ($wall%.1f s); wrote ${dir.getPath}/{correspondences.csv,key_features.csv,live_features.csv,summary.json,matches.png}"
    )
  }

  def main(args: Array[String]): Unit = {
    if (args.contains("--help")) { println(usage); return }
    val status = run(args.toSeq)
    if (status != 0) sys.exit(status)
  }
}

/** Ground truth: a 3x3 homography from keyframe to live coordinates. */
object Homography {
  final case class Quality(matches: Int, inliers3: Double, inliers8: Double)

  def load(path: String): Array[Double] = {
    val f = new File(path)
    if (!f.isFile) throw new IllegalArgumentException(s"no such file: $path")
    val v = scala.io.Source.fromFile(f).getLines().flatMap(_.trim.split("\\s+")).filter(_.nonEmpty)
      .map(s => s.toDoubleOption.getOrElse(throw new IllegalArgumentException(s"$path: '$s' is not a number"))).toArray
    if (v.length != 9) throw new IllegalArgumentException(s"$path: a homography has 9 numbers, found ${v.length}")
    v
  }
  def project(h: Array[Double], x: Double, y: Double): (Double, Double) = {
    val w = h(6) * x + h(7) * y + h(8)
    ((h(0) * x + h(1) * y + h(2)) / w, (h(3) * x + h(4) * y + h(5)) / w)
  }
  def error(h: Array[Double], kx: Double, ky: Double, lx: Double, ly: Double): Double = {
    val (px, py) = project(h, kx, ky); math.hypot(px - lx, py - ly)
  }
  def error(h: Array[Double], c: Correspondence): Double = error(h, c.keyX, c.keyY, c.liveX, c.liveY)
  def quality(cs: Seq[Correspondence], h: Array[Double]): Quality = qualityOf(cs.map(c => error(h, c)))
  def qualityOf(errors: Seq[Double]): Quality = {
    def frac(t: Double) = if (errors.isEmpty) 0.0 else errors.count(_ <= t).toDouble / errors.size
    Quality(errors.size, frac(3), frac(8))
  }
}
