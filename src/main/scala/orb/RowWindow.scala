package orb

import spinal.core._
import spinal.lib._

/** @param rows      rows seen at once: the current one plus `rows - 1` stored ones
  * @param maxWidth  pixels per line, the depth of the memory
  * @param dataWidth bits per pixel */
case class RowWindowConfig(rows: Int, maxWidth: Int, dataWidth: Int) {
  require(rows >= 2, "a row window needs at least one stored row")
  require(maxWidth >= 2 && dataWidth >= 1)
  def addrWidth: Int = log2Up(maxWidth)
  def storedBits: Int = (rows - 1) * dataWidth
}

/** A window of the last `rows` image rows, one column per pixel, in one RAM with synchronous reads.
  *
  * Word `x` of the RAM holds the column of the `rows - 1` previous rows at x. A pixel reads its column; the read
  * data go through a plain register (the RAM block's output register), and the column, with the new pixel on top
  * and the oldest dropped, is written back from there, two clocks after the read. Pixels two clocks apart have
  * different x unless a line is one or two pixels long, and such a frame is either faulty or too narrow for any
  * corner, so its output is never used.
  * One wide RAM instead of one per row: the same M4K count, one address counter, and every reader of the column
  * (Harris now, the descriptor later) shares the same rows. */
class RowWindow(val c: RowWindowConfig) extends Area {
  val ram = Mem(Bits(c.storedBits bits), c.maxWidth)

  /** Pushes `pixel` at column `x` when `fire`; returns, `RowWindow.latency` clocks later, the column: element 0 is
    * that pixel, element r the pixel r rows above it. */
  def column(fire: Bool, x: UInt, pixel: Bits): Vec[Bits] = {
    val stored = RegNext(ram.readSync(x.resize(c.addrWidth), fire))
    // After a fault x saturates at maxWidth: such a pixel is never stored (its frame's output is void anyway).
    val fireD = Delay(fire && x < c.maxWidth, RowWindow.latency, init = False)
    val xD = Delay(x.resize(c.addrWidth), RowWindow.latency)
    val col = Vec(Bits(c.dataWidth bits), c.rows)
    col(0) := Delay(pixel, RowWindow.latency)
    for (r <- 1 until c.rows) col(r) := stored((r - 1) * c.dataWidth, c.dataWidth bits)
    ram.write(xD, Vec(col.take(c.rows - 1)).asBits, fireD) // element 0 (the newest row) in the low bits
    col
  }
}

object RowWindow {

  /** clocks from a pixel to its column: the RAM read and its output register */
  val latency = 2
}

/** The shared raw-image line buffer: every reader taps the rows it needs from one column. Latency:
  * `RowWindow.latency`. */
class LineBuffer(f: FrameConfig, rows: Int) extends Component {
  val io = new Bundle {
    val pixels = slave Flow (TrackedPixel(f))
    val columns = master Flow (LineColumn(f, rows))
  }
  val window = new RowWindow(RowWindowConfig(rows, f.maxWidth, 8))
  val col = window.column(io.pixels.valid, io.pixels.x, io.pixels.luma.asBits)
  io.columns.valid := Delay(io.pixels.valid, RowWindow.latency, init = False)
  io.columns.pixel := Delay(io.pixels.payload, RowWindow.latency)
  for (r <- 0 until rows) io.columns.column(r) := col(r).asUInt
}
