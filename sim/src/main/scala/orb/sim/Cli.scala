package orb.sim

import orb.model.GrayImage

/** The shared command line of the measurement apps: `[--threshold T] [--bins N,..] [IMAGE ...]`. Errors are one
  * line on stderr and exit status 2. */
final class Cli(app: String, usage: String, withBins: Boolean) {
  def fail(msg: String): Nothing = { System.err.println(s"$app: $msg"); sys.exit(2) }

  final case class Options(threshold: Long, bins: Seq[Int], images: Seq[String])

  def parse(args: Array[String], defaultThreshold: Long, defaultBins: Int): Options = {
    var o = Options(defaultThreshold, Seq(defaultBins), Nil)
    var rest = args.toList
    while (rest.nonEmpty) rest match {
      case "--help" :: _ => println(usage); sys.exit(0)
      case "--threshold" :: t :: tail =>
        o = o.copy(threshold = t.toLongOption.filter(_ >= 0).getOrElse(fail(s"--threshold takes a non-negative integer, not '$t'"))); rest = tail
      case "--bins" :: b :: tail if withBins =>
        o = o.copy(bins = b.split(",").toSeq.map(s => s.trim.toIntOption.filter(n => n >= 8 && n % 8 == 0)
          .getOrElse(fail(s"--bins takes multiples of 8, not '$s'")))); rest = tail
      case opt :: Nil if opt == "--threshold" || (withBins && opt == "--bins") => fail(s"$opt needs a value")
      case opt :: _ if opt.startsWith("--") => fail(s"unknown option '$opt' (see --help)")
      case f :: tail => o = o.copy(images = o.images :+ f); rest = tail
      case Nil =>
    }
    if (o.images.isEmpty)
      o = o.copy(images = Option(new java.io.File("data").listFiles()).toSeq.flatten.map(_.getPath).filter(_.endsWith(".png")).sorted)
    o
  }

  def load(path: String): GrayImage = try GrayImage.load(path) catch { case e: IllegalArgumentException => fail(e.getMessage) }
}
