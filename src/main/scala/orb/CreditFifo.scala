package orb

import spinal.core._
import spinal.lib._

/** A queue in one RAM that reads ahead into a few registers (`buffer` places), as many words as it has places not yet
  * promised (its credits): every read decision comes from registers (the count's emptiness and the credits), never
  * from the consumer's readiness, so no handshake reaches the RAM's pointers in the clock it is decided (a
  * `StreamFifo` steps its read pointer from the pop's handshake, through its address stage). The read port is always
  * enabled at the read pointer (a register), its data through a plain register (the RAM's output register) into the
  * places, a ring of registers. A word takes four clocks from its read to the credit it frees, so `buffer` places
  * serve a consumer that takes one every `4 / buffer` clocks. The RAM's and the ring's pointers and counts are each a
  * `QueueFill` (full and empty registers, as in `SettledFifo`). `flush` empties it all; `io.held` (reads in flight)
  * and `io.placed` (words in the places) show what it holds beside the RAM's words (`io.stored`), for counting what a
  * flush drops. */
class CreditFifo[T <: Data](payloadType: HardType[T], depth: Int, val buffer: Int = 3) extends Component {
  require(depth >= 2 && buffer >= 2)
  val io = new Bundle {
    val push = slave Stream (payloadType())
    val pop = master Stream (payloadType())
    val flush = in Bool ()
    val stored = out UInt (log2Up(depth + 1) bits)
    val held = out Bits (2 bits)
    val placed = out UInt (log2Up(buffer + 1) bits)
  }
  val ram = Mem(payloadType(), depth)
  val fill = new QueueFill(depth)
  val credits = Reg(UInt(log2Up(buffer + 1) bits)) init buffer

  io.push.ready := !fill.full
  val pushed = io.push.fire
  ram.write(fill.writeAt, io.push.payload, enable = pushed)
  // a read when a word is stored and a place is free for it, from registers alone
  val read = !fill.empty && credits =/= 0
  fill.step(pushed, read)

  // the read's word a clock later from the RAM, a clock after that from its output register
  val data = RegNext(ram.readSync(fill.readAt))
  val reading = RegNext(read) init False
  val arriving = RegNext(reading) init False

  // the places in a ring with pointers and a count of their own (an arriving word is written where the ring's write
  // pointer points: an enable, no selection before the places; the head is the place its read pointer picks)
  val places = Vec(Reg(payloadType()), buffer)
  val ring = new QueueFill(buffer)
  val popped = io.pop.fire
  io.pop.valid := !ring.empty
  io.pop.payload := places(ring.readAt)
  when(arriving) {
    places(ring.writeAt) := data
  }
  ring.step(arriving, popped)
  credits := credits - U(read) + U(popped)

  io.stored := fill.count
  io.placed := ring.count
  io.held := Cat(arriving, reading)

  when(io.flush) {
    fill.clear()
    credits := buffer
    reading := False
    arriving := False
    ring.clear()
  }
}
