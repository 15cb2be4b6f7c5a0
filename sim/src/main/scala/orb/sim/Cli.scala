package orb.sim

import orb.CommandLine
import orb.model.GrayImage

/** What the host tools share around `orb.CommandLine`: `--help`, the exit on a usage error, image loading, and the
  * command line of the fidelity apps (`[--threshold T] [--bins N,..] [IMAGE ...]`). */
object Cli {

  /** Runs an app: `--help` prints `usage`; a usage error is one line on stderr and exit status 2. */
  def main(app: String, usage: String, args: Seq[String])(body: => Unit): Unit =
    if (args.contains("--help")) println(usage)
    else
      try body
      catch {
        case e: CommandLine.UsageError =>
          System.err.println(s"$app: ${e.getMessage}")
          sys.exit(2)
      }

  /** An image, or a usage error that says why not. */
  def load(path: String): GrayImage =
    try GrayImage.load(path)
    catch { case e: IllegalArgumentException => CommandLine.fail(e.getMessage) }

  final case class Fidelity(threshold: Long, bins: Seq[Int], images: Seq[String])

  /** `[--threshold T] [--bins N,..] [IMAGE ...]` (`--bins` only `withBins`); no image: every PNG in `data/`. */
  def fidelity(args: Seq[String], defaultThreshold: Long, defaultBins: Int, withBins: Boolean): Fidelity = {
    val threshold = CommandLine.valued[Fidelity]("--threshold") { (o, v) =>
      o.copy(threshold = CommandLine.whole("--threshold", v, 0, Long.MaxValue))
    }
    val bins = CommandLine.valued[Fidelity]("--bins") { (o, v) =>
      o.copy(bins = v.split(",").toSeq.map { s =>
        s.trim.toIntOption.filter(n => n >= 8 && n % 8 == 0).getOrElse(CommandLine.fail(
          s"--bins takes multiples of 8, not '$s'"
        ))
      })
    }
    val opts = if (withBins) Seq(threshold, bins) else Seq(threshold)
    val o = CommandLine.parse(
      args,
      Fidelity(defaultThreshold, Seq(defaultBins), Nil),
      opts,
      positional = Some((o: Fidelity, image: String) => o.copy(images = o.images :+ image))
    )
    if (o.images.nonEmpty) o
    else {
      val pngs = Option(new java.io.File("data").listFiles()).toSeq.flatten.map(_.getPath).filter(_.endsWith(".png"))
      o.copy(images = pngs.sorted)
    }
  }
}
