package orb

import spinal.core._
import java.io.File

/** `runMain orb.Generate [--out DIR] [--config NAME] [--max-width N] [--clock-mhz F]`: writes the Verilog of the
  * core and a Quartus II project for the Cyclone II EP2C70 around it. */
object Generate {
  val defaultOut = "gen"
  val usage: String =
    s"""usage: orb.Generate [--out DIR] [--config NAME] [--max-width N] [--clock-mhz F]
       |  --out DIR        where to write OrbTop.v and the Quartus project (default: $defaultOut)
       |  --config NAME    preset: ${OrbConfig.presets.keys.toSeq.sorted.mkString(", ")} (default: default)
       |  --max-width N    longest line in pixels (line buffer depth), overrides the preset
       |  --clock-mhz F     pixel clock of the timing constraint in OrbTop.sdc (default: 50, the DE2-70 board clock;
       |                   100 for a faster camera)
       |  --help           this text""".stripMargin

  final case class Options(
      out: String = defaultOut,
      config: OrbConfig = OrbConfig.default,
      configName: String = "default",
      clockMhz: Double = 50.0
  )

  private val options: Seq[CommandLine.Opt[Options]] = Seq(
    CommandLine.valued("--out")((o, v) => o.copy(out = v)),
    CommandLine.valued("--config") { (o, v) =>
      val name = CommandLine.preset(v)
      o.copy(config = OrbConfig.presets(name), configName = name)
    },
    CommandLine.valued("--max-width") { (o, v) =>
      val w = CommandLine.whole("--max-width", v, 16, 2047).toInt
      o.copy(config = o.config.copy(frame = o.config.frame.copy(maxWidth = w)))
    },
    CommandLine.valued("--clock-mhz") { (o, v) =>
      o.copy(clockMhz =
        CommandLine.number("--clock-mhz", v, "a frequency in MHz from 0 to 500")(f => f > 0 && f <= 500)
      )
    }
  )

  /** Parses the arguments; Left is a one-line error. */
  def parse(args: Seq[String]): Either[String, Options] =
    CommandLine.attempt(CommandLine.parse(args, Options(), options))

  /** The SpinalHDL settings for the Cyclone II target: Altera device (memories inferred as M4K with synchronous
    * reads), plain Verilog, asynchronous active-high reset. */
  def spinalConfig(out: String): SpinalConfig =
    SpinalConfig(
      targetDirectory = out,
      device = Device.ALTERA,
      mode = Verilog,
      defaultConfigForClockDomains = ClockDomainConfig(resetKind = ASYNC, resetActiveLevel = HIGH),
      oneFilePerComponent = false
    )

  /** Writes the Verilog (and any memory initialisation files) and the Quartus project; returns the Verilog. */
  def generate(o: Options): File = {
    val dir = new File(o.out)
    dir.mkdirs()
    val report = spinalConfig(o.out).generate(new OrbTop(o.config))
    val sources = report.generatedSourcesPaths.toSeq.map(p =>
      dir.toPath.toAbsolutePath.relativize(new File(p).toPath.toAbsolutePath).toString
    ).sorted
    QuartusProject.write(dir, report.toplevelName, sources, o.clockMhz)
    new File(dir, s"${report.toplevelName}.v")
  }

  /** Exit status: 0 done, 2 bad arguments. */
  def run(args: Seq[String], err: java.io.PrintStream = System.err): Int =
    if (args.contains("--help")) { println(usage); 0 }
    else parse(args) match {
      case Left(msg) => err.println(s"orb.Generate: $msg"); 2
      case Right(o) =>
        val file = generate(o)
        println(s"orb.Generate: wrote ${file.getPath} and the Quartus project ${file.getPath.stripSuffix(".v")}.qpf " +
          f"(config ${o.configName}, maxWidth ${o.config.maxWidth}, ${o.clockMhz}%.1f MHz)")
        0
    }

  def main(args: Array[String]): Unit = {
    val status = run(args.toSeq)
    if (status != 0) sys.exit(status)
  }
}
