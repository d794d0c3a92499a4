package ielas

import chisel3._
import chisel3.util._

// Building blocks instantiated many times. Each is its own module so that the synthesis flow (docs/synthesis.md)
// synthesises a replicated block once and counts it per instance.

/** Sum of |x_k - y_k| over the bytes of two descriptors. One subtractor per byte: for a negative difference d, the
  * low 8 bits of d inverted are |d| - 1, so the sum adds the inverted bytes plus the count of negative ones (no
  * compare, no second subtractor, no mux).
  */
class DescriptorSad(descriptorBytes: Int) extends Module {
  val io = IO(new Bundle {
    val x = Input(UInt((8 * descriptorBytes).W))
    val y = Input(UInt((8 * descriptorBytes).W))
    val sad = Output(UInt(DescriptorSad.bits(descriptorBytes).W))
  })
  private val diffs = (0 until descriptorBytes).map(k => io.x(8 * k + 7, 8 * k).zext - io.y(8 * k + 7, 8 * k).zext)
  private val signs = diffs.map(_(8))
  private val mags = diffs.zip(signs).map { case (d, neg) => d(7, 0).asUInt ^ Fill(8, neg) }
  io.sad := VecInit(mags).reduceTree(_ +& _) +& PopCount(signs)
}

object DescriptorSad {
  /** Bits of a SAD: descriptorBytes x 255 (12 bits for 16 bytes). */
  def bits(descriptorBytes: Int): Int = log2Ceil(descriptorBytes * 255 + 1)
}
