package orb

import org.scalatest.funsuite.AnyFunSuite

/** The apps' one command-line parser: options applied in order, and the same one-line errors for every app. */
class CommandLineSpec extends AnyFunSuite {
  final case class O(n: Long = 0, on: Boolean = false, files: Seq[String] = Nil)
  val opts: Seq[CommandLine.Opt[O]] = Seq(
    CommandLine.valued[O]("--n")((o, v) => o.copy(n = CommandLine.whole("--n", v, 1, 9))),
    CommandLine.flag[O]("--on")(_.copy(on = true))
  )
  val files = Some((o: O, f: String) => o.copy(files = o.files :+ f))

  def error(args: String*)(positional: Option[(O, String) => O] = files): String =
    CommandLine.attempt(CommandLine.parse(args, O(), opts, positional)).swap.getOrElse(
      fail(s"${args.mkString(" ")} parsed")
    )

  test("flags, values and positional arguments, in order; a later value wins") {
    assert(CommandLine.parse(Seq("a.png", "--n", "3", "--on", "b.png", "--n", "4"), O(), opts, files) ==
      O(4, on = true, Seq("a.png", "b.png")))
    assert(CommandLine.parse(Nil, O(), opts) == O())
  }

  test("errors name the argument: unknown, missing value, out of range, positional where none is taken") {
    assert(error("--bogus")() == "unknown argument '--bogus' (see --help)")
    assert(error("--n")() == "--n needs a value")
    assert(error("--n", "10")() == "--n takes a whole number from 1 to 9, not '10'")
    assert(error("--n", "x")() == "--n takes a whole number from 1 to 9, not 'x'")
    assert(error("a.png")(None) == "unknown argument 'a.png' (see --help)")
    assert(CommandLine.attempt(CommandLine.positive("--seeds", "0")) == Left(
      "--seeds takes a positive whole number, not '0'"
    ))
    assert(CommandLine.attempt(CommandLine.choice("--engine", "fpga", Seq("model", "rtl"))) == Left(
      "--engine is model or rtl, not 'fpga'"
    ))
    assert(
      CommandLine.attempt(CommandLine.preset("nope")).left.exists(_.startsWith("unknown --config 'nope' (known: "))
    )
  }
}
