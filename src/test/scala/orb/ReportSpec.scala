package orb

import org.scalatest.funsuite.AnyFunSuite
import spinal.core.Component

import java.io.File

/** `orb.Report --no-timing` on the default configuration: the files, the JSON keys, and figures that agree with
  * the design (Yosys reads and maps the whole core on the way); the timing proxy's wrapper and register packing on
  * its calibration designs (Debian's yosys; place and route stays out of the suite). */
class ReportSpec extends AnyFunSuite {
  test("command line: timing options, and clear errors") {
    assert(Report.parse(Seq("--out", "r", "--seeds", "5", "--only", "core.harris,matcher", "--calibrate")) ==
      Right(Report.Options(out = "r", seeds = 5, only = Seq("core.harris", "matcher"), calibrate = true)))
    assert(Report.parse(Seq("--only", "core.nothing")).left.exists(_.contains("unknown --only name 'core.nothing'")))
    assert(Report.parse(Seq("--seeds", "0")).left.exists(_.contains("positive whole number")))
    assert(Report.parse(Seq("--seeds")) == Left("--seeds needs a value"))
    assert(Report.parse(Seq("--fast")).left.exists(_.contains("unknown argument '--fast'")))
    assert(Report.parse(Seq("--placer", "heap")) == Right(Report.Options(placer = "heap")))
    assert(Report.Options().placer == "static")
    assert(Report.parse(Seq("--placer", "sa")).left.exists(_.contains("unknown --placer 'sa'")))
  }

  test("the proxy's wrapper synthesises, and plain registers move into the RAM and multiplier blocks") {
    val dir = new File("target/report-test/probes")
    for (
      (make, expected) <- Seq[(() => Component, String)](
        (
            () => new Ecp5Proxy.RamProbe
        ) -> "ram_ports=1 ram_ffs=16 mult_inputs=0 mult_constant_inputs=0 mult_outputs=0 mult_ffs=0 mult_constant_pins=0 inverted_enables=0 mult_resets_folded=0",
        // both operand registers and the product register (16 + 16 + 32 flip-flops)
        (
            () => new Ecp5Proxy.MulProbe
        ) -> "ram_ports=0 ram_ffs=0 mult_inputs=2 mult_constant_inputs=0 mult_outputs=1 mult_ffs=64 mult_constant_pins=5 inverted_enables=0 mult_resets_folded=0",
        // the variable operand's register and the product register; the constant operand registered with them
        (
            () => new Ecp5Proxy.ConstMulProbe
        ) -> "ram_ports=0 ram_ffs=0 mult_inputs=1 mult_constant_inputs=1 mult_outputs=1 mult_ffs=48 mult_constant_pins=5 inverted_enables=0 mult_resets_folded=0",
        // an operand register with a synchronous set/reset of its enable: folded into LUTs before the block's register
        (
            () => new Ecp5Proxy.ResetMulProbe
        ) -> "ram_ports=0 ram_ffs=0 mult_inputs=2 mult_constant_inputs=0 mult_outputs=1 mult_ffs=64 mult_constant_pins=5 inverted_enables=0 mult_resets_folded=16",
        // an operand register with no enable and a synchronous reset (a constant table's entries): folded alike
        (
            () => new Ecp5Proxy.TableMulProbe
        ) -> "ram_ports=0 ram_ffs=0 mult_inputs=2 mult_constant_inputs=0 mult_outputs=1 mult_ffs=64 mult_constant_pins=5 inverted_enables=0 mult_resets_folded=16"
      )
    ) {
      val r = Generate.spinalConfig(dir.getPath).generate(make())
      val work = new File(dir, r.toplevelName)
      Ecp5Proxy.synthesize(Seq("yosys"), work, new File(dir, s"${r.toplevelName}.v"), r.toplevelName)
      assert(Ecp5Proxy.packRegisters(work) == expected, r.toplevelName)
      val packed = scala.io.Source.fromFile(new File(work, "packed.json")).mkString
      if (r.toplevelName == "RamProbe")
        assert(packed.contains("\"REGMODE_B\": \"OUTREG\"") || packed.contains("\"REGMODE_A\": \"OUTREG\""))
      else assert(packed.contains("\"REG_OUTPUT_CLK\": \"CLK0\"") && packed.contains("\"REG_INPUTA_CLK\": \"CLK0\"") &&
        packed.contains("\"REG_INPUTB_CLK\": \"CLK0\""))
    }
    // The wrapper: every input from the ring, every output into the tree; no input pin.
    val ports = Seq(
      Ecp5Proxy.Port("clk", input = true, 1),
      Ecp5Proxy.Port("reset", input = true, 1),
      Ecp5Proxy.Port("io_a", input = true, 16),
      Ecp5Proxy.Port("io_p", input = false, 32)
    )
    val w = Ecp5Proxy.wrapper("M", ports)
    assert(w.contains("module proxy_top (input wire clk, output wire dout);") && w.contains(".io_a(ring[15:0])") &&
      w.contains(".io_p(outs[31:0])") && w.contains(".reset(reset_g)") && w.contains("DCCA reset_buffer") && w.contains(
        "assign dout = level3[0];"
      ))
    assert(Ecp5Proxy.ports(scala.io.Source.fromFile(new File(dir, "MulProbe.v")).mkString, "MulProbe").map(p =>
      p.name -> p.width
    ).toSet ==
      Set("io_a" -> 16, "io_b" -> 16, "io_product" -> 32, "clk" -> 1, "reset" -> 1))
  }

  test("the resource count: a RAM's write port takes no logic, its output register no logic element") {
    // Yosys's `proc` writes a memory's write data as "the data when enabled, else undefined": without
    // `opt_expr -mux_undef` the generic count mapped that to a LUT per data bit, which no FPGA flow builds (the
    // write enable is the block's own pin).
    val dir = new File("target/report-test/count")
    val r = Generate.spinalConfig(dir.getPath).generate(new Ecp5Proxy.RamProbe)
    val (stat, alone) = ResourceCount.runYosys(dir, new File(dir, s"${r.toplevelName}.v"), r.toplevelName)
    val cells = ResourceCount.total(r.toplevelName, ResourceCount.parseStat(stat))
    // the read address, the RAM's output register, the incremented output: 10 + 16 + 16 flip-flops, 16 carry bits
    assert(cells.luts == 0 && cells.carry == 16 && cells.ffs == 42, cells)
    // alone: the read address (fed by a port) and the output register's copy of the RAM's data, not the RAM's own
    assert(alone(r.toplevelName) == 10, alone)
  }

  test("the resource count: a block is counted in a Yosys run of its own, whatever else the file holds") {
    // ABC's mapping follows the order of the names it is given; a run of the whole design let every other module's
    // names move a block's count (the feature budget, its Verilog unchanged, by up to about 170 LEs)
    val dir = new File("target/report-test/own")
    val r = Generate.spinalConfig(dir.getPath).generate(new OrbTop(OrbConfig.default))
    val module = r.toplevel.core.budget.definitionName
    val verilog = new File(dir, s"${r.toplevelName}.v")
    val text = scala.io.Source.fromFile(verilog).mkString
    // the same file with a module of many names of its own before the block's
    val names = (0 until 400).map(i => s"  wire [7:0] probe_$i = a + 8'd$i;").mkString("\n")
    val probe =
      s"module OrbCountProbe (input wire [7:0] a, output wire [7:0] y);\n$names\n  assign y = probe_399;\nendmodule\n\n"
    val start = text.indexOf(s"module $module ")
    assert(start > 0, s"module $module in the Verilog")
    val other = new File(dir, "withProbe.v")
    Report.write(other, text.substring(0, start) + probe + text.substring(start))
    val alone = ResourceCount.moduleCells(dir, verilog, module, "yosys/plain")
    val beside = ResourceCount.moduleCells(dir, other, module, "yosys/probe")
    assert(alone.luts > 0 && alone == beside, s"$alone against $beside")
  }

  test("the resource count: a register kept apart that nothing reads takes no logic element") {
    val dir = new File("target/report-test/kept")
    val r = Generate.spinalConfig(dir.getPath).generate(new Ecp5Proxy.KeptProbe)
    val verilog = scala.io.Source.fromFile(new File(dir, s"${r.toplevelName}.v")).mkString
    val keptUnread = "\\(\\* preserve \\*\\) reg +\\[7:0\\] +\\w+_b;".r
    assert(keptUnread.findAllIn(verilog).size == 2, "the unread field's two kept registers are in the Verilog")
    val (stat, _) = ResourceCount.runYosys(dir, new File(dir, s"${r.toplevelName}.v"), r.toplevelName)
    val cells = ResourceCount.total(r.toplevelName, ResourceCount.parseStat(stat))
    assert(cells.ffs == 16 && cells.luts == 0, cells)
  }

  test("ABC's address-dependent assertion (run Yosys again) is told from any other failure of the resource count") {
    val aborted = Seq(
      "ABC: + lutpack -S 1 ",
      "ABC: berkeley-abc: src/opt/lpk/lpkCut.c:200: Lpk_CutTruth: Assertion " +
        "`((unsigned)(ABC_PTRUINT_T)pFanin->pCopy) & 0xffff0000' failed.",
      "ABC: Aborted",
      "ERROR: ABC: execution of command \"berkeley-abc\" -s -f /tmp/yosys-abc-dvnfeJ/abc.script 2>&1\" failed: " +
        "return code 134."
    ).mkString("\n")
    assert(ResourceCount.abcAborted(aborted))
    assert(!ResourceCount.abcAborted("ERROR: Module `\\Foo' referenced in module `\\Top' is not part of the design."))
    assert(!ResourceCount.abcAborted("ABC: + lutpack -S 1\nEnd of script."), "a run that ended")
  }

  test("a seed whose reset arc to its global buffer does not route is told from any other failure") {
    val work = new File("target/report-test/reset-arc")
    work.mkdirs()
    def logOf(seed: Int, lines: String*): Unit =
      Report.write(new File(work, s"nextpnr_seed$seed.log"), lines.mkString("", "\n", "\n"))
    logOf(
      1,
      "Info: Running main router loop...",
      "ERROR: Failed to route arc 0.0 of net 'reset_q', from X29/Y2/Q0_SLICE to X0/Y0/G_CLKI_TDCC0."
    )
    logOf(2, "ERROR: Failed to route arc 3.0 of net 'dut.core.x', from X1/Y1/Q0_SLICE to X2/Y2/A0_SLICE.")
    assert(Ecp5Proxy.resetArcFailed(work, 1))
    assert(!Ecp5Proxy.resetArcFailed(work, 2), "another net's arc is a real failure")
    assert(!Ecp5Proxy.resetArcFailed(work, 3), "no log: no replacement")
  }

  test("a seed whose reset arc fails is replaced by seed + 100, + 200 and so on, and the run says so") {
    def run(seed: Int, routed: Boolean) =
      Ecp5Proxy.Run(seed, if (routed) Some(100.0 + seed) else None, if (routed) "routed" else "unroutable", None, 1.0)
    val tried = scala.collection.mutable.ArrayBuffer[Int]()
    def route(routes: Int => Boolean)(s: Int) = { tried += s; run(s, routes(s)) }
    // seeds 1 and 101 fail on the reset's arc, 201 routes
    val replaced = Ecp5Proxy.withReplacements(1)(route(_ == 201), _ != 201, _ => ())
    assert(tried == Seq(1, 101, 201) && replaced.seed == 201 && replaced.fmaxMhz.contains(301.0))
    assert(replaced.outcome.contains("in place of seeds 1 and 101"), replaced.outcome)
    // a routed seed, or one that fails for any other reason, stands
    tried.clear()
    assert(Ecp5Proxy.withReplacements(2)(route(_ => true), _ => true, _ => ()).outcome == "routed")
    assert(!Ecp5Proxy.withReplacements(3)(route(_ => false), _ => false, _ => ()).routed && tried == Seq(2, 3))
    // every replacement failing too: unroutable, and the seeds named
    tried.clear()
    val failed = Ecp5Proxy.withReplacements(1)(route(_ => false), _ => true, _ => ())
    assert(tried == (0 to Ecp5Proxy.replacementTries).map(1 + _ * Ecp5Proxy.replacementSeedOffset))
    assert(!failed.routed && failed.outcome.contains("on seeds 1, 101, 201, 301"), failed.outcome)
  }

  test("an unroutable run names the congested blocks from router2's heat maps") {
    val work = new File("target/report-test/congestion")
    Option(work.listFiles()).foreach(_.foreach(_.delete()))
    work.mkdirs()
    Ecp5Proxy.resource("netlist.py", new File(work, "netlist.py"))
    assert(Ecp5Proxy.congestion(work, "h").isEmpty, "no heat maps: nothing to name")
    def map(iteration: Int, lines: String*): Unit =
      Report.write(new File(work, s"h_congestion_by_net_$iteration.csv"), lines.mkString("", "\n", "\n"))
    // the second iteration has the fewest overused wires: its shares count, block names as the report's
    map(1, "dut.core.descriptors.store_1_a[2],40", "dut.core.budget.banks_0_1_2_score[3],10")
    map(
      2,
      "dut.core.budget.banks_0_1_2_score[3],6",
      "dut.core.budget.emission_x,3",
      "dut.matcher_1.lanes_0_q,2",
      "dut._zz_readData[1],1",
      "regs_sources_1,0"
    )
    assert(Ecp5Proxy.congestion(work, "h") ==
      Some("congested: core.budget 75 %, matcher 17 %, top 8 % of the nets on overused wires (iteration 2)"))
  }

  test("report.json and report.md for the default configuration, without timing") {
    val dir = new File("target/report-test")
    Report.run(Report.Options(out = dir.getPath, timing = false))
    val json = scala.io.Source.fromFile(new File(dir, "report.json")).mkString
    def number(key: String, in: String = json): Double =
      ("\"" + key + "\": ([0-9.]+|null)").r.findFirstMatchIn(in).map(_.group(1)).filter(_ != "null").map(_.toDouble)
        .getOrElse(fail(s"no $key in report.json"))
    for (k <- Seq("les", "luts", "ffs", "m4k", "multipliers", "pixels_per_clock")) assert(number(k) >= 0, k)
    assert(json.contains("\"fmax_mhz\": null"), "--no-timing gives fmax_mhz null")
    val blocks = json.substring(json.indexOf("\"blocks\""), json.indexOf("\"memories\""))
    for (b <- Seq("core.harris", "core.budget", "core.descriptors", "matcher", "top"))
      assert(blocks.contains(s""""$b": {"les": """), b)
    for (k <- Seq("luts", "ffs", "m4k", "multipliers", "fmax_mhz", "pixels_per_clock"))
      assert(s""""$k": """.r.findAllMatchIn(blocks).size == 9, s"every block has $k")
    // Per-block figures add up to the totals; the memory list adds up to the M4K total.
    val perBlock = """"m4k": (\d+)""".r.findAllMatchIn(blocks).map(_.group(1).toInt).sum
    val memories = json.substring(json.indexOf("\"memories\""))
    val perMemory = """"m4k": (\d+), "shape"""".r.findAllMatchIn(memories).map(_.group(1).toInt).sum
    assert(perBlock == number("m4k") && perMemory == number("m4k"))
    val luts = """"luts": (\d+)""".r.findAllMatchIn(blocks).map(_.group(1).toInt).sum
    assert(luts == number("luts"))
    // The design's memories: the smoothed rows two to a bank (2048 deep; the last bank 1024 when the count is odd),
    // the raw rows, the store lanes.
    val cfg = OrbConfig.default
    val rows = cfg.descriptor.smoothedRows
    assert(""""depth": 2048, "width": 8""".r.findAllMatchIn(memories).size == rows / 2)
    assert(""""depth": 1024, "width": 8""".r.findAllMatchIn(memories).size == rows % 2)
    // a store entry (position and descriptor, 278 bits) in `storeParts` RAMs per lane
    val entryBits = 2 * cfg.frame.coordWidth + OrbDescriptorConfig.descriptorBits
    val partBits = (entryBits + MatcherConfig.storeParts - 1) / MatcherConfig.storeParts
    assert(
      s""""depth": ${cfg.matcher.groups}, "width": $partBits""".r.findAllMatchIn(memories).size ==
        cfg.matcher.comparators * MatcherConfig.storeParts
    )
    assert(number("multipliers") >= 24, "at least the Harris products")
    assert(
      number("per_cell") == cfg.budget.perCell && number("clocks_per_feature") == cfg.clocksPerFeature &&
        number("descriptor_clocks_max") == DescriptorUnit.maxClocks(cfg.descriptor),
      "the budget's capacity figures"
    )
    // Logic elements as two bounds: flip-flops packed with any LUT, or only with the one feeding them.
    assert(number("les") >= number("les_low") && number("ffs_alone") <= number("ffs") && number("ffs_alone") > 0)
    assert(number("les") == number("luts") + number("carry_les") + number("ffs_alone"))
    val md = scala.io.Source.fromFile(new File(dir, "report.md")).mkString
    assert(md.contains("## Feature budget capacity"))
    assert(md.contains("| **total** |") && md.contains("Not run (--no-timing)"))
    println(s"[orb] report: ${number("les")} LEs, ${number("m4k")} M4K, ${number("multipliers")} multipliers")
  }
}
