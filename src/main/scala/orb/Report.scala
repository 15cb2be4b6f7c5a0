package orb

import spinal.core._

import java.io.{File, PrintWriter}
import scala.collection.mutable
import scala.sys.process._

/** `runMain orb.Report --out DIR [--config NAME] [--no-timing] [--block-timing] [--seeds N] [--calibrate]
  * [--timing-minutes N]`: what the core costs on the Cyclone II EP2C70, and how fast it routes on the proxy.
  *
  *  - memories: every RAM/ROM of the design, depth x width, mapped to the best M4K shape (from the design itself);
  *  - logic: the Verilog through Yosys with generic cells (`resources/orb/report/flow.ys`): 4-input LUTs, one
  *    carry-chain logic element per adder/comparator bit, flip-flops, multipliers as 18x18 blocks; per block; logic
  *    elements as two bounds (flip-flops packed with any LUT, or only with the LUT that feeds them);
  *  - timing proxy (unless --no-timing): `Ecp5Proxy`, routed Fmax over seeds on a Lattice ECP5 LFE5U-85F.
  * Writes DIR/report.json and DIR/report.md. */
object Report {
  val app = "orb.Report"
  /** the issue's goals: the whole core, and every block alone (so that the core can reach its own) */
  val coreGoalMhz = 150.0
  val blockGoalMhz = 165.0
  val usage: String =
    s"""usage: $app --out DIR [--config NAME] [--no-timing] [--block-timing] [--seeds N] [--calibrate] [--timing-minutes N]
       |  --out DIR            where to write report.json, report.md and the work files (default: report)
       |  --config NAME        preset: ${OrbConfig.presets.keys.toSeq.sorted.mkString(", ")} (default: default)
       |  --no-timing          skip the ECP5 place and route (which takes tens of minutes)
       |  --block-timing       also place and route every block alone, in its own wrapper
       |  --seeds N            place and route N times with seeds 1..N; the median and the minimum are reported
       |                       (default 3)
       |  --calibrate          also time a one-RAM and a one-multiplier design with and without register packing
       |  --only NAMES         time only these (comma-separated: core, or block names as in report.json, e.g.
       |                       core.harris,matcher)
       |  --timing-minutes N   a seed whose routing has not finished after N minutes is unroutable (default 30)""".stripMargin

  /** The EP2C70 (DE2-70). */
  object Device { val name = "EP2C70F896C6"; val les = 68416; val m4k = 250; val multipliers = 150 }

  final case class Options(out: String = "report", configName: String = "default", timing: Boolean = true,
                           blockTiming: Boolean = false, seeds: Int = 3, calibrate: Boolean = false, minutes: Int = 30,
                           only: Seq[String] = Nil)

  /** the blocks as report.json names them */
  val blockNames: Seq[String] = Seq("core.tracker", "core.lines", "core.harris", "core.budget", "core.smoother",
    "core.orientation", "core.descriptors", "matcher")

  private val options: Seq[CommandLine.Opt[Options]] = {
    import CommandLine.{flag, valued}
    Seq(
      valued("--out")((o, v) => o.copy(out = v)),
      valued("--config")((o, v) => o.copy(configName = CommandLine.preset(v))),
      flag("--no-timing")(_.copy(timing = false)),
      flag("--block-timing")(_.copy(blockTiming = true)),
      flag("--calibrate")(_.copy(calibrate = true)),
      valued("--only") { (o, v) =>
        val known = "core" +: blockNames
        val names = v.split(",").map(_.trim).toSeq
        for (bad <- names.find(!known.contains(_)))
          CommandLine.fail(s"unknown --only name '$bad' (known: ${known.mkString(", ")})")
        o.copy(only = names)
      },
      valued("--seeds")((o, v) => o.copy(seeds = CommandLine.positive("--seeds", v))),
      valued("--timing-minutes")((o, v) => o.copy(minutes = CommandLine.positive("--timing-minutes", v))))
  }

  def parse(args: Seq[String]): Either[String, Options] =
    CommandLine.attempt(CommandLine.parse(args, Options(), options))

  // ---- memories ----

  final case class Memory(block: String, name: String, depth: Int, width: Int, rom: Boolean) {
    /** the M4K shapes of Cyclone II (depth x width) */
    def shapes: Seq[(Int, Int)] = Seq(4096 -> 1, 2048 -> 2, 1024 -> 4, 512 -> 9, 256 -> 18, 128 -> 36)
    def blocksFor(s: (Int, Int)): Int = ((depth + s._1 - 1) / s._1) * ((width + s._2 - 1) / s._2)
    val (m4k, shape) = shapes.map(s => (blocksFor(s), s)).minBy(_._1)
    def bits: Long = depth.toLong * width
  }

  /** The block of a component: the first of `blocks` it is or lies in, else "top". */
  def blockOf(c: Component, blocks: Seq[(String, Component)]): String =
    blocks.find { case (_, b) => c == b || c.parents().contains(b) }.map(_._1).getOrElse("top")

  def memories(top: Component, blocks: Seq[(String, Component)]): Seq[Memory] = {
    val out = mutable.ArrayBuffer[Memory]()
    top.walkComponents { c =>
      c.dslBody.walkDeclarations {
        case m: Mem[_] => out += Memory(blockOf(c, blocks), s"${c.getPath().stripPrefix("toplevel/")}/${m.getName()}",
          m.wordCount, m.width, m.initialContent != null)
        case _ =>
      }
    }
    out.toSeq
  }

  // ---- logic with Yosys ----

  /** `ffsAlone`: flip-flops that no LUT or carry bit feeding them can host (see `netlist.py les`). */
  final case class Cells(luts: Long = 0, carry: Long = 0, ffs: Long = 0, mul18: Double = 0, ffsAlone: Long = 0) {
    def +(o: Cells): Cells = Cells(luts + o.luts, carry + o.carry, ffs + o.ffs, mul18 + o.mul18, ffsAlone + o.ffsAlone)
    def -(o: Cells): Cells = Cells(luts - o.luts, carry - o.carry, ffs - o.ffs, mul18 - o.mul18, ffsAlone - o.ffsAlone)
    def *(n: Long): Cells = Cells(luts * n, carry * n, ffs * n, mul18 * n, ffsAlone * n)
    /** logic elements if every flip-flop packed with some used LUT (optimistic: a lower bound) */
    def lesLow: Long = (luts + carry) max ffs
    /** logic elements if a flip-flop packs only with the LUT or carry bit that feeds it (the estimate the report uses;
      * Cyclone II can pack an unrelated register into a used LE, so Quartus may do a little better) */
    def les: Long = luts + carry + ffsAlone
  }

  /** Parses Yosys `stat` (per module): own cells, and instances of other modules. */
  def parseStat(text: String): Map[String, (Cells, Map[String, Long])] = {
    val modules = mutable.LinkedHashMap[String, (Cells, Map[String, Long])]()
    var current: String = null
    var cells = Cells(); var subs = Map.empty[String, Long]
    def flush(): Unit = if (current != null && current != "design hierarchy") modules(current) = (cells, subs)
    val header = "=== (.+) ===".r
    val cell = """\s+(\S+)\s+(\d+)""".r
    for (line <- text.linesIterator) line.trim match {
      case header(name) => flush(); current = name; cells = Cells(); subs = Map.empty
      case _ => line match {
        case cell(kind, n) if current != null =>
          val k = n.toLong
          if (kind == "$lut") cells = cells.copy(luts = cells.luts + k)
          else if (kind == "ORB_CARRY") cells = cells.copy(carry = cells.carry + k)
          else if (kind == "ORB_MUL18") cells = cells.copy(mul18 = cells.mul18 + k)
          else if (kind == "ORB_MUL9") cells = cells.copy(mul18 = cells.mul18 + 0.5 * k)
          else if (kind.startsWith("$_DFF") || kind.startsWith("$_SDFF") || kind.startsWith("$_DLATCH")) cells = cells.copy(ffs = cells.ffs + k)
          else if (!kind.startsWith("$")) subs = subs + (kind -> (subs.getOrElse(kind, 0L) + k))
        case _ =>
      }
    }
    flush()
    modules.toMap
  }

  /** A module's cells including its submodules. */
  def total(module: String, stat: Map[String, (Cells, Map[String, Long])]): Cells = stat.get(module) match {
    case None => Cells()
    case Some((own, subs)) => subs.foldLeft(own) { case (acc, (m, n)) => acc + total(m, stat) * n }
  }

  /** Adds each module's flip-flops that take a logic element of their own. */
  def withAlone(stat: Map[String, (Cells, Map[String, Long])], alone: Map[String, Long]): Map[String, (Cells, Map[String, Long])] =
    stat.map { case (m, (c, subs)) => m -> (c.copy(ffsAlone = alone.getOrElse(m, 0L)), subs) }

  def parseAlone(text: String): Map[String, Long] =
    text.linesIterator.map(_.trim.split(" ")).collect { case Array(m, n) if n.forall(_.isDigit) => m -> n.toLong }.toMap

  /** Yosys' `stat` text and the flip-flops alone per module. */
  def runYosys(dir: File, verilog: File, top: String): (String, Map[String, Long]) = {
    val work = new File(dir, "yosys"); work.mkdirs()
    for (f <- Seq("cells.v", "map_mul.v", "map_alu.v", "flow.ys", "netlist.py")) {
      val in = getClass.getResourceAsStream(s"/orb/report/$f")
      require(in != null, s"missing resource orb/report/$f")
      val text = scala.io.Source.fromInputStream(in).mkString.replace("TOP.v", verilog.getAbsolutePath).replace("-top TOP", s"-top $top")
      write(new File(work, f), text)
    }
    val log = new File(work, "yosys.log")
    val status = try Process(Seq("yosys", "-q", "-l", log.getName, "-s", "flow.ys"), work).!(ProcessLogger(_ => ()))
      catch { case _: java.io.IOException => throw new RuntimeException("yosys is not on the PATH (Debian: apt-get install yosys)") }
    if (status != 0) throw new RuntimeException(s"yosys failed (status $status); see ${log.getPath}")
    val alone = new StringBuilder
    val s2 = Process(Seq("python3", "netlist.py", "les", "generic.json"), work).!(ProcessLogger(l => alone ++= l + "\n", l => alone ++= l + "\n"))
    if (s2 != 0) throw new RuntimeException(s"netlist.py les failed (needs python3): $alone")
    (scala.io.Source.fromFile(new File(work, "stat.txt")).mkString, parseAlone(alone.toString))
  }

  // ---- output ----

  def write(f: File, text: String): Unit = { val w = new PrintWriter(f); try w.print(text) finally w.close() }
  def pct(v: Double, of: Double): Double = 100.0 * v / of

  def timingJson(t: Ecp5Proxy.Timing): Json.Obj = Json.obj(
    "module" -> t.module,
    "fmax_mhz" -> t.medianMhz,
    "fmax_min_mhz" -> t.minMhz,
    "routed" -> t.routed,
    "seeds" -> t.runs.map(r => Json.obj("seed" -> r.seed, "fmax_mhz" -> r.fmaxMhz, "outcome" -> r.outcome, "seconds" -> r.seconds.round,
      "failing" -> r.failing.headOption)),
    "packed" -> t.packed,
    "critical_path" -> t.critical.flatMap(_.path).map(p => Json.obj(
      "from" -> p.from, "to" -> p.to, "delay_ns" -> p.delayNs, "logic_ns" -> p.logicNs, "routing_ns" -> p.routingNs,
      "levels" -> p.levels, "max_fanout" -> p.maxFanout, "max_fanout_net" -> p.maxFanoutNet, "rtl_lines" -> p.rtlLines)),
    "seconds" -> t.seconds.round)

  def timingLine(t: Ecp5Proxy.Timing, goal: Double): String = {
    val seeds = t.runs.map(r => r.fmaxMhz.fold(s"seed ${r.seed} ${r.outcome}")(f => f"seed ${r.seed} $f%.1f")).mkString("; ")
    val head = (t.medianMhz, t.minMhz) match {
      case (Some(m), Some(lo)) => f"**$m%.1f MHz** median, $lo%.1f minimum (goal $goal%.0f: ${if (m >= goal) "met" else "not met"})"
      case _ => "**unroutable**"
    }
    val path = t.critical.flatMap(_.path).fold("") { p =>
      f"; critical path `${p.from}` -> `${p.to}`: ${p.delayNs}%.2f ns (${p.logicNs}%.2f logic, ${p.routingNs}%.2f routing), " +
        s"${p.levels} logic levels, largest fan-out ${p.maxFanout} (`${p.maxFanoutNet}`)" +
        (if (p.rtlLines.isEmpty) "" else s"; RTL ${p.rtlLines.take(6).map("`" + _ + "`").mkString(", ")}")
    }
    val failing = t.critical.flatMap(_.failing.headOption).fold("")(f => s"; $f (every one: `ecp5/${t.module}/slack_seedN.txt`)")
    s"$head ($seeds; packed: ${t.packed})$path$failing"
  }

  /** The calibration designs through the proxy, unpacked then packed. */
  def calibration(dir: File, o: Options, seeds: Seq[Int]): Seq[(String, Ecp5Proxy.Timing, Ecp5Proxy.Timing)] = {
    val probes = new File(dir, "probes")
    probes.mkdirs()
    Seq[(String, () => Component)]("one RAM" -> (() => new Ecp5Proxy.RamProbe), "one multiplier" -> (() => new Ecp5Proxy.MulProbe)).map {
      case (what, make) =>
        val r = Generate.spinalConfig(probes.getPath).generate(make())
        val v = new File(probes, s"${r.toplevelName}.v")
        (what, Ecp5Proxy.timing(dir, v, r.toplevelName, seeds, o.minutes, blockGoalMhz, pack = false),
          Ecp5Proxy.timing(dir, v, r.toplevelName, seeds, o.minutes, blockGoalMhz))
    }
  }

  def run(o: Options): Unit = {
    val cfg = OrbConfig.presets(o.configName)
    val dir = new File(o.out)
    dir.mkdirs()
    val rtl = new File(dir, "rtl")
    rtl.mkdirs()
    val report = Generate.spinalConfig(rtl.getPath).generate(new OrbTop(cfg))
    val top = report.toplevel
    val verilog = new File(rtl, s"${report.toplevelName}.v")
    val instances: Seq[(String, Component)] = blockNames.zip(Seq(top.core.tracker, top.core.lines, top.core.harris,
      top.core.budget, top.core.smoother, top.core.orientation, top.core.descriptors, top.matcher))
    val mems = memories(top, instances)
    println(s"$app: ${mems.size} memories, ${mems.map(_.m4k).sum} M4K; Yosys generic synthesis (a few minutes)")
    val (statText, alone) = runYosys(dir, verilog, report.toplevelName)
    val stat = withAlone(parseStat(statText), alone)
    // Blocks: the core's stages and the matcher, as instances; the rest (registers, glue) is "top".
    val blockCells = instances.map { case (n, c) => n -> total(c.definitionName, stat) }
    val all = total(report.toplevelName, stat)
    val glue = blockCells.map(_._2).foldLeft(all)(_ - _)
    val blocks = blockCells :+ ("top" -> glue)
    def m4kOf(b: String) = mems.filter(_.block == b).map(_.m4k).sum
    val seeds = 1 to o.seeds
    def wanted(n: String) = if (o.only.nonEmpty) o.only.contains(n) else n == "core" || o.blockTiming
    val coreTime = if (o.timing && wanted("core")) Some(Ecp5Proxy.timing(dir, verilog, report.toplevelName, seeds, o.minutes, coreGoalMhz)) else None
    val blockTimes = if (o.timing) instances.collect { case (n, c) if wanted(n) =>
      n -> Ecp5Proxy.timing(dir, verilog, c.definitionName, seeds, o.minutes, blockGoalMhz)
    }.toMap else Map.empty[String, Ecp5Proxy.Timing]
    val calibrated = if (o.timing && o.calibrate) calibration(dir, o, seeds) else Nil
    val m4k = mems.map(_.m4k).sum
    def percent(c: Cells) = Json.obj(
      "les" -> pct(c.les.toDouble, Device.les), "les_low" -> pct(c.lesLow.toDouble, Device.les),
      "m4k" -> pct(m4k.toDouble, Device.m4k), "multipliers" -> pct(c.mul18, Device.multipliers))
    def cellFields(c: Cells, mk: Int) = Seq("les" -> c.les, "les_low" -> c.lesLow, "luts" -> c.luts, "carry_les" -> c.carry,
      "ffs" -> c.ffs, "ffs_alone" -> c.ffsAlone, "m4k" -> mk, "multipliers" -> c.mul18)
    def fmaxFields(t: Option[Ecp5Proxy.Timing]) = Seq("fmax_mhz" -> t.flatMap(_.medianMhz), "fmax_min_mhz" -> t.flatMap(_.minMhz),
      "fmax_routed" -> t.map(_.routed))
    val tDesc = DescriptorUnit.maxClocks(cfg.descriptor)
    val json = Json.obj(Seq[(String, Any)](
      "config" -> o.configName, "device" -> Device.name, "max_width" -> cfg.maxWidth) ++
      cellFields(all, m4k) ++ fmaxFields(coreTime) ++ Seq(
      "pixels_per_clock" -> 1,
      "percent" -> percent(all),
      "blocks" -> Json.Obj(blocks.map { case (n, c) =>
        n -> Json.Obj(cellFields(c, m4kOf(n)) ++ fmaxFields(blockTimes.get(n)) :+ ("pixels_per_clock" -> 1))
      }),
      "memories" -> mems.map(m => Json.obj("block" -> m.block, "name" -> m.name, "depth" -> m.depth, "width" -> m.width,
        "rom" -> m.rom, "m4k" -> m.m4k, "shape" -> s"${m.shape._1}x${m.shape._2}")),
      "budget" -> Json.obj("cell" -> s"${cfg.budget.cellWidth}x${cfg.budget.cellHeight}", "per_cell" -> cfg.budget.perCell,
        "per_cell_from_width" -> Json.Obj(cfg.perCellSteps.map { case (w, k) => w.toString -> k }),
        "descriptor_clocks_max" -> tDesc, "matcher_clocks_per_feature" -> cfg.matcher.clocksPerFeature,
        "clocks_per_feature" -> cfg.clocksPerFeature, "per_band_max" -> cfg.budgetPerBand),
      "timing" -> (if (!o.timing) None else Some(Json.obj(
        "proxy" -> s"${Ecp5Proxy.device}: for comparing variants, not Cyclone II timing",
        "seeds" -> seeds, "core_goal_mhz" -> coreGoalMhz, "block_goal_mhz" -> blockGoalMhz,
        "core" -> coreTime.map(timingJson),
        "blocks" -> Json.Obj(instances.flatMap { case (n, _) => blockTimes.get(n).map(t => n -> timingJson(t)) }),
        "calibration" -> calibrated.map { case (what, raw, packed) =>
          Json.obj("design" -> what, "unpacked" -> timingJson(raw), "packed" -> timingJson(packed)) })))): _*)
    write(new File(dir, "report.json"), Json.render(json) + "\n")

    def num(d: Double) = Json.number(d)
    val md = new StringBuilder
    md ++= s"# Resource report: OrbTop, config ${o.configName} (maxWidth ${cfg.maxWidth}), target ${Device.name}\n\n"
    val flags = (if (o.timing) "" else " --no-timing") + (if (o.timing && o.blockTiming) " --block-timing" else "") +
      (if (o.timing && o.only.nonEmpty) s" --only ${o.only.mkString(",")}" else "") +
      (if (o.timing && o.calibrate) " --calibrate" else "") + (if (o.timing) s" --seeds ${o.seeds} --timing-minutes ${o.minutes}" else "")
    md ++= s"Produced by `./sbt \"runMain orb.Report --out ${o.out} --config ${o.configName}$flags\"`.\n\n"
    md ++= "| | LEs (est.) | LEs (low) | 4-LUTs | carry LEs | FFs | FFs alone | M4K | 18x18 mult. |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n"
    for ((n, c) <- blocks)
      md ++= s"| $n | ${c.les} | ${c.lesLow} | ${c.luts} | ${c.carry} | ${c.ffs} | ${c.ffsAlone} | ${m4kOf(n)} | ${num(c.mul18)} |\n"
    md ++= s"| **total** | **${all.les}** | ${all.lesLow} | ${all.luts} | ${all.carry} | ${all.ffs} | ${all.ffsAlone} | **$m4k** | **${num(all.mul18)}** |\n"
    md ++= f"| EP2C70 | ${Device.les} (${pct(all.les.toDouble, Device.les)}%.1f%%) | ${pct(all.lesLow.toDouble, Device.les)}%.1f%% | | | | | " +
      f"${Device.m4k} (${pct(m4k.toDouble, Device.m4k)}%.1f%%) | ${Device.multipliers} (${pct(all.mul18, Device.multipliers)}%.1f%%) |\n\n"
    md ++= "LEs (est.): one per LUT and per carry-chain bit, plus one per flip-flop that the LUT or carry bit feeding it " +
      "cannot host (fed by a flip-flop, a RAM, a port, or a second flip-flop of the same LUT). LEs (low): every " +
      "flip-flop packed into some used LE. Memories are not in the LUT counts.\n\n"
    md ++= "## Memories\n\n| block | memory | depth x width | kind | M4K | as |\n|---|---|---:|---|---:|---|\n"
    for (m <- mems.sortBy(m => (m.block, m.name)))
      md ++= s"| ${m.block} | ${m.name} | ${m.depth} x ${m.width} | ${if (m.rom) "ROM" else "RAM"} | ${m.m4k} | ${m.shape._1}x${m.shape._2} |\n"
    md ++= s"\n## Feature budget capacity\n\nCells of ${cfg.budget.cellWidth} x ${cfg.budget.cellHeight} px keep ${cfg.budget.perCell} corners " +
      s"(by line length: ${cfg.perCellSteps.map { case (w, k) => s"$k from $w px" }.mkString(", ")}); at most ${cfg.budgetPerBand} per band " +
      s"in ${cfg.maxWidth}-px lines. A descriptor takes at most $tDesc clocks of the engine, the matcher " +
      s"${cfg.matcher.clocksPerFeature} clocks per live feature: ${cfg.clocksPerFeature} clocks per feature in a busy stretch " +
      s"(`OrbConfig.budgetService` checks every line length).\n"
    md ++= "\n## Timing proxy\n\n"
    md ++= (if (!o.timing) "Not run (--no-timing).\n" else {
      s"${Ecp5Proxy.device}; seeds ${seeds.mkString(", ")}; a proxy for comparing variants, not Cyclone II timing.\n\n" +
        coreTime.fold("")(c => s"* whole core: ${timingLine(c, coreGoalMhz)}\n") +
        instances.flatMap { case (n, _) => blockTimes.get(n).map(t => s"* $n alone: ${timingLine(t, blockGoalMhz)}\n") }.mkString +
        calibrated.map { case (what, raw, packed) =>
          s"* calibration, $what: without packing ${timingLine(raw, blockGoalMhz)}; with packing ${timingLine(packed, blockGoalMhz)}\n"
        }.mkString
    })
    write(new File(dir, "report.md"), md.toString)
    println(f"$app: ${all.les} LEs (${pct(all.les.toDouble, Device.les)}%.1f%%; ${pct(all.lesLow.toDouble, Device.les)}%.1f%% packed optimistically), " +
      f"$m4k M4K (${pct(m4k.toDouble, Device.m4k)}%.1f%%), ${num(all.mul18)} multipliers (${pct(all.mul18, Device.multipliers)}%.1f%%)" +
      coreTime.fold("")(c => c.medianMhz.fold(", ECP5 proxy: unroutable")(m => f", ECP5 proxy $m%.1f MHz median")) +
      s"; wrote ${dir.getPath}/report.json and report.md")
  }

  def main(args: Array[String]): Unit = {
    if (args.contains("--help")) { println(usage); return }
    parse(args.toSeq) match {
      case Left(msg) => System.err.println(s"$app: $msg"); sys.exit(2)
      case Right(o) =>
        try run(o) catch { case e: RuntimeException => System.err.println(s"$app: ${e.getMessage}"); sys.exit(1) }
    }
  }
}
