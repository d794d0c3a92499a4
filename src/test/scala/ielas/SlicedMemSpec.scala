package ielas

import chisel3._
import chisel3.util._
import org.scalatest.flatspec.AnyFlatSpec

import scala.util.Random

/** A memory as bit slices behaves as one memory of its full width: seeded random writes and reads against a plain
  * array (a `Mem` reads combinationally and before the clock's write; a `SyncReadMem` read returns the next clock),
  * at shapes that are cut into 3 slices. The slice widths are checked against the block shapes by hand.
  */
class SlicedMemSpec extends AnyFlatSpec {
  import StreamTester._

  class Harness(depth: Int, width: Int, syncRead: Boolean) extends Module {
    val io = IO(new Bundle {
      val wen = Input(Bool()); val waddr = Input(UInt(log2Ceil(depth).W)); val wdata = Input(UInt(width.W))
      val raddr = Input(UInt(log2Ceil(depth).W)); val rdata = Output(UInt(width.W))
    })
    val mem = new SlicedMem(depth, width, syncRead, "mem")
    when(io.wen) { mem.write(io.waddr, io.wdata) }
    io.rdata := mem.read(io.raddr)
  }

  behavior of "SlicedMem"

  it should "cut a word into slices as wide as an 18-kbit block is at the depth, balanced" in {
    assert(Seq(512, 513, 1024, 1025, 2048, 3726, 4096, 8192, 8193, 20000).map(SlicedMem.blockWidth) ==
      Seq(36, 18, 18, 9, 9, 4, 4, 2, 1, 1))
  }

  for (syncRead <- Seq(false, true)) {
    val (depth, width) = (3000, 11) // 4k x 4 blocks: slices of 4, 4 and 3 bits
    it should s"read what was written, as one ${if (syncRead) "SyncReadMem" else "Mem"} of ${depth}x$width" in {
      val rnd = new Random(seed + (if (syncRead) 1 else 0))
      simulate(new Harness(depth, width, syncRead), tmpDir(s"SlicedMemSpec-$syncRead")) { dut =>
        assert(dut.mem.widths == Seq(4, 4, 3))
        val model = Array.fill[BigInt](depth)(0)
        // every word written once first (power-up contents are not defined), then random traffic
        poke(dut.io.wen, true)
        for (a <- 0 until depth) {
          val v = BigInt(width, rnd); model(a) = v
          poke(dut.io.waddr, BigInt(a)); poke(dut.io.wdata, v); step(dut.clock)
        }
        var pending: Option[BigInt] = None // a SyncReadMem read issued last clock
        var checked = 0
        for (_ <- 0 until 20000) {
          val (wen, waddr, wdata) = (rnd.nextInt(3) == 0, rnd.nextInt(depth), BigInt(width, rnd))
          // a SyncReadMem read of the address written in the same clock is left undefined: not issued
          var raddr = rnd.nextInt(depth)
          if (syncRead && wen && raddr == waddr) raddr = (raddr + 1) % depth
          poke(dut.io.wen, wen); poke(dut.io.waddr, BigInt(waddr)); poke(dut.io.wdata, wdata)
          poke(dut.io.raddr, BigInt(raddr))
          if (syncRead) {
            pending.foreach { want => assert(peek(dut.io.rdata) == want); checked += 1 }
            pending = Some(model(raddr))
          } else {
            assert(peek(dut.io.rdata) == model(raddr), s"read of $raddr"); checked += 1
          }
          if (wen) model(waddr) = wdata
          step(dut.clock)
        }
        assert(checked >= 19999)
      }
    }
  }
}
