package ielas

import chisel3._
import chisel3.util._

/** A memory of `width`-bit words stored as bit slices, each no wider than an 18-kbit block RAM is at this depth.
  *
  * Both families the project maps to have the same block shapes (ECP5 DP16KD, 7-series RAMB18: 16k x 1, 8k x 2,
  * 4k x 4, 2k x 9, 1k x 18, 512 x 36). Yosys builds a memory deeper than 1k words at its full width from blocks
  * stacked in depth, so a read passes a multiplexer across the blocks and the address net reaches all of them. Cut
  * into slices as wide as a block is at that depth, each slice is one block deep: the word leaves the blocks with no
  * multiplexer, straight into the next address, and a depth a little above a power of two takes fewer blocks (3 x 1242
  * words of 11 bits: three 4k x 4 blocks instead of four 1k x 18). Slices are balanced in width (11 bits: 4, 4, 3).
  * Every slice sees the same addresses and enables, so the whole behaves as one memory (the same read-under-write
  * as a single `Mem` or `SyncReadMem` of this shape).
  */
class SlicedMem(depth: Int, width: Int, syncRead: Boolean, name: String) {
  private val count = (width + SlicedMem.blockWidth(depth) - 1) / SlicedMem.blockWidth(depth)
  /** The slices' widths, least significant first. */
  val widths: Seq[Int] = Seq.tabulate(count)(i => width / count + (if (i < width % count) 1 else 0))
  private val lows = widths.scanLeft(0)(_ + _).init
  private def sliceName(i: Int) = if (count == 1) name else s"${name}_s$i"
  private val mems: Seq[Either[Mem[UInt], SyncReadMem[UInt]]] = widths.zipWithIndex.map { case (w, i) =>
    if (syncRead) Right(SyncReadMem(depth, UInt(w.W)).suggestName(sliceName(i)))
    else Left(Mem(depth, UInt(w.W)).suggestName(sliceName(i)))
  }

  /** A `Mem`'s combinational read, or a `SyncReadMem`'s read (data the next clock). */
  def read(addr: UInt): UInt = Cat(mems.reverse.map(_.fold(_.read(addr), _.read(addr))))

  def write(addr: UInt, data: UInt): Unit =
    mems.zip(widths.zip(lows)).foreach { case (m, (w, lo)) =>
      val part = data(lo + w - 1, lo)
      m.fold(_.write(addr, part), _.write(addr, part))
    }
}

object SlicedMem {
  /** The widest word an 18-kbit block RAM holds at `depth` words. */
  def blockWidth(depth: Int): Int =
    Seq(512 -> 36, 1024 -> 18, 2048 -> 9, 4096 -> 4, 8192 -> 2).collectFirst { case (d, w) if depth <= d => w }.getOrElse(1)
}
