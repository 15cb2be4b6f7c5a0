package orb

/** The one command-line parser of the apps (`Generate`, `Report` and the host tools in `sim`): each app declares
  * its options once, as flags (`--name`) or valued options (`--name VALUE`) applied to its options case class, and
  * gets the same errors as every other app, each one line: "--x needs a value", "unknown argument 'y' (see --help)",
  * "--x takes ..., not 'v'". `--help` is the app's own business (it prints its usage). */
object CommandLine {

  /** A bad command line: its message is the one line an app prints before it exits with status 2. */
  final class UsageError(message: String) extends Exception(message)

  def fail(message: String): Nothing = throw new UsageError(message)

  /** An option of an app whose options are `O`. */
  final case class Opt[O](name: String, valued: Boolean, apply: (O, String) => O)

  /** `--name`: no value. */
  def flag[O](name: String)(f: O => O): Opt[O] = Opt(name, valued = false, (o, _) => f(o))

  /** `--name VALUE`. */
  def valued[O](name: String)(f: (O, String) => O): Opt[O] = Opt(name, valued = true, f)

  /** The options given, in order, applied to `init`; an argument that is not an option goes to `positional` (an
    * error where the app takes none). Throws `UsageError`. */
  def parse[O](args: Seq[String], init: O, opts: Seq[Opt[O]], positional: Option[(O, String) => O] = None): O = {
    val byName = opts.map(o => o.name -> o).toMap
    require(byName.size == opts.size, "an option declared twice")
    var o = init
    var rest = args.toList
    while (rest.nonEmpty) {
      val arg = rest.head
      rest = rest.tail
      byName.get(arg) match {
        case Some(opt) if opt.valued =>
          if (rest.isEmpty) fail(s"$arg needs a value")
          o = opt.apply(o, rest.head)
          rest = rest.tail
        case Some(opt) =>
          o = opt.apply(o, "")
        case None =>
          positional match {
            case Some(take) if !arg.startsWith("--") => o = take(o, arg)
            case _ => fail(s"unknown argument '$arg' (see --help)")
          }
      }
    }
    o
  }

  /** `parse`, with a usage error as Left. */
  def attempt[O](body: => O): Either[String, O] =
    try Right(body)
    catch { case e: UsageError => Left(e.getMessage) }

  /** A whole number from `lo` to `hi`. */
  def whole(flag: String, v: String, lo: Long, hi: Long): Long =
    v.toLongOption.filter(n => n >= lo && n <= hi).getOrElse(
      fail(s"$flag takes a whole number from $lo to $hi, not '$v'")
    )

  /** A whole number from 1 up. */
  def positive(flag: String, v: String): Int =
    v.toIntOption.filter(_ > 0).getOrElse(fail(s"$flag takes a positive whole number, not '$v'"))

  /** A number that `ok` accepts; `what` says which ("a frequency in MHz from 0 to 500"). */
  def number(flag: String, v: String, what: String)(ok: Double => Boolean): Double =
    v.toDoubleOption.filter(ok).getOrElse(fail(s"$flag takes $what, not '$v'"))

  /** One of `choices`. */
  def choice(flag: String, v: String, choices: Seq[String]): String =
    if (choices.contains(v)) v else fail(s"$flag is ${choices.mkString(" or ")}, not '$v'")

  /** The name of a configuration preset (`OrbConfig.presets`). */
  def preset(v: String): String =
    if (OrbConfig.presets.contains(v)) v
    else fail(s"unknown --config '$v' (known: ${OrbConfig.presets.keys.toSeq.sorted.mkString(", ")})")
}
