package orb

import spinal.core._
import spinal.lib._

/** A queue in one RAM for a consumer that takes an item every few clocks at most: the RAM's read port and its output
  * register are always enabled, reading the head at the read pointer every clock, so no enable pin waits for the
  * consumer's readiness (a `StreamFifo` enables its read from the pop's handshake). The head is offered once the
  * pointer has stood still for three clocks with the head written: a pop every fourth clock at most, three clocks of
  * latency more than a register. Full and empty are registers, each set from one comparison of the count register
  * and the push and pop; the write goes to the RAM a clock after the push, from registers (address, data, enable),
  * so no logic lies before the RAM's write pins (synthesis takes the registers into the RAM's own). */
class SettledFifo[T <: Data](payloadType: HardType[T], depth: Int) extends Component {
  require(depth >= 2)
  val io = new Bundle {
    val push = slave Stream (payloadType())
    val pop = master Stream (payloadType())
  }
  val ram = Mem(payloadType(), depth)
  val fill = new QueueFill(depth)
  io.push.ready := !fill.full
  val pushed = io.push.fire
  val popped = io.pop.fire
  // the write a clock later, from registers
  val writing = RegNext(pushed) init False
  val writingAt = RegNext(fill.writeAt)
  val writingData = RegNext(io.push.payload)
  ram.write(writingAt, writingData, enable = writing)
  fill.step(pushed, popped)

  // the read address a plain copy of the pointer (the RAM's address register: no logic between the pointer's
  // register and the RAM), the RAM's output register and a plain register behind it (the block's output register),
  // all always enabled
  val address = RegNext(fill.readAt)
  val head = RegNext(ram.readSync(address))

  /** the pointer held the head (not empty, no pop) for the address, the read and the output register; a head pushed
    * into an empty queue is written a clock after the push, when `empty` falls, and read from the clock after */
  val settled = (0 until 3).foldLeft(!fill.empty && !popped)((held, _) => RegNext(held && !popped) init False)
  io.pop.valid := settled
  io.pop.payload := head
}

/** A queue's place in its RAM: the write and read pointers and the count of words, with full and empty as registers,
  * each set from one comparison of the count register where the count moves onto or off its ends. */
class QueueFill(depth: Int) extends Area {
  val addressWidth = log2Up(depth)

  /** the next place after `at` (a power-of-two depth wraps by itself) */
  def after(at: UInt): UInt = if (isPow2(depth)) at + 1 else Mux(at === depth - 1, U(0, addressWidth bits), at + 1)
  val writeAt, readAt = Reg(UInt(addressWidth bits)) init 0
  val count = Reg(UInt(log2Up(depth + 1) bits)) init 0
  val full = RegInit(False)
  val empty = RegInit(True)

  /** a word in (`in`) and out (`out`) in this clock: the count moves by one at most */
  def step(in: Bool, out: Bool): Unit = {
    when(in) {
      writeAt := after(writeAt)
    }
    when(out) {
      readAt := after(readAt)
    }
    when(in && !out) {
      count := count + 1
      full := count === depth - 1
      empty := False
    }
    when(out && !in) {
      count := count - 1
      full := False
      empty := count === 1
    }
  }

  /** empty again (a flush), overriding the clock's step */
  def clear(): Unit = {
    writeAt := 0
    readAt := 0
    count := 0
    full := False
    empty := True
  }
}
