package orb

import spinal.core._
import spinal.lib._
import orb.Pipes.delayApart

/** @param rows       rows seen at once: the current one plus `rows - 1` stored ones
  * @param maxWidth   pixels per line, the depth of the memory
  * @param dataWidth  bits per pixel
  * @param rowsPerRam stored rows per RAM (the last RAM takes what is left) */
case class RowWindowConfig(rows: Int, maxWidth: Int, dataWidth: Int, rowsPerRam: Int = Int.MaxValue) {
  require(rows >= 2, "a row window needs at least one stored row")
  require(maxWidth >= 2 && dataWidth >= 1 && rowsPerRam >= 1)
  def addrWidth: Int = log2Up(maxWidth)
  def storedRows: Int = rows - 1

  /** the stored rows of each RAM, oldest last */
  def ramRows: Seq[Range] = (0 until storedRows).grouped(rowsPerRam min storedRows).toSeq
}

/** A window of the last `rows` image rows, one column per pixel, in RAMs with synchronous reads.
  *
  * Word `x` of a RAM holds the column of its share of the `rows - 1` previous rows at x. A pixel reads its column;
  * the read data go through a plain register (the RAM block's output register), and the column, with the new pixel
  * on top and the oldest dropped, is written back from there, two clocks after the read. Pixels two clocks apart
  * have different x unless a line is one or two pixels long, and such a frame is either faulty or too narrow for
  * any corner, so its output is never used.
  * A few RAMs of several rows each (the same M4K count as one wide RAM when each RAM but the last fills whole
  * blocks), and each RAM has its own registers of the write's address and enable (one register would drive every block of
  * a wide RAM across the chip). */
class RowWindow(val c: RowWindowConfig) extends Area {
  val rams = c.ramRows.map(rs => Mem(Bits(rs.size * c.dataWidth bits), c.maxWidth))

  /** Pushes `pixel` at column `x` when `fire`; returns, `RowWindow.latency` clocks later, the column: element 0 is
    * that pixel, element r the pixel r rows above it. `readX`, if given, holds a copy of `x` per RAM but the first
    * (registers kept apart where `x` is made): each RAM's read address, so that no register drives every RAM. */
  def column(fire: Bool, x: UInt, pixel: Bits, readX: Seq[UInt] = Nil): Vec[Bits] = {
    require(readX.isEmpty || readX.size == rams.size - 1, "a copy of x per RAM but the first")
    val col = Vec(Bits(c.dataWidth bits), c.rows)
    col(0) := Delay(pixel, RowWindow.latency)
    val readAddresses = x +: (if (readX.isEmpty) Seq.fill(rams.size - 1)(x) else readX)
    for (((ram, rs), address) <- rams.zip(c.ramRows).zip(readAddresses)) {
      // read every clock (a column nobody fired for is never used): no enable drives every block
      val stored = RegNext(ram.readSync(address.resize(c.addrWidth)))
      for ((r, i) <- rs.zipWithIndex) col(r + 1) := stored(i * c.dataWidth, c.dataWidth bits)
    }
    // After a fault x saturates at maxWidth: such a pixel is never stored (its frame's output is void anyway).
    val stores = fire && x < c.maxWidth
    for (((ram, rs), address) <- rams.zip(c.ramRows).zip(readAddresses)) {
      // each RAM's write address and enable delayed in registers of its own (every one kept apart), the address
      // from the RAM's read address
      val fireD = delayApart(stores, RowWindow.latency, init = False)
      val xD = delayApart(address.resize(c.addrWidth), RowWindow.latency)
      // element r of the column goes one row down: the RAM's rows take the column's elements rs (the newest in the
      // low bits)
      ram.write(xD, Vec(rs.map(r => col(r))).asBits, fireD)
    }
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

    /** the pixels' x again, a copy per RAM but the first (`FrameTracker`'s `xCopies`, kept apart there) */
    val readX = in Vec (f.coord(), LineBuffer.readCopies(f, rows))
    val columns = master Flow (LineColumn(f, rows))
  }
  val window = new RowWindow(LineBuffer.windowConfig(f, rows))
  val col = window.column(io.pixels.valid, io.pixels.x, io.pixels.luma.asBits, io.readX.toList)
  io.columns.valid := Delay(io.pixels.valid, RowWindow.latency, init = False)
  io.columns.pixel := Delay(io.pixels.payload, RowWindow.latency)
  for (r <- 0 until rows) io.columns.column(r) := col(r).asUInt

  /** Fed by `tracker`: its tracked pixels and its copies of x (made for this buffer: `LineBuffer.readCopies`). */
  def follow(tracker: FrameTracker): Unit = {
    io.pixels << tracker.io.tracked
    io.readX := tracker.io.xCopies
  }
}

object LineBuffer {

  /** stored rows per RAM: 9 rows of 8 bits fill whole M4K blocks of 512 x 9 (72 bits), so the RAMs take no more
    * blocks than one wide RAM would */
  val rowsPerRam: Int = 9

  def windowConfig(f: FrameConfig, rows: Int): RowWindowConfig = RowWindowConfig(rows, f.maxWidth, 8, rowsPerRam)

  /** copies of the pixels' x the line buffer reads its RAMs with (one per RAM but the first): what its
    * `FrameTracker` makes (`xCopies`) */
  def readCopies(f: FrameConfig, rows: Int): Int = windowConfig(f, rows).ramRows.size - 1
}
