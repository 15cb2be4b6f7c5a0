package orb

import spinal.core._

import java.io.{File, PrintWriter}
import scala.collection.mutable
import scala.sys.process._

/** `runMain orb.Report --out DIR [--config NAME] [--no-timing] [--block-timing] [--seeds N] [--calibrate]
  * [--timing-minutes N] [--placer static|heap]`: what the core costs on the Cyclone II EP2C70, and how fast it routes on the proxy.
  *
  *  - memories: every RAM/ROM of the design, depth x width, mapped to the best M4K shape (from the design itself);
  *  - logic: the Verilog through Yosys with generic cells (`resources/orb/report/flow.ys`): 4-input LUTs, one
  *    carry-chain logic element per adder/comparator bit, flip-flops, multipliers as 18x18 blocks; per block; logic
  *    elements as two bounds (flip-flops packed with any LUT, or only with the LUT that feeds them);
  *  - timing proxy (unless --no-timing): `Ecp5Proxy`, routed Fmax over seeds on a Lattice ECP5 LFE5U-85F.
  * Writes DIR/report.json and DIR/report.md. */
object Report {
  import ResourceCount._
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
       |  --timing-minutes N   a seed whose routing has not finished after N minutes is unroutable (default 30)
       |  --placer NAME        nextpnr's placer: ${Ecp5Proxy.placers.mkString(" or ")} (default ${Ecp5Proxy.placers
        .head})""".stripMargin

  /** The EP2C70 (DE2-70). */
  object Device { val name = "EP2C70F896C6"; val les = 68416; val m4k = 250; val multipliers = 150 }

  final case class Options(
      out: String = "report",
      configName: String = "default",
      timing: Boolean = true,
      blockTiming: Boolean = false,
      seeds: Int = 3,
      calibrate: Boolean = false,
      minutes: Int = 30,
      only: Seq[String] = Nil,
      placer: String = Ecp5Proxy.placers.head
  )

  /** the blocks as report.json names them */
  val blockNames: Seq[String] = Seq(
    "core.tracker",
    "core.lines",
    "core.harris",
    "core.budget",
    "core.smoother",
    "core.orientation",
    "core.descriptors",
    "matcher"
  )

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
      valued("--timing-minutes")((o, v) => o.copy(minutes = CommandLine.positive("--timing-minutes", v))),
      valued("--placer") { (o, v) =>
        if (!Ecp5Proxy.placers.contains(v))
          CommandLine.fail(s"unknown --placer '$v' (known: ${Ecp5Proxy.placers.mkString(", ")})")
        o.copy(placer = v)
      }
    )
  }

  def parse(args: Seq[String]): Either[String, Options] =
    CommandLine.attempt(CommandLine.parse(args, Options(), options))

  // ---- output ----

  def write(f: File, text: String): Unit = {
    val w = new PrintWriter(f);
    try w.print(text)
    finally w.close()
  }
  def pct(v: Double, of: Double): Double = 100.0 * v / of

  def timingJson(t: Ecp5Proxy.Timing): Json.Obj = Json.obj(
    "module" -> t.module,
    "fmax_mhz" -> t.medianMhz,
    "fmax_min_mhz" -> t.minMhz,
    "routed" -> t.routed,
    "seeds" -> t.runs.map(r =>
      Json.obj(
        "seed" -> r.seed,
        "fmax_mhz" -> r.fmaxMhz,
        "outcome" -> r.outcome,
        "seconds" -> r.seconds.round,
        "failing" -> r.failing.headOption
      )
    ),
    "packed" -> t.packed,
    "critical_path" -> t.critical.flatMap(_.path).map(p =>
      Json.obj(
        "from" -> p.from,
        "to" -> p.to,
        "delay_ns" -> p.delayNs,
        "logic_ns" -> p.logicNs,
        "routing_ns" -> p.routingNs,
        "levels" -> p.levels,
        "max_fanout" -> p.maxFanout,
        "max_fanout_net" -> p.maxFanoutNet,
        "rtl_lines" -> p.rtlLines
      )
    ),
    "seconds" -> t.seconds.round
  )

  def timingLine(t: Ecp5Proxy.Timing, goal: Double): String = {
    val seeds =
      t.runs
        .map(r =>
          r.fmaxMhz.fold(s"seed ${r.seed} ${r.outcome}")(f =>
            f"seed ${r.seed} $f%.1f" + (if (r.outcome.contains("in place of")) s" (${r.outcome})" else "")
          )
        )
        .mkString("; ")
    val head = (t.medianMhz, t.minMhz) match {
      case (Some(m), Some(lo)) =>
        f"**$m%.1f MHz** median, $lo%.1f minimum (goal $goal%.0f: ${if (m >= goal) "met" else "not met"})"
      case _ => "**unroutable**"
    }
    val path = t.critical.flatMap(_.path).fold("") { p =>
      f"; critical path `${p.from}` -> `${p.to}`: ${p.delayNs}%.2f ns (${p.logicNs}%.2f logic, ${p.routingNs}%.2f routing), " +
        s"${p.levels} logic levels, largest fan-out ${p.maxFanout} (`${p.maxFanoutNet}`)" +
        (if (p.rtlLines.isEmpty) "" else s"; RTL ${p.rtlLines.take(6).map("`" + _ + "`").mkString(", ")}")
    }
    val failing =
      t.critical.flatMap(_.failing.headOption).fold("")(f => s"; $f (every one: `ecp5/${t.module}/slack_seedN.txt`)")
    s"$head ($seeds; packed: ${t.packed})$path$failing"
  }

  /** The calibration designs through the proxy, unpacked then packed. */
  def calibration(dir: File, o: Options, seeds: Seq[Int]): Seq[(String, Ecp5Proxy.Timing, Ecp5Proxy.Timing)] = {
    val probes = new File(dir, "probes")
    probes.mkdirs()
    Seq[(String, () => Component)](
      "one RAM" -> (() => new Ecp5Proxy.RamProbe),
      "one multiplier" -> (() => new Ecp5Proxy.MulProbe)
    ).map {
      case (what, make) =>
        val r = Generate.spinalConfig(probes.getPath).generate(make())
        val v = new File(probes, s"${r.toplevelName}.v")
        (
          what,
          Ecp5Proxy.timing(dir, v, r.toplevelName, seeds, o.minutes, blockGoalMhz, o.placer, pack = false),
          Ecp5Proxy.timing(dir, v, r.toplevelName, seeds, o.minutes, blockGoalMhz, o.placer)
        )
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
    val instances: Seq[(String, Component)] = blockNames.zip(Seq(
      top.core.tracker,
      top.core.lines,
      top.core.harris,
      top.core.budget,
      top.core.smoother,
      top.core.orientation,
      top.core.descriptors,
      top.matcher
    ))
    val mems = memories(top, instances)
    println(s"$app: ${mems.size} memories, ${mems.map(_.m4k).sum} M4K; Yosys generic synthesis (a few minutes)")
    val (statText, alone) = runYosys(dir, verilog, report.toplevelName)
    val stat = withAlone(parseStat(statText), alone)
    // Blocks: the core's stages and the matcher, as instances, each counted in a Yosys run of its own (so that it
    // moves only with its own RTL); the rest (registers, glue) is "top", from the whole design's run.
    val glue =
      instances.map { case (_, c) => total(c.definitionName, stat) }.foldLeft(total(report.toplevelName, stat))(
        _ - _
      )
    val blockCells = instances.map { case (n, c) => n -> moduleCells(dir, verilog, c.definitionName, s"yosys/$n") }
    val all = blockCells.map(_._2).foldLeft(glue)(_ + _)
    val blocks = blockCells :+ ("top" -> glue)
    def m4kOf(b: String) = mems.filter(_.block == b).map(_.m4k).sum
    val seeds = 1 to o.seeds
    def wanted(n: String) = if (o.only.nonEmpty) o.only.contains(n) else n == "core" || o.blockTiming
    val coreTime = if (o.timing && wanted("core"))
      Some(Ecp5Proxy.timing(dir, verilog, report.toplevelName, seeds, o.minutes, coreGoalMhz, o.placer))
    else None
    val blockTimes = if (o.timing) instances.collect {
      case (n, c) if wanted(n) =>
        n -> Ecp5Proxy.timing(dir, verilog, c.definitionName, seeds, o.minutes, blockGoalMhz, o.placer)
    }.toMap
    else Map.empty[String, Ecp5Proxy.Timing]
    val calibrated = if (o.timing && o.calibrate) calibration(dir, o, seeds) else Nil
    val m4k = mems.map(_.m4k).sum
    def percent(c: Cells) = Json.obj(
      "les" -> pct(c.les.toDouble, Device.les),
      "les_low" -> pct(c.lesLow.toDouble, Device.les),
      "m4k" -> pct(m4k.toDouble, Device.m4k),
      "multipliers" -> pct(c.mul18, Device.multipliers)
    )
    def cellFields(c: Cells, mk: Int) = Seq(
      "les" -> c.les,
      "les_low" -> c.lesLow,
      "luts" -> c.luts,
      "carry_les" -> c.carry,
      "ffs" -> c.ffs,
      "ffs_alone" -> c.ffsAlone,
      "m4k" -> mk,
      "multipliers" -> c.mul18
    )
    def fmaxFields(t: Option[Ecp5Proxy.Timing]) =
      Seq("fmax_mhz" -> t.flatMap(_.medianMhz), "fmax_min_mhz" -> t.flatMap(_.minMhz), "fmax_routed" -> t.map(_.routed))
    val tDesc = DescriptorUnit.maxClocks(cfg.descriptor)
    val json = Json.obj(Seq[(String, Any)](
      "config" -> o.configName,
      "device" -> Device.name,
      "max_width" -> cfg.maxWidth
    ) ++
      cellFields(all, m4k) ++ fmaxFields(coreTime) ++ Seq(
        "pixels_per_clock" -> 1,
        "percent" -> percent(all),
        "blocks" -> Json.Obj(blocks.map { case (n, c) =>
          n -> Json.Obj(cellFields(c, m4kOf(n)) ++ fmaxFields(blockTimes.get(n)) :+ ("pixels_per_clock" -> 1))
        }),
        "memories" -> mems.map(m =>
          Json.obj(
            "block" -> m.block,
            "name" -> m.name,
            "depth" -> m.depth,
            "width" -> m.width,
            "rom" -> m.rom,
            "m4k" -> m.m4k,
            "shape" -> s"${m.shape._1}x${m.shape._2}"
          )
        ),
        "budget" -> Json.obj(
          "cell" -> s"${cfg.budget.cellWidth}x${cfg.budget.cellHeight}",
          "per_cell" -> cfg.budget.perCell,
          "per_cell_from_width" -> Json.Obj(cfg.perCellSteps.map { case (w, k) => w.toString -> k }),
          "descriptor_clocks_max" -> tDesc,
          "matcher_clocks_per_feature" -> cfg.matcher.clocksPerFeature,
          "clocks_per_feature" -> cfg.clocksPerFeature,
          "per_band_max" -> cfg.budgetPerBand
        ),
        "timing" -> (if (!o.timing) None
                     else Some(Json.obj(
                       "proxy" -> s"${Ecp5Proxy.device(o.placer)}: for comparing variants, not Cyclone II timing",
                       "seeds" -> seeds,
                       "core_goal_mhz" -> coreGoalMhz,
                       "block_goal_mhz" -> blockGoalMhz,
                       "core" -> coreTime.map(timingJson),
                       "blocks" -> Json.Obj(instances.flatMap { case (n, _) =>
                         blockTimes.get(n).map(t => n -> timingJson(t))
                       }),
                       "calibration" -> calibrated.map { case (what, raw, packed) =>
                         Json.obj("design" -> what, "unpacked" -> timingJson(raw), "packed" -> timingJson(packed))
                       }
                     )))
      ): _*)
    write(new File(dir, "report.json"), Json.render(json) + "\n")

    def num(d: Double) = Json.number(d)
    val md = new StringBuilder
    md ++= s"# Resource report: OrbTop, config ${o.configName} (maxWidth ${cfg.maxWidth}), target ${Device.name}\n\n"
    val flags = (if (o.timing) "" else " --no-timing") + (if (o.timing && o.blockTiming) " --block-timing" else "") +
      (if (o.timing && o.only.nonEmpty) s" --only ${o.only.mkString(",")}" else "") +
      (if (o.timing && o.calibrate) " --calibrate" else "") + (if (o.timing)
                                                                 s" --seeds ${o.seeds} --timing-minutes ${o.minutes}"
                                                               else "")
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
    md ++= (if (!o.timing) "Not run (--no-timing).\n"
            else {
              s"${Ecp5Proxy.device(o.placer)}; seeds ${seeds.mkString(", ")}; a proxy for comparing variants, not Cyclone II timing.\n\n" +
                coreTime.fold("")(c => s"* whole core: ${timingLine(c, coreGoalMhz)}\n") +
                instances.flatMap { case (n, _) =>
                  blockTimes.get(n).map(t => s"* $n alone: ${timingLine(t, blockGoalMhz)}\n")
                }.mkString +
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
        try run(o)
        catch { case e: RuntimeException => System.err.println(s"$app: ${e.getMessage}"); sys.exit(1) }
    }
  }
}
