package orb

import spinal.core._

import java.io.File
import scala.collection.mutable
import scala.sys.process._

/** What `Report` counts: the memories of the design (from the design itself) and its logic (Yosys with generic
  * cells, `resources/orb/report/flow.ys`, and `netlist.py les` for the flip-flops that take a logic element of
  * their own). */
object ResourceCount {
  // ---- memories ----

  final case class Memory(block: String, name: String, depth: Int, width: Int, rom: Boolean) {

    /** the M4K shapes of Cyclone II (depth x width) */
    def shapes: Seq[(Int, Int)] = Seq(4096 -> 1, 2048 -> 2, 1024 -> 4, 512 -> 9, 256 -> 18, 128 -> 36)
    def blocksFor(s: (Int, Int)): Int = ((depth + s._1 - 1) / s._1) * ((width + s._2 - 1) / s._2)
    val (m4k, shape) = shapes.map(s => (blocksFor(s), s)).minBy(_._1)
    def bits: Long = depth.toLong * width
  }

  /** The block of a component: the first of `blocks` it is or lies in, else "top". */
  def blockOf(c: Component, blocks: Seq[(String, Component)]): String =
    blocks.find { case (_, b) => c == b || c.parents().contains(b) }.map(_._1).getOrElse("top")

  def memories(top: Component, blocks: Seq[(String, Component)]): Seq[Memory] = {
    val out = mutable.ArrayBuffer[Memory]()
    top.walkComponents { c =>
      c.dslBody.walkDeclarations {
        case m: Mem[_] => out += Memory(
            blockOf(c, blocks),
            s"${c.getPath().stripPrefix("toplevel/")}/${m.getName()}",
            m.wordCount,
            m.width,
            m.initialContent != null
          )
        case _ =>
      }
    }
    out.toSeq
  }

  // ---- logic with Yosys ----

  /** `ffsAlone`: flip-flops that no LUT or carry bit feeding them can host (see `netlist.py les`). */
  final case class Cells(luts: Long = 0, carry: Long = 0, ffs: Long = 0, mul18: Double = 0, ffsAlone: Long = 0) {
    def +(o: Cells): Cells = Cells(luts + o.luts, carry + o.carry, ffs + o.ffs, mul18 + o.mul18, ffsAlone + o.ffsAlone)
    def -(o: Cells): Cells = Cells(luts - o.luts, carry - o.carry, ffs - o.ffs, mul18 - o.mul18, ffsAlone - o.ffsAlone)
    def *(n: Long): Cells = Cells(luts * n, carry * n, ffs * n, mul18 * n, ffsAlone * n)

    /** logic elements if every flip-flop packed with some used LUT (optimistic: a lower bound) */
    def lesLow: Long = (luts + carry) max ffs

    /** logic elements if a flip-flop packs only with the LUT or carry bit that feeds it (the estimate the report uses;
      * Cyclone II can pack an unrelated register into a used LE, so Quartus may do a little better) */
    def les: Long = luts + carry + ffsAlone
  }

  /** Parses Yosys `stat` (per module): own cells, and instances of other modules. */
  def parseStat(text: String): Map[String, (Cells, Map[String, Long])] = {
    val modules = mutable.LinkedHashMap[String, (Cells, Map[String, Long])]()
    var current: String = null
    var cells = Cells(); var subs = Map.empty[String, Long]
    def flush(): Unit = if (current != null && current != "design hierarchy") modules(current) = (cells, subs)
    val header = "=== (.+) ===".r
    val cell = """\s+(\S+)\s+(\d+)""".r
    for (line <- text.linesIterator) line.trim match {
      case header(name) => flush(); current = name; cells = Cells(); subs = Map.empty
      case _ => line match {
          case cell(kind, n) if current != null =>
            val k = n.toLong
            if (kind == "$lut") cells = cells.copy(luts = cells.luts + k)
            else if (kind == "ORB_CARRY") cells = cells.copy(carry = cells.carry + k)
            else if (kind == "ORB_MUL18") cells = cells.copy(mul18 = cells.mul18 + k)
            else if (kind == "ORB_MUL9") cells = cells.copy(mul18 = cells.mul18 + 0.5 * k)
            else if (kind.startsWith("$_DFF") || kind.startsWith("$_SDFF") || kind.startsWith("$_DLATCH"))
              cells = cells.copy(ffs = cells.ffs + k)
            else if (!kind.startsWith("$")) subs = subs + (kind -> (subs.getOrElse(kind, 0L) + k))
          case _ =>
        }
    }
    flush()
    modules.toMap
  }

  /** A module's cells including its submodules. */
  def total(module: String, stat: Map[String, (Cells, Map[String, Long])]): Cells = stat.get(module) match {
    case None => Cells()
    case Some((own, subs)) => subs.foldLeft(own) { case (acc, (m, n)) => acc + total(m, stat) * n }
  }

  /** Adds each module's flip-flops that take a logic element of their own. */
  def withAlone(
      stat: Map[String, (Cells, Map[String, Long])],
      alone: Map[String, Long]
  ): Map[String, (Cells, Map[String, Long])] =
    stat.map { case (m, (c, subs)) => m -> (c.copy(ffsAlone = alone.getOrElse(m, 0L)), subs) }

  def parseAlone(text: String): Map[String, Long] =
    text.linesIterator.map(_.trim.split(" ")).collect { case Array(m, n) if n.forall(_.isDigit) => m -> n.toLong }.toMap

  /** runs of Yosys when its ABC aborts (see `abcAborted`) */
  val abcAttempts: Int = 3

  /** Yosys's log says that ABC aborted on an assertion (Debian's ABC has one in `lutpack` that depends on memory
    * addresses, so another run of the same netlist passes), not that the flow itself failed. */
  def abcAborted(log: String): Boolean =
    log.linesIterator.exists(l => l.startsWith("ABC:") && l.contains("Assertion")) &&
      log.contains("ERROR: ABC: execution of command")

  /** Yosys' `stat` text and the flip-flops alone per module, for `top` and the modules below it (`work` under
    * `dir`). Only they are elaborated (`read_verilog -defer`), so the other modules of the file, and what they
    * name, cannot change how ABC maps them. */
  def runYosys(dir: File, verilog: File, top: String, work: String = "yosys"): (String, Map[String, Long]) = {
    val workDir = new File(dir, work); workDir.mkdirs()
    runYosysIn(workDir, verilog, top)
  }

  /** A module's cells (with the modules below it) from a Yosys run of its own, on a file of its own modules alone
    * (`moduleVerilog`): the count moves only with their RTL. ABC's mapping depends on the order of the names it is
    * given, and any other module Yosys reads, even unelaborated, shifts it. */
  def moduleCells(dir: File, verilog: File, module: String, work: String): Cells = {
    val workDir = new File(dir, work); workDir.mkdirs()
    val own = new File(workDir, s"$module.v")
    Report.write(own, moduleVerilog(scala.io.Source.fromFile(verilog).mkString, module))
    val (text, alone) = runYosys(dir, own, module, work)
    total(module, withAlone(parseStat(text), alone))
  }

  /** `module` and every module it instantiates, directly or below, from a Verilog file, in the file's order. */
  def moduleVerilog(text: String, module: String): String = {
    val header = """(?m)^module\s+(\w+)""".r
    val starts = header.findAllMatchIn(text).map(m => m.group(1) -> m.start).toSeq
    val texts = starts.map { case (name, at) =>
      val end = text.indexOf("endmodule", at)
      require(end > at, s"module $name has no endmodule")
      name -> text.substring(at, end + "endmodule".length)
    }.toMap
    require(texts.contains(module), s"no module $module in the Verilog")
    val instance = """(?m)^\s*(\w+)\s+\w+\s*\(""".r
    def below(m: String): Set[String] =
      instance.findAllMatchIn(texts(m)).map(_.group(1)).filter(n => n != m && texts.contains(n)).toSet
    var wanted = Set(module)
    var frontier = Set(module)
    while (frontier.nonEmpty) {
      val next = frontier.flatMap(below) -- wanted
      wanted ++= next
      frontier = next
    }
    starts.map(_._1).filter(wanted).map(texts).mkString("", "\n\n", "\n")
  }

  private def runYosysIn(work: File, verilog: File, top: String): (String, Map[String, Long]) = {
    for (f <- Seq("cells.v", "map_mul.v", "map_alu.v", "flow.ys", "netlist.py")) {
      val in = getClass.getResourceAsStream(s"/orb/report/$f")
      require(in != null, s"missing resource orb/report/$f")
      val text = scala.io.Source.fromInputStream(in).mkString.replace("TOP.v", verilog.getAbsolutePath).replace(
        "-top TOP",
        s"-top $top"
      )
      Report.write(new File(work, f), text)
    }
    val log = new File(work, "yosys.log")
    def run(): Int =
      try Process(Seq("yosys", "-q", "-l", log.getName, "-s", "flow.ys"), work).!(ProcessLogger(_ => ()))
      catch {
        case _: java.io.IOException =>
          throw new RuntimeException("yosys is not on the PATH (Debian: apt-get install yosys)")
      }
    def logText: String = if (log.isFile) scala.io.Source.fromFile(log).mkString else ""
    // ABC's assertion in `lutpack` tests a pointer's bits, so it fails now and then on the same netlist: run again
    var status = run()
    var attempt = 1
    while (status != 0 && abcAborted(logText) && attempt < abcAttempts) {
      println(s"orb.Report: Yosys's ABC aborted (an assertion that depends on memory addresses); running it again")
      status = run()
      attempt += 1
    }
    if (status != 0) throw new RuntimeException(s"yosys failed (status $status); see ${log.getPath}")
    val alone = new StringBuilder
    val s2 = Process(Seq("python3", "netlist.py", "les", "generic.json"), work).!(ProcessLogger(
      l => alone ++= l + "\n",
      l => alone ++= l + "\n"
    ))
    if (s2 != 0) throw new RuntimeException(s"netlist.py les failed (needs python3): $alone")
    (scala.io.Source.fromFile(new File(work, "stat.txt")).mkString, parseAlone(alone.toString))
  }
}
