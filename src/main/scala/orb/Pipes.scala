package orb

import spinal.core._
import spinal.lib._
import spinal.lib.misc.pipeline.StagePipeline

/** Registers shaped for timing. */
object Pipes {

  /** A status count of the clocks `inc` is high, counted a clock late: the increment registered first, so no
    * handshake reaches the counter's enables. */
  def lateCounter(f: FrameConfig, inc: Bool): UInt = {
    val c = Reg(f.counter()) init 0
    when(RegNext(inc) init False) {
      c := c + 1
    }
    c
  }

  /** `r`, a register, kept apart: the Verilog attribute `preserve` (which Quartus honours, and the proxy's Yosys
    * flows too) stops synthesis from merging it with an identical register, so each copy of a value stays beside
    * the logic it drives. */
  def keptApart[T <: Data](r: T): T = {
    r.addAttribute("preserve")
    r
  }

  /** `v` through `n` registers, each kept apart: the blocks fed by the same stream (the line buffer's columns) would
    * otherwise have identical delay registers, which synthesis merges into one, so that one block's enables come
    * from another block's register across the chip. */
  def delayApart[T <: Data](v: T, n: Int, init: T = null.asInstanceOf[T]): T =
    (0 until n).foldLeft(v) { (x, _) =>
      val r = RegNext(x)
      if (init != null) r.init(init)
      keptApart(r)
    }

  /** Every stage's valid register of a built `pipeline` kept apart, for the same reason as `delayApart`: the stage
    * valids of two pipelines fed by the same stream are identical registers. */
  def keepValidsApart(pipeline: StagePipeline): Unit =
    pipeline.nodes.values.map(_.valid).filter(_.isReg).foreach(keptApart(_))

  /** `in.halfPipe()` (a beat every other clock, the ready the valid register's complement) whose payload is loaded by
    * its own copy of the "empty" flag (kept apart): the valid register drives the handshake only. A `flush` empties
    * it (what it takes in that clock too). */
  def halfPipe[T <: Data](in: Stream[T], flush: Bool = null): Stream[T] = {
    val out = Stream(cloneOf(in.payload))
    val valid = RegInit(False)
    when(in.valid) {
      valid := True
    }
    when(out.fire) {
      valid := False
    }
    if (flush != null) {
      when(flush) {
        valid := False
      }
    }
    val payload = Reg(cloneOf(in.payload))
    val empty = keptApart(RegNext(!valid.getAheadValue()) init True)
    when(empty) {
      payload := in.payload
    }
    in.ready := !valid
    out.valid := valid
    out.payload := payload
    out
  }

}
