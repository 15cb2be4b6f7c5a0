package orb

import org.scalatest.funsuite.AnyFunSuite
import java.io.{ByteArrayOutputStream, File, PrintStream}
import scala.sys.process._

/** The emitted Verilog for the Cyclone II target: lint-clean for Verilator, readable and synthesizable by Yosys
  * (Verilog-2005 front end, no SystemVerilog), and the command line's error handling. */
class GenerateSpec extends AnyFunSuite {
  val config: OrbConfig = OrbConfig.default
  def runCli(args: String*): (Int, String) = {
    val err = new ByteArrayOutputStream()
    val status = Generate.run(args, new PrintStream(err))
    (status, err.toString.trim)
  }

  test("bad arguments give a one-line error and status 2") {
    for (
      args <- Seq(
        Seq("--bogus"),
        Seq("--config", "nope"),
        Seq("--max-width", "abc"),
        Seq("--max-width", "5000"),
        Seq("--out"),
        Seq("--clock-mhz", "fast")
      )
    ) {
      val (status, msg) = runCli(args: _*)
      assert(status == 2, args)
      assert(msg.startsWith("orb.Generate: ") && !msg.contains("\n") && !msg.contains("Exception"), s"$args -> $msg")
    }
    assert(runCli("--bogus")._2.contains("unknown argument '--bogus'"))
    assert(runCli("--out")._2.contains("--out needs a value"))
  }

  lazy val verilog: File = {
    val dir = new File("target/generate-test")
    val (status, msg) = runCli("--out", dir.getPath)
    assert(status == 0, msg)
    new File(dir, "OrbTop.v")
  }

  def tool(cmd: Seq[String]): (Int, String) = {
    val out = new StringBuilder
    val log = ProcessLogger(l => out ++= l + "\n", l => out ++= l + "\n")
    val status =
      try Process(cmd).!(log)
      catch { case e: java.io.IOException => fail(s"cannot run ${cmd.head}: install it (see README)") }
    (status, out.toString)
  }

  test("the Quartus project: Cyclone II EP2C70F896C6, every file the .qsf names exists, the clock constraint") {
    val dir = verilog.getParentFile
    val qsf = new File(dir, "OrbTop.qsf")
    assert(new File(dir, "OrbTop.qpf").isFile && qsf.isFile)
    val text = scala.io.Source.fromFile(qsf).mkString
    assert(text.contains("-name FAMILY \"Cyclone II\"") && text.contains("-name DEVICE EP2C70F896C6") && text.contains(
      "-name TOP_LEVEL_ENTITY OrbTop"
    ))
    assert(
      text.contains("set_global_assignment -name AUTO_ROM_RECOGNITION OFF"),
      "constant tables stay logic, as counted"
    )
    val named = QuartusProject.namedFiles(qsf)
    assert(named.contains("OrbTop.v") && named.contains("OrbTop.sdc"), named)
    named.foreach(f => assert(new File(dir, f).isFile, s"$f is named by the .qsf but missing"))
    assert(scala.io.Source.fromFile(new File(dir, "OrbTop.sdc")).mkString.contains("-period 20.000 [get_ports clk]"))
    val fast = new File("target/generate-test-100")
    assert(runCli("--out", fast.getPath, "--clock-mhz", "100")._1 == 0)
    assert(scala.io.Source.fromFile(new File(fast, "OrbTop.sdc")).mkString.contains("-period 10.000 [get_ports clk]"))
  }

  test("HarrisConfig(segment = None) elaborates without any segment-test logic; the default has it") {
    def verilog(cfg: OrbConfig, dir: String): String = {
      Generate.spinalConfig(dir).generateVerilog(new OrbTop(cfg))
      val src = scala.io.Source.fromFile(new File(dir, "OrbTop.v"));
      try src.mkString
      finally src.close()
    }
    val plain = verilog(
      config.copy(harris = config.harris.copy(segment = None, defaultThreshold = 1L << 13)),
      "target/gen-test-plain"
    )
    val default = verilog(config, "target/gen-test-default")
    assert(default.contains("PASSES") && !plain.contains("PASSES") && !plain.contains("BRIGHTER"))
  }

  test("--help lists every option and exits 0") {
    val out = new ByteArrayOutputStream()
    val status = Console.withOut(out)(Generate.run(Seq("--help")))
    assert(status == 0)
    for (opt <- Seq("--out", "--config", "--max-width", "--clock-mhz")) assert(out.toString.contains(opt), opt)
  }

  test("Verilator lint as Verilog-2001: no warning, no error") {
    val (status, out) = tool(Seq(
      "verilator",
      "--lint-only",
      "--default-language",
      "1364-2001",
      "--top-module",
      "OrbTop",
      verilog.getPath
    ))
    assert(status == 0 && !out.contains("%Warning") && !out.contains("%Error"), out)
  }

  test("plain Verilog: no SystemVerilog constructs, no simulation-only code") {
    val text = scala.io.Source.fromFile(verilog).mkString
    for (
      kw <-
        Seq("always_ff", "always_comb", "logic ", "typedef", "interface ", "$display", "$finish", "assert ", "initial")
    )
      assert(!text.contains(kw), s"'$kw' in the emitted Verilog")
  }

  test("every RAM has registered read ports, as Quartus needs for M4K blocks; constant tables are ROMs") {
    val dump = "target/generate-test/memories.txt"
    val script =
      s"read_verilog ${verilog.getPath}; hierarchy -top OrbTop; proc; opt -fast; memory -nomap; tee -q -o $dump dump t:$$mem_v2"
    val (status, out) = tool(Seq("yosys", "-q", "-p", script))
    assert(status == 0, out.takeRight(3000))
    val text = scala.io.Source.fromFile(dump).mkString
    case class MemInfo(name: String, depth: Int, width: Int, writePorts: Int, readClocked: String)
    val mems = text.split("cell \\$mem_v2 ").drop(1).map { c =>
      def param(p: String) = ("parameter \\\\" + p + " (\\S+)").r.findFirstMatchIn(c).map(_.group(1)).getOrElse("?")
      MemInfo(
        c.takeWhile(_ != '\n').trim,
        param("SIZE").toInt,
        param("WIDTH").toInt,
        param("WR_PORTS").toInt,
        param("RD_CLK_ENABLE")
      )
    }.toSeq
    val (rams, roms) = mems.partition(_.writePorts > 0)
    println(
      s"[orb] RAMs: ${rams.groupBy(m => s"${m.depth}x${m.width}").map { case (k, v) => s"${v.size} x $k" }.mkString(", ")}; " +
        s"ROMs (constant tables): ${roms.size}"
    )
    for (m <- rams) assert(m.readClocked.matches("\\d+'1+"), s"${m.name}: a read port is not registered")
    val banks = rams.filter(_.name.startsWith("\\store_"))
    assert(banks.size == config.descriptor.smoothedBanks, "one RAM per bank of two smoothed rows")
    assert(
      banks.map(_.depth).sum == config.descriptor.smoothedRows * config.maxWidth,
      "a row of maxWidth bytes per ring slot"
    )
    val window = rams.filter(_.name.startsWith("\\window_rams_"))
    assert(window.nonEmpty && rams.exists(_.name.startsWith("\\suppress_scores_rams_")))
    assert(window.forall(_.depth == config.maxWidth), "depth = maxWidth")
    assert(window.map(_.width).sum == (config.rawRows - 1) * 8, "every stored raw row, a byte a pixel")
  }
}
