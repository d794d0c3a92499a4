package ielas

import chisel3._
import org.scalatest.flatspec.AnyFlatSpec

import scala.util.Random

/** The top's block-RAM queue on its own, at depths that wrap its pointers often (7, 40): seeded random values
  * streamed through under random input gaps and output back-pressure come out complete and in order (expected: the
  * input sequence itself); without stalls a beat leaves every clock; with the output stalled it takes at least
  * `entries` beats before `in.ready` falls, and `in.ready` does not follow `out.ready` within a cycle (a register).
  */
class BlockQueueSpec extends AnyFlatSpec {
  import StreamTester._

  behavior of "BlockQueue"

  for (entries <- Seq(7, 40)) {
    it should s"pass every beat in order, one per clock without stalls, and hold $entries beats (entries = $entries)" in {
      val rnd = new Random(seed + entries)
      simulate(new BlockQueue(UInt(16.W), entries), tmpDir(s"BlockQueueSpec$entries")) { dut =>
        reset(dut)
        checkPassThrough(dut.clock, dut.io.in, dut.io.out, rnd, noStallSlack = 4, drain = 5, "queue")
        // capacity: with the output stalled, every one of `entries` beats is taken
        poke(dut.io.out.ready, false)
        poke(dut.io.in.valid, true)
        var taken = 0
        var cycles = 0
        while (peek(dut.io.in.ready) && cycles < 4 * entries) {
          poke(dut.io.in.bits, BigInt(taken))
          step(dut.clock); taken += 1; cycles += 1
        }
        assert(taken >= entries, s"a stalled queue of $entries entries took only $taken beats")
        poke(dut.io.in.valid, false)
        val readyBefore = peek(dut.io.in.ready)
        poke(dut.io.out.ready, true)
        assert(peek(dut.io.in.ready) == readyBefore, "in.ready followed out.ready within the cycle")
        // what was taken comes out in order
        var next = 0
        cycles = 0
        while (next < taken && cycles < 4 * entries + 10) {
          if (peek(dut.io.out.valid)) {
            assert(peek(dut.io.out.bits) == BigInt(next), s"beat $next came out as ${peek(dut.io.out.bits)}")
            next += 1
          }
          step(dut.clock); cycles += 1
        }
        assert(next == taken, s"only $next of $taken stalled beats came out")
      }
    }
  }
}
