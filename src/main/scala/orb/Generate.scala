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

  final case class Options(out: String = defaultOut, config: OrbConfig = OrbConfig.default, configName: String = "default",
                           clockMhz: Double = 50.0)

  private val valued = Set("--out", "--config", "--max-width", "--clock-mhz")

  /** Parses the arguments; Left is a one-line error. */
  def parse(args: Seq[String]): Either[String, Options] = {
    def loop(rest: List[String], o: Options): Either[String, Options] = rest match {
      case Nil => Right(o)
      case "--out" :: dir :: tail => loop(tail, o.copy(out = dir))
      case "--config" :: name :: tail => OrbConfig.presets.get(name) match {
        case Some(c) => loop(tail, o.copy(config = c, configName = name))
        case None => Left(s"unknown --config '$name' (known: ${OrbConfig.presets.keys.toSeq.sorted.mkString(", ")})")
      }
      case "--max-width" :: n :: tail => n.toIntOption match {
        case Some(w) if w >= 16 && w <= 2047 => loop(tail, o.copy(config = o.config.copy(frame = o.config.frame.copy(maxWidth = w))))
        case _ => Left(s"--max-width takes a whole number from 16 to 2047, not '$n'")
      }
      case "--clock-mhz" :: f :: tail => f.toDoubleOption match {
        case Some(mhz) if mhz > 0 && mhz <= 500 => loop(tail, o.copy(clockMhz = mhz))
        case _ => Left(s"--clock-mhz takes a frequency in MHz from 0 to 500, not '$f'")
      }
      case opt :: Nil if valued(opt) => Left(s"$opt needs a value")
      case other :: _ => Left(s"unknown argument '$other' (see --help)")
    }
    loop(args.toList, Options())
  }

  /** The SpinalHDL settings for the Cyclone II target: Altera device (memories inferred as M4K with synchronous
    * reads), plain Verilog, asynchronous active-high reset. */
  def spinalConfig(out: String): SpinalConfig =
    SpinalConfig(targetDirectory = out, device = Device.ALTERA, mode = Verilog,
      defaultConfigForClockDomains = ClockDomainConfig(resetKind = ASYNC, resetActiveLevel = HIGH),
      oneFilePerComponent = false)

  /** Writes the Verilog (and any memory initialisation files) and the Quartus project; returns the Verilog. */
  def generate(o: Options): File = {
    val dir = new File(o.out)
    dir.mkdirs()
    val report = spinalConfig(o.out).generate(new OrbTop(o.config))
    val sources = report.generatedSourcesPaths.toSeq.map(p => dir.toPath.toAbsolutePath.relativize(new File(p).toPath.toAbsolutePath).toString).sorted
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
