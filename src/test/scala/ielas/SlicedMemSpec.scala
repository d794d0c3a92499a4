package ielas

import chisel3._
import chisel3.util._
import org.scalatest.flatspec.AnyFlatSpec

import scala.util.Random

/** A memory as bit slices behaves as one `Mem` of its full width (a read is combinational and sees the memory before
  * the clock's write): seeded random writes and reads against a plain array, at 3000 x 11 (slices 4, 4, 3) and at the
  * descriptor line buffer's kitti shape, 1242 x 96 (eight slices of 9 bits and three of 8). The slice widths are
  * checked against the block shapes by hand.
  */
class SlicedMemSpec extends AnyFlatSpec {
  import StreamTester._

  class Harness(depth: Int, width: Int) extends Module {
    val io = IO(new Bundle {
      val wen = Input(Bool()); val waddr = Input(UInt(log2Ceil(depth).W)); val wdata = Input(UInt(width.W))
      val raddr = Input(UInt(log2Ceil(depth).W)); val rdata = Output(UInt(width.W))
    })
    val mem = new SlicedMem(depth, width, "mem")
    when(io.wen) { mem.write(io.waddr, io.wdata) }
    io.rdata := mem.read(io.raddr)
  }

  behavior of "SlicedMem"

  it should "cut a word into slices as wide as an 18-kbit block is at the depth, balanced" in {
    assert(Seq(512, 513, 1024, 1025, 2048, 3726, 4096, 8192, 8193, 20000).map(SlicedMem.blockWidth) ==
      Seq(36, 18, 18, 9, 9, 4, 4, 2, 1, 1))
  }

  for (((depth, width), slices) <- Seq((3000, 11) -> Seq(4, 4, 3), (1242, 96) -> (Seq.fill(8)(9) ++ Seq.fill(3)(8)))) {
    it should s"read what was written, as one Mem of ${depth}x$width" in {
      val rnd = new Random(seed + depth)
      simulate(new Harness(depth, width), tmpDir(s"SlicedMemSpec-$depth")) { dut =>
        assert(dut.mem.widths == slices)
        val model = Array.fill[BigInt](depth)(0)
        // every word written once first (power-up contents are not defined), then random traffic
        poke(dut.io.wen, true)
        for (a <- 0 until depth) {
          val v = BigInt(width, rnd); model(a) = v
          poke(dut.io.waddr, BigInt(a)); poke(dut.io.wdata, v); step(dut.clock)
        }
        for (_ <- 0 until 20000) {
          val (wen, waddr, wdata, raddr) = (rnd.nextInt(3) == 0, rnd.nextInt(depth), BigInt(width, rnd), rnd.nextInt(depth))
          poke(dut.io.wen, wen); poke(dut.io.waddr, BigInt(waddr)); poke(dut.io.wdata, wdata)
          poke(dut.io.raddr, BigInt(raddr))
          assert(peek(dut.io.rdata) == model(raddr), s"read of $raddr")
          if (wen) model(waddr) = wdata
          step(dut.clock)
        }
      }
    }
  }
}
