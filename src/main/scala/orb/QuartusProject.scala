package orb

import java.io.{File, PrintWriter}

/** A Quartus II project for the DE2-70's Cyclone II (EP2C70F896C6) around the generated Verilog: open
  * `OrbTop.qpf` in Quartus II 13.0sp1 (the last release with Cyclone II) and compile. The core has no pins of
  * a board: the project compiles it alone (for fit and timing) or it is added to a board design. */
object QuartusProject {
  val family = "Cyclone II"
  val device = "EP2C70F896C6"

  /** Writes `top`.qpf, .qsf and .sdc into `dir`, naming `sources` (file names relative to `dir`). */
  def write(dir: File, top: String, sources: Seq[String], clockMhz: Double): Seq[File] = {
    require(clockMhz > 0 && clockMhz <= 500, s"clock $clockMhz MHz")
    def file(name: String)(body: PrintWriter => Unit): File = {
      val f = new File(dir, name); val w = new PrintWriter(f)
      try body(w)
      finally w.close()
      f
    }
    val qpf = file(s"$top.qpf") { w =>
      w.println("QUARTUS_VERSION = \"13.0\"")
      w.println(s"""PROJECT_REVISION = "$top"""")
    }
    val sdc = file(s"$top.sdc") { w =>
      w.println(f"# Pixel clock: one pixel per clock, so the pixel rate is this clock ($clockMhz%.3f MHz).")
      w.println(f"create_clock -name clk -period ${1000.0 / clockMhz}%.3f [get_ports clk]")
      w.println("derive_clock_uncertainty")
      w.println("# The reset is asynchronous to the pixel clock.")
      w.println("set_false_path -from [get_ports reset]")
    }
    val qsf = file(s"$top.qsf") { w =>
      def g(k: String, v: String) = w.println(s"set_global_assignment -name $k $v")
      g("FAMILY", s""""$family"""")
      g("DEVICE", device)
      g("TOP_LEVEL_ENTITY", top)
      g("ORIGINAL_QUARTUS_VERSION", "13.0")
      g("PROJECT_OUTPUT_DIRECTORY", "output_files")
      g("VERILOG_INPUT_VERSION", "VERILOG_2001")
      g("NUM_PARALLEL_PROCESSORS", "ALL")
      g("OPTIMIZATION_TECHNIQUE", "SPEED")
      // The constant tables (cos/sin, test pattern, angle tangents) are logic, as orb.Report counts them: Quartus
      // may not move them into M4K blocks, which the design uses up to its budget.
      g("AUTO_ROM_RECOGNITION", "OFF")
      sources.foreach { s =>
        val kind = if (s.endsWith(".v")) "VERILOG_FILE" else if (s.endsWith(".mif")) "MIF_FILE" else "SOURCE_FILE"
        g(kind, s)
      }
      g("SDC_FILE", sdc.getName)
    }
    Seq(qpf, qsf, sdc)
  }

  /** Every file a .qsf names (VERILOG_FILE, SDC_FILE, MIF_FILE, SOURCE_FILE). */
  def namedFiles(qsf: File): Seq[String] = {
    val named = """set_global_assignment -name (VERILOG_FILE|SDC_FILE|MIF_FILE|SOURCE_FILE) (\S+)""".r
    scala.io.Source.fromFile(qsf).getLines().collect { case named(_, f) => f }.toSeq
  }
}
