package orb

import spinal.core._
import spinal.lib._

/** A queue in one RAM that reads ahead into a few registers (`buffer` places), as many words as it has places not yet
  * promised (its credits): every read decision comes from registers (the count's emptiness and the credits), never
  * from the consumer's readiness, so no handshake reaches the RAM's pointers in the clock it is decided (a
  * `StreamFifo` steps its read pointer from the pop's handshake, through its address stage). The read port is always
  * enabled at the read pointer (a register), its data through a plain register (the RAM's output register) into the
  * places; the head is place 0, a register. A word takes four clocks from its read to the credit it frees, so
  * `buffer` places serve a consumer that takes one every `4 / buffer` clocks. Full and empty are registers, each set
  * from one comparison of the count register and the push and read, as in `SettledFifo`. `flush` empties it all;
  * `io.held` shows what it holds beside the RAM's words (`io.stored`), for counting what a flush drops. */
class CreditFifo[T <: Data](payloadType: HardType[T], depth: Int, buffer: Int = 3) extends Component {
  require(depth >= 2 && buffer >= 2)
  val io = new Bundle {
    val push = slave Stream (payloadType())
    val pop = master Stream (payloadType())
    val flush = in Bool ()
    val stored = out UInt (log2Up(depth + 1) bits)
    val held = out Bits (2 + buffer bits)
  }
  val ram = Mem(payloadType(), depth)
  val addressWidth = log2Up(depth)

  /** the next place after `at` (a power-of-two depth wraps by itself) */
  def after(at: UInt): UInt = if (isPow2(depth)) at + 1 else Mux(at === depth - 1, U(0, addressWidth bits), at + 1)
  val writeAt, readAt = Reg(UInt(addressWidth bits)) init 0
  val count = Reg(UInt(log2Up(depth + 1) bits)) init 0
  val full = RegInit(False)
  val empty = RegInit(True)
  val credits = Reg(UInt(log2Up(buffer + 1) bits)) init buffer

  io.push.ready := !full
  val pushed = io.push.fire
  ram.write(writeAt, io.push.payload, enable = pushed)
  when(pushed) {
    writeAt := after(writeAt)
  }

  // a read when a word is stored and a place is free for it, from registers alone
  val read = !empty && credits =/= 0
  when(read) {
    readAt := after(readAt)
  }
  // the count moves by one at most; full and empty change only where it moves onto or off its ends
  val up = pushed && !read
  val down = read && !pushed
  when(up) {
    count := count + 1
    full := count === depth - 1
    empty := False
  }
  when(down) {
    count := count - 1
    full := False
    empty := count === 1
  }

  // the read's word a clock later from the RAM, a clock after that from its output register
  val data = RegNext(ram.readSync(readAt))
  val reading = RegNext(read) init False
  val arriving = RegNext(reading) init False

  // the places: place 0 is the head; the used ones are contiguous from it; a pop moves the others on by one, and an
  // arriving word takes the first place free after the move
  val places = Vec(Reg(payloadType()), buffer)
  val used = Vec(RegInit(False), buffer)
  val popped = io.pop.fire
  io.pop.valid := used(0)
  io.pop.payload := places(0)
  for (i <- 0 until buffer) {
    val next = if (i + 1 < buffer) used(i + 1) else False
    val previous = if (i == 0) True else used(i - 1)
    val takes = arriving && Mux(popped, used(i) && !next, !used(i) && previous)
    when(takes) {
      places(i) := data
    } elsewhen (popped) {
      if (i + 1 < buffer) places(i) := places(i + 1)
    }
    used(i) := takes || Mux(popped, next, used(i))
  }
  credits := credits - U(read) + U(popped)

  io.stored := count
  io.held := Cat(used.asBits, arriving, reading)

  when(io.flush) {
    writeAt := 0
    readAt := 0
    count := 0
    full := False
    empty := True
    credits := buffer
    reading := False
    arriving := False
    used.foreach(_ := False)
  }
}
