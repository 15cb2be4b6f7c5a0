package orb

/** The 256 learned rBRIEF tests (Rublee et al. 2011, as in OpenCV), read from `data/orb_pattern_31.csv`, which is on
  * the classpath. */
final case class BriefTest(x1: Int, y1: Int, x2: Int, y2: Int)

object Pattern {
  lazy val tests: IndexedSeq[BriefTest] = {
    val in = Option(getClass.getResourceAsStream("/orb_pattern_31.csv"))
      .getOrElse(throw new IllegalStateException("orb_pattern_31.csv is not on the classpath (it lives in data/)"))
    val lines =
      try scala.io.Source.fromInputStream(in).getLines().toVector
      finally in.close()
    val tests = lines.map(_.trim).filter(l => l.nonEmpty && (l.head == '-' || l.head.isDigit)).map { l =>
      val Array(x1, y1, x2, y2) = l.split(",").map(_.trim.toInt)
      BriefTest(x1, y1, x2, y2)
    }
    require(
      tests.size == OrbDescriptorConfig.descriptorBits,
      s"expected ${OrbDescriptorConfig.descriptorBits} BRIEF tests, found ${tests.size}"
    )
    tests
  }
}
