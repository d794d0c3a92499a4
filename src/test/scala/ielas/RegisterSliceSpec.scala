package ielas

import chisel3._
import org.scalatest.flatspec.AnyFlatSpec

import scala.util.Random

/** The stage boundary of the top on its own: seeded random values streamed through under random input gaps and
  * output back-pressure come out complete and in order (expected: the input sequence itself); with no stalls a beat
  * leaves every clock; and `in.ready` and `out.valid` do not change within a cycle when the other side's `out.ready`
  * or `in.valid` does (they are registers, which is what the top puts the slice there for).
  */
class RegisterSliceSpec extends AnyFlatSpec {
  import StreamTester._

  behavior of "RegisterSlice"

  it should "pass every beat in order under gaps and back-pressure, one per clock without stalls, with registered handshakes" in {
    val rnd = new Random(seed)
    simulate(new RegisterSlice(UInt(16.W)), tmpDir("RegisterSliceSpec")) { dut =>
      reset(dut)
      checkPassThrough(dut.clock, dut.io.in, dut.io.out, rnd, noStallSlack = 2, drain = 3, "slice")
      // registered handshakes: fill the slice (output stalled), then toggle the other side within one cycle
      poke(dut.io.out.ready, false)
      poke(dut.io.in.valid, true)
      poke(dut.io.in.bits, BigInt(1))
      step(dut.clock, 2) // the output register and the held register are full now
      poke(dut.io.in.valid, false)
      val readyBefore = peek(dut.io.in.ready)
      val validBefore = peek(dut.io.out.valid)
      assert(!readyBefore && validBefore, "a stalled, full slice must not be ready and must offer its beat")
      poke(dut.io.out.ready, true)
      assert(peek(dut.io.in.ready) == readyBefore, "in.ready followed out.ready within the cycle")
      poke(dut.io.in.valid, true)
      assert(peek(dut.io.out.valid) == validBefore, "out.valid followed in.valid within the cycle")
      step(dut.clock)
      assert(peek(dut.io.in.ready), "the held beat moved on: the slice takes input again")
    }
  }
}
