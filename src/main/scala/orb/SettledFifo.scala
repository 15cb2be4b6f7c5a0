package orb

import spinal.core._
import spinal.lib._

/** A queue in one RAM for a consumer that takes an item every few clocks at most: the RAM's read port and its output
  * register are always enabled, reading the head at the read pointer every clock, so no enable pin waits for the
  * consumer's readiness (a `StreamFifo` enables its read from the pop's handshake). The head is offered once the
  * pointer has stood still for two clocks with the head written: a pop every third clock at most, two clocks of
  * latency more than a register. */
class SettledFifo[T <: Data](payloadType: HardType[T], depth: Int) extends Component {
  require(depth >= 2)
  val io = new Bundle {
    val push = slave Stream (payloadType())
    val pop = master Stream (payloadType())
  }
  val ram = Mem(payloadType(), depth)

  /** a place in the RAM and whether the pointer has wrapped an odd number of times */
  case class Pointer() extends Area {
    val at = Reg(UInt(log2Up(depth) bits)) init 0
    val lap = Reg(Bool()) init False
    def step(): Unit = {
      when(at === depth - 1) {
        at := 0
        lap := !lap
      } otherwise {
        at := at + 1
      }
    }
  }
  val write = Pointer()
  val read = Pointer()
  val empty = write.at === read.at && write.lap === read.lap
  val full = write.at === read.at && write.lap =/= read.lap
  io.push.ready := !full
  ram.write(write.at, io.push.payload, enable = io.push.fire)
  when(io.push.fire) {
    write.step()
  }
  val popped = io.pop.fire
  when(popped) {
    read.step()
  }
  // the RAM's output register and a plain register behind it (the block's output register), both always enabled
  val head = RegNext(ram.readSync(read.at))

  /** the head's place was read while it held the head (not empty, no pop), and registered a clock later */
  val reading = RegNext(!empty && !popped) init False
  val settled = RegNext(reading && !popped) init False
  io.pop.valid := settled
  io.pop.payload := head
}
