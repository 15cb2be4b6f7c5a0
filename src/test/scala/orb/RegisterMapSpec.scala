package orb

import org.scalatest.funsuite.AnyFunSuite

/** The register map is one table: the README's table is written from it, and every counter has its hardware source
  * and its model value. (The slave built from it is checked over the bus in `OrbTopSpec`.) */
class RegisterMapSpec extends AnyFunSuite {
  test("the README's register table is the one the register map writes") {
    val readme = scala.io.Source.fromFile("README.md").mkString
    val table = RegisterMap.markdown(OrbConfig.default)
    assert(readme.contains(table + "\n"), s"README.md should hold this table (from RegisterMap.markdown):\n$table")
  }

  test("every register has one word, every read-only register a source, every counter a model value") {
    val all = RegisterMap.all
    assert(all.map(_.address) == all.map(_.address).sorted.distinct, "addresses in order, one register per word")
    assert(all.filterNot(_.writable).forall(_.hardware.isDefined))
    assert(all.filter(_.writable).forall(r => r.hardware.isEmpty && r.model.isEmpty))
    assert(RegisterMap.counters.map(_.key) == Seq(
      "frames",
      "bad_frames",
      "bad_lines",
      "corners",
      "features",
      "feature_drops",
      "stored",
      "store_overflow",
      "matches",
      "match_drops",
      "deselected"
    ))
    assert(RegisterMap.CONTROL.reset(OrbConfig.default) == 6 && RegisterMap.id == BigInt("4f524203", 16))
  }
}
