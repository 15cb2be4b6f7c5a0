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

  /** The last `n` values of `v` (element 0 = `v` itself), advancing only on valid pixels: the horizontal extent of
    * a window, whatever the blanking. */
  def lastValid[T <: Data](v: T, n: Int, valid: Bool): Vec[T] = History[T](v, n, valid, null.asInstanceOf[T])

  /** Arithmetic shift right (floor), written as a slice so that the Verilog has no width-changing shift. */
  def floorShift(v: SInt, n: Int): SInt = if (n == 0) v else v(v.high downto n)
  def floorShift(v: UInt, n: Int): UInt = if (n == 0) v else v(v.high downto n)
}
