package ielas

import chisel3._
import chisel3.util._

/** A read-first `Mem` of `width`-bit words stored as bit slices, each no wider than an 18-kbit block RAM is at this
  * depth.
  *
  * Both families the project maps to have the same block shapes (ECP5 DP16KD, 7-series RAMB18: 16k x 1, 8k x 2,
  * 4k x 4, 2k x 9, 1k x 18, 512 x 36). Yosys may build a deep, wide memory from blocks stacked in depth (the
  * descriptor's 1242 x 96-bit line buffer: 3 x 3 blocks of 512 x 36), so a read passes a multiplexer across the blocks.
  * Cut into slices as wide as a block is at that depth, each slice is one block deep and the word leaves the blocks
  * with no multiplexer (that buffer: 11 blocks of 2k x 9). Slices are balanced in width (11 bits: 4, 4, 3). Every
  * slice sees the same addresses and enables, so the whole behaves as one `Mem` of this shape.
  */
class SlicedMem(depth: Int, width: Int, name: String) {
  private val count = (width + SlicedMem.blockWidth(depth) - 1) / SlicedMem.blockWidth(depth)
  /** The slices' widths, least significant first. */
  val widths: Seq[Int] = Seq.tabulate(count)(i => width / count + (if (i < width % count) 1 else 0))
  private val lows = widths.scanLeft(0)(_ + _).init
  /** The slices. */
  val mems: Seq[Mem[UInt]] = widths.zipWithIndex.map { case (w, i) =>
    Mem(depth, UInt(w.W)).suggestName(if (count == 1) name else s"${name}_s$i")
  }

  /** The combinational read (before this clock's write). */
  def read(addr: UInt): UInt = Cat(mems.reverse.map(_.read(addr)))

  def write(addr: UInt, data: UInt): Unit =
    mems.zip(widths.zip(lows)).foreach { case (m, (w, lo)) => m.write(addr, data(lo + w - 1, lo)) }
}

object SlicedMem {
  /** The widest word an 18-kbit block RAM holds at `depth` words. */
  def blockWidth(depth: Int): Int =
    Seq(512 -> 36, 1024 -> 18, 2048 -> 9, 4096 -> 4, 8192 -> 2).collectFirst { case (d, w) if depth <= d => w }.getOrElse(1)
}
