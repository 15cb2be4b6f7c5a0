package orb.sim

import orb.model.GrayImage
import org.scalatest.funsuite.AnyFunSuite

import java.io.{ByteArrayOutputStream, File, PrintStream}
import java.nio.file.Files
import scala.sys.process._

/** The `Match` command as a user runs it: its outputs, model == RTL, the waveform, and every error case. */
class MatchCliSpec extends AnyFunSuite {
  val tmp: File = Files.createTempDirectory("orb-match").toFile
  val graf1: String = "data/graf1.png"; val graf3: String = "data/graf3.png"; val h: String = "data/graf_1to3.H.txt"

  /** (exit status, what went to stderr) */
  def run(args: String*): (Int, String) = {
    val buf = new ByteArrayOutputStream()
    val status = Match.run(args, new PrintStream(buf, true))
    (status, buf.toString.trim)
  }
  def lines(dir: File, name: String): Seq[String] = scala.io.Source.fromFile(new File(dir, name)).getLines().toSeq

  test("bad arguments and bad files: one line on stderr, exit status 2") {
    val big = new File(tmp, "big.png"); GrayImage.tabulate(1100, 60)((x, _) => x % 256).save(big)
    val tiny = new File(tmp, "tiny.png"); GrayImage.tabulate(40, 40)((x, _) => x).save(tiny)
    val junk = new File(tmp, "junk.png"); Files.write(junk.toPath, "not an image".getBytes)
    val badH = new File(tmp, "bad.H.txt"); Files.write(badH.toPath, "1 0 0\n0 1".getBytes)
    val out = new File(tmp, "err").getPath

    /** the pair and the output folder, then `more` */
    def pair(more: String*): Seq[String] = Seq("--key", graf1, "--live", graf3, "--out", out) ++ more
    val cases = Seq(
      Seq("--key", graf1, "--live", graf3) -> "required",
      Seq("--key", "data/nope.png", "--live", graf3, "--out", out) -> "no such image file",
      Seq("--key", junk.getPath, "--live", graf3, "--out", out) -> "not a readable image",
      Seq("--key", big.getPath, "--live", graf3, "--out", out) -> "at most 1024x2047",
      Seq("--key", tiny.getPath, "--live", graf3, "--out", out) -> "at least 45x45",
      pair("--hamming", "300") -> "--hamming",
      pair("--ratio", "2.5") -> "--ratio",
      pair("--engine", "fpga") -> "--engine",
      pair("--trace", "3") -> "--trace",
      pair("--wave") -> "--wave needs --engine rtl",
      pair("--frobnicate") -> "unknown argument",
      pair("--hamming") -> "needs a value",
      pair("--homography", badH.getPath) -> "9 numbers",
      pair("--homography", "data/none.txt") -> "no such file",
      pair("--segment-threshold", "256") -> "--segment-threshold takes a whole number from 0 to 255",
      pair("--segment-threshold", "20", "--no-segment-test") -> "contradict",
      pair("--features", "70000") -> "--features takes a whole number from 0 to 65535",
      pair("--features", "many") -> "--features"
    )
    for ((args, expected) <- cases) {
      val (status, err) = run(args: _*)
      assert(status == 2, s"${args.mkString(" ")}: status $status")
      assert(
        err.linesIterator.size == 1 && err.startsWith("orb.sim.Match: ") && err.contains(expected),
        s"${args.mkString(" ")}: '$err'"
      )
    }
  }

  test("model engine on graf1 -> graf3: every output file, summary figures consistent with the CSVs") {
    val dir = new File(tmp, "model")
    assert(run("--key", graf1, "--live", graf3, "--out", dir.getPath, "--homography", h, "--ratio", "0.8")._1 == 0)
    val cs = lines(dir, "correspondences.csv")
    assert(cs.head == "live_x,live_y,key_x,key_y,distance" && cs.size > 20)
    val live = lines(dir, "live_features.csv")
    assert(live.head == "x,y,angle_deg,score,descriptor" && live.tail.forall(_.split(",")(4).matches("[0-9a-f]{64}")))
    val summary = lines(dir, "summary.json").mkString("\n")
    assert(summary.contains(s""""correspondences": ${cs.size - 1}""") && summary.contains(
      s""""features": ${live.size - 1}"""
    ))
    assert(summary.contains("\"inliers_3px\": 0.") && summary.contains("\"ratio\": 0.80") && summary.contains(
      "\"segment_threshold\": 20"
    ))
    assert(
      live.size - 1 == 500 && lines(dir, "key_features.csv").size - 1 == 500,
      "the target, on images with more corners"
    )
    assert(summary.contains("\"target\": 500") && summary.contains("\"stream\": \"5 frames") && summary.contains(
      "\"deselected\": "
    ))
    val few = new File(tmp, "model-100")
    assert(run("--key", graf1, "--live", graf3, "--out", few.getPath, "--features", "100")._1 == 0)
    assert(lines(few, "live_features.csv").size - 1 == 100 && lines(few, "summary.json").mkString.contains(
      "\"features\": 100"
    ))
    val plain = new File(tmp, "model-harris")
    assert(run("--key", graf1, "--live", graf3, "--out", plain.getPath, "--no-segment-test")._1 == 0)
    assert(lines(plain, "summary.json").mkString("\n").contains("\"segment_threshold\": null"))
    assert(lines(plain, "live_features.csv") != live, "pure Harris maxima are other features")
    assert(javax.imageio.ImageIO.read(new File(dir, "matches.png")).getWidth == 800 + 8 + 800)
  }

  test("rtl engine == model engine (identical CSVs) on crops, with a waveform whose save file names real signals") {
    val key = new File(tmp, "key.png"); GrayImage.load(graf1).crop(240, 180, 224, 192).save(key)
    val live = new File(tmp, "live.png"); GrayImage.load(graf3).crop(230, 190, 224, 192).save(live)
    val (m, r) = (new File(tmp, "crop-model"), new File(tmp, "crop-rtl"))
    val common = Seq("--key", key.getPath, "--live", live.getPath, "--hamming", "90", "--trace", "100,90")
    assert(run(common ++ Seq("--out", m.getPath): _*)._1 == 0)
    assert(run(common ++ Seq("--out", r.getPath, "--engine", "rtl", "--wave", "--wave-rows", "16"): _*)._1 == 0)
    for (f <- Seq("correspondences.csv", "key_features.csv", "live_features.csv"))
      assert(lines(m, f) == lines(r, f), s"$f differs between the engines")
    assert(lines(m, "correspondences.csv").size > 1, "the crops have correspondences")
    val trace = lines(r, "trace.txt")
    assert(trace.exists(_.startsWith("descriptor")) && !trace.exists(_.contains("differs")), trace.mkString("\n"))
    val summary = lines(r, "summary.json").mkString("\n")
    assert(summary.contains("\"pixels_per_clock\": 0.") && summary.contains("\"match_drops\": 0"))
    val fst = new File(r, "wave.fst")
    assert(fst.length() > 1000)
    val names = lines(r, "wave.gtkw").filter(_.startsWith("TOP."))
    assert(names.size > 50)
    assume(scala.util.Try("fst2vcd --help".!(ProcessLogger(_ => ()))).isSuccess, "fst2vcd (gtkwave) is not installed")
    val header =
      Seq("fst2vcd", fst.getPath).lazyLines_!(ProcessLogger(_ => ())).takeWhile(!_.contains("$enddefinitions"))
    var scope = List[String](); val declared = scala.collection.mutable.Set[String]()
    header.map(_.trim.split("\\s+").toSeq).foreach {
      case Seq("$scope", _, name, _*) => scope = scope :+ name
      case Seq("$upscope", _*) => scope = scope.init
      case Seq("$var", _, _, _, name, rest @ _*) =>
        declared += (scope :+ name).mkString(".") + rest.headOption.filter(_.startsWith("[")).getOrElse("")
      case _ =>
    }
    val missing = names.filterNot(declared)
    assert(missing.isEmpty, s"signals of wave.gtkw not in wave.fst: ${missing.take(5)}")
  }
}
