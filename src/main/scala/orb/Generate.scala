package orb

import spinal.core._
import java.io.File

/** `runMain orb.Generate [--out DIR] [--config NAME] [--max-width N]`: writes the Verilog of the core. */
object Generate {
  val defaultOut = "gen"
  val usage: String =
    s"""usage: orb.Generate [--out DIR] [--config NAME] [--max-width N]
       |  --out DIR        where to write OrbCore.v (default: $defaultOut)
       |  --config NAME    preset: ${OrbConfig.presets.keys.toSeq.sorted.mkString(", ")} (default: default)
       |  --max-width N    longest line in pixels (line buffer depth), overrides the preset
       |  --help           this text""".stripMargin

  final case class Options(out: String = defaultOut, config: OrbConfig = OrbConfig.default, configName: String = "default")

  private val valued = Set("--out", "--config", "--max-width")

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

  def generate(o: Options): File = {
    new File(o.out).mkdirs()
    spinalConfig(o.out).generate(new OrbCore(o.config))
    new File(o.out, "OrbCore.v")
  }

  /** Exit status: 0 done, 2 bad arguments. */
  def run(args: Seq[String], err: java.io.PrintStream = System.err): Int =
    if (args.contains("--help")) { println(usage); 0 }
    else parse(args) match {
      case Left(msg) => err.println(s"orb.Generate: $msg"); 2
      case Right(o) =>
        val file = generate(o)
        println(s"orb.Generate: wrote ${file.getPath} (config ${o.configName}, maxWidth ${o.config.maxWidth})")
        0
    }

  def main(args: Array[String]): Unit = {
    val status = run(args.toSeq)
    if (status != 0) sys.exit(status)
  }
}
