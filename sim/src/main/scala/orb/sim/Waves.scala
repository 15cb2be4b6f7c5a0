package orb.sim

import orb.OrbTop
import spinal.core._

import java.io.{File, PrintWriter}

/** A GTKWave save file for `Match --wave`: the pipeline's signals, one group per stage, named as Verilator writes
  * them into the FST (TOP.OrbTop.<instance path>.<signal>[msb:0]). */
object Waves {
  def groups(top: OrbTop): Seq[(String, Seq[BaseType])] = {
    def flat(d: Data): Seq[BaseType] = d.flatten.toSeq
    val m = top.matcher
    Seq(
      "1 camera pixels" -> flat(top.io.pixels),
      "2 frame tracker" -> flat(top.core.tracker.io.tracked),
      "3 Harris corners" -> (flat(top.core.harris.io.corners) ++ flat(top.core.harris.io.control)),
      "4 feature budget (selected corners)" -> (flat(top.core.budget.io.selected) ++ Seq(
        top.core.budget.io.deselected
      )),
      "5 orientation" -> flat(top.core.orientation.io.oriented),
      "6 descriptors (feature stream)" -> flat(top.core.io.features),
      "7 matcher" -> (Seq(m.activity, m.decide.done) ++ flat(m.compare.acc) ++ flat(m.scan.live)),
      "8 correspondences" -> flat(top.io.correspondences),
      "9 registers (Avalon-MM)" -> flat(top.io.ctrl)
    )
  }

  /** TOP.OrbTop.core.harris.io_corners_valid and the like. */
  def fstName(s: BaseType): String = {
    val path =
      if (s.component.parent == null) Nil else s.component.parents().drop(1).map(_.getName()) :+ s.component.getName()
    val scope = ("TOP" +: "OrbTop" +: path).mkString(".")
    val range = if (s.getBitsWidth > 1) s"[${s.getBitsWidth - 1}:0]" else ""
    s"$scope.${s.getName()}$range"
  }

  def writeGtkw(file: File, fst: File, top: OrbTop): Unit = {
    val w = new PrintWriter(file)
    try {
      w.println(s"""[dumpfile] "${fst.getAbsolutePath}"""")
      w.println("[timestart] 0")
      for ((name, signals) <- groups(top)) {
        w.println(s"@800200\n-$name")
        w.println("@28") // binary for 1-bit, below for buses
        for (s <- signals) {
          if (s.getBitsWidth > 1) w.println("@22") else w.println("@28")
          w.println(fstName(s))
        }
        w.println("@1000200\n-" + name)
      }
    } finally w.close()
  }
}
