package ielas

import chisel3._
import chisel3.util._

// Building blocks instantiated many times. Each is its own module so that the synthesis flow (docs/synthesis.md)
// synthesises a replicated block once and counts it per instance.

/** Sum of |x_k - y_k| over the bytes of two descriptors. One subtractor per byte and no compare, no second
  * subtractor, no mux ([[DescriptorSad.sumOfDifferences]]).
  */
class DescriptorSad(descriptorBytes: Int) extends Module {
  val io = IO(new Bundle {
    val x = Input(UInt((8 * descriptorBytes).W))
    val y = Input(UInt((8 * descriptorBytes).W))
    val sad = Output(UInt(DescriptorSad.bits(descriptorBytes).W))
  })
  private val diffs = DescriptorSad.byteDifferences(io.x, io.y, descriptorBytes)
  io.sad := DescriptorSad.sumOfDifferences(diffs)
}

object DescriptorSad {
  /** Bits of a SAD: descriptorBytes x 255 (12 bits for 16 bytes). */
  def bits(descriptorBytes: Int): Int = log2Ceil(descriptorBytes * 255 + 1)

  /** x_k - y_k per byte, 9-bit two's complement. */
  def byteDifferences(x: UInt, y: UInt, bytes: Int): Seq[SInt] =
    (0 until bytes).map(k => x(8 * k + 7, 8 * k).zext - y(8 * k + 7, 8 * k).zext)

  /** Sum of |d_k|: for a negative d the low 8 bits inverted are |d| - 1, so the sum adds the inverted bytes plus the
    * count of negative ones. */
  def sumOfDifferences(diffs: Seq[SInt]): UInt = {
    val signs = diffs.map(_(8))
    val mags = diffs.zip(signs).map { case (d, neg) => d(7, 0).asUInt ^ Fill(8, neg) }
    VecInit(mags).reduceTree(_ +& _) +& PopCount(signs)
  }
}

/** A [[DescriptorSad]] cut in two by a register, for a pipeline whose subtracts fit beside a block RAM's read: this
  * half forms the byte differences (9 bits a byte, fewer than the two descriptors' 16), [[DifferencesSad]] sums their
  * magnitudes a clock later. The sum equals DescriptorSad's.
  */
class ByteDifferences(bytes: Int) extends Module {
  val io = IO(new Bundle {
    val x = Input(UInt((8 * bytes).W))
    val y = Input(UInt((8 * bytes).W))
    val diffs = Output(UInt((9 * bytes).W)) // byte k in bits 9k .. 9k + 8
  })
  io.diffs := Cat(DescriptorSad.byteDifferences(io.x, io.y, bytes).reverse.map(_.asUInt))
}

/** The second half of a cut [[DescriptorSad]]: the SAD from [[ByteDifferences]]' output. */
class DifferencesSad(bytes: Int) extends Module {
  val io = IO(new Bundle {
    val diffs = Input(UInt((9 * bytes).W))
    val sad = Output(UInt(DescriptorSad.bits(bytes).W))
  })
  io.sad := DescriptorSad.sumOfDifferences((0 until bytes).map(k => io.diffs(9 * k + 8, 9 * k).asSInt))
}
