package orb

import spinal.core._
import spinal.lib._

/** Small fixed-point helpers shared by the stages. */
object Arith {
  /** v * k for a constant k >= 0, as a sum of shifted copies of v (no multiplier block); `width` bits out. */
  def constMul(v: UInt, k: Int, width: Int): UInt = {
    require(k >= 0)
    val terms = (0 until 31).filter(b => ((k >> b) & 1) == 1).map(b => v.resize(width) |<< b)
    if (terms.isEmpty) U(0, width bits) else terms.reduceBalancedTree(_ + _)
  }

  /** `op` over `values` as a balanced tree with a plain register after every `perStage` levels, and registers
    * added at the end so that the result is exactly `stages` clocks late whatever the number of values. */
  def pipelinedTree[T <: Data](values: Seq[T], perStage: Int, stages: Int)(op: (T, T) => T): T = {
    require(values.nonEmpty && perStage >= 1)
    var level = values
    var depth = 0
    var registers = 0
    while (level.size > 1) {
      level = level.grouped(2).map(g => if (g.size == 2) op(g(0), g(1)) else g(0)).toSeq
      depth += 1
      if (depth % perStage == 0 && level.size > 1) {
        require(registers < stages, s"a tree of ${values.size} values needs more than $stages stages of $perStage levels")
        level = level.map(RegNext(_))
        registers += 1
      }
    }
    (registers until stages).foldLeft(level.head)((v, _) => RegNext(v))
  }

  /** The last `n` values of `v` (element 0 = `v` itself), advancing only on valid pixels: the horizontal extent of
    * a window, whatever the blanking. */
  def lastValid[T <: Data](v: T, n: Int, valid: Bool): Vec[T] = History[T](v, n, valid, null.asInstanceOf[T])

  /** Arithmetic shift right (floor), written as a slice so that the Verilog has no width-changing shift. */
  def floorShift(v: SInt, n: Int): SInt = if (n == 0) v else v(v.high downto n)
  def floorShift(v: UInt, n: Int): UInt = if (n == 0) v else v(v.high downto n)
}
