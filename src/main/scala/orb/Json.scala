package orb

/** A small JSON writer for the apps' reports: objects are ordered `(key, value)` sequences; values are strings,
  * numbers, booleans, `None` / `null`, `Option`s, sequences and nested objects. */
object Json {
  final case class Obj(fields: Seq[(String, Any)])

  def obj(fields: (String, Any)*): Obj = Obj(fields)

  def quote(s: String): String = {
    val b = new StringBuilder("\"")
    for (c <- s) c match {
      case '"' => b ++= "\\\""
      case '\\' => b ++= "\\\\"
      case '\n' => b ++= "\\n"
      case '\t' => b ++= "\\t"
      case c if c < ' ' => b ++= f"\\u${c.toInt}%04x"
      case c => b += c
    }
    (b += '"').toString
  }

  def number(d: Double): String =
    if (d.isNaN || d.isInfinite) "null"
    else if (d == math.rint(d) && math.abs(d) < 1e15) f"$d%.0f"
    else BigDecimal(d).setScale(3, BigDecimal.RoundingMode.HALF_EVEN).bigDecimal.stripTrailingZeros.toPlainString

  private def scalar(v: Any): Boolean = v match {
    case _: Obj | _: Map[_, _] => false
    case s: Iterable[_] => s.forall(scalar)
    case Some(x) => scalar(x)
    case _ => true
  }

  /** Objects with nested objects break into lines of `indent` levels of two spaces; objects of scalars and sequences
    * of scalars stay on one line. */
  def render(v: Any, indent: Int = 0): String = {
    val pad = "  " * (indent + 1)
    v match {
      case null | None => "null"
      case Some(x) => render(x, indent)
      case s: String => quote(s)
      case b: Boolean => b.toString
      case i: Int => i.toString
      case l: Long => l.toString
      case d: Double => number(d)
      case f: Float => number(f.toDouble)
      case Obj(fields) if fields.isEmpty => "{}"
      case Obj(fields) if fields.forall(f => scalar(f._2)) =>
        fields.map { case (k, x) => s"${quote(k)}: ${render(x, indent + 1)}" }.mkString("{", ", ", "}")
      case Obj(fields) =>
        fields.map { case (k, x) => s"$pad${quote(k)}: ${render(x, indent + 1)}" }.mkString(
          "{\n",
          ",\n",
          s"\n${"  " * indent}}"
        )
      case m: Map[_, _] => render(Obj(m.toSeq.map { case (k, x) => k.toString -> x }), indent)
      case s: Iterable[_] if s.exists(_.isInstanceOf[Obj]) =>
        s.map(x => pad + render(x, indent + 1)).mkString("[\n", ",\n", s"\n${"  " * indent}]")
      case s: Iterable[_] => s.map(render(_, indent)).mkString("[", ", ", "]")
      case other => quote(other.toString)
    }
  }
}
