package orb

import org.scalatest.funsuite.AnyFunSuite

import java.io.File

/** `orb.Report --no-timing` on the default configuration: the files, the JSON keys, and figures that agree with
  * the design (Yosys reads and maps the whole core on the way). */
class ReportSpec extends AnyFunSuite {
  test("report.json and report.md for the default configuration, without timing") {
    val dir = new File("target/report-test")
    Report.run(Report.Options(out = dir.getPath, timing = false))
    val json = scala.io.Source.fromFile(new File(dir, "report.json")).mkString
    def number(key: String, in: String = json): Double =
      ("\"" + key + "\": ([0-9.]+|null)").r.findFirstMatchIn(in).map(_.group(1)).filter(_ != "null").map(_.toDouble)
        .getOrElse(fail(s"no $key in report.json"))
    for (k <- Seq("les", "luts", "ffs", "m4k", "multipliers", "pixels_per_clock")) assert(number(k) >= 0, k)
    assert(json.contains("\"fmax_mhz\": null"), "--no-timing gives fmax_mhz null")
    val blocks = json.substring(json.indexOf("\"blocks\""), json.indexOf("\"memories\""))
    for (b <- Seq("core.harris", "core.budget", "core.descriptors", "matcher", "top")) assert(blocks.contains(s""""$b": {"les": """), b)
    for (k <- Seq("luts", "ffs", "m4k", "multipliers", "fmax_mhz", "pixels_per_clock"))
      assert(s""""$k": """.r.findAllMatchIn(blocks).size == 9, s"every block has $k")
    // Per-block figures add up to the totals; the memory list adds up to the M4K total.
    val perBlock = """"m4k": (\d+)""".r.findAllMatchIn(blocks).map(_.group(1).toInt).sum
    val memories = json.substring(json.indexOf("\"memories\""))
    val perMemory = """"m4k": (\d+), "shape"""".r.findAllMatchIn(memories).map(_.group(1).toInt).sum
    assert(perBlock == number("m4k") && perMemory == number("m4k"))
    val luts = """"luts": (\d+)""".r.findAllMatchIn(blocks).map(_.group(1).toInt).sum
    assert(luts == number("luts"))
    // The design's memories: one RAM per smoothed row (1024 deep), the raw rows, the store lanes.
    val cfg = OrbConfig.default
    assert(""""depth": 1024, "width": 8""".r.findAllMatchIn(memories).size == cfg.descriptor.smoothedRows)
    assert(memories.contains(s""""depth": ${cfg.matcher.groups}, "width": 278"""))
    assert(number("multipliers") >= 24, "at least the Harris products")
    assert(number("per_cell") == cfg.budget.perCell && number("clocks_per_feature") == cfg.clocksPerFeature &&
      number("descriptor_clocks_max") == DescriptorUnit.maxClocks(cfg.descriptor), "the budget's capacity figures")
    val md = scala.io.Source.fromFile(new File(dir, "report.md")).mkString
    assert(md.contains("## Feature budget capacity"))
    assert(md.contains("| **total** |") && md.contains("Not run (--no-timing)"))
    println(s"[orb] report: ${number("les")} LEs, ${number("m4k")} M4K, ${number("multipliers")} multipliers")
  }
}
