package ielas

import chisel3._
import chisel3.util._

// Building blocks that several stages instantiate. Each is its own module so that the synthesis flow
// (docs/synthesis.md) synthesises a replicated block once and counts it per instance.

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

/** out(j) = in((amount + j) mod n) for j < outputs, n a power of two: a log2(n)-stage barrel rotator, so that all
  * columns of a bank-interleaved window come from one rotation (n x width x log2 n two-way muxes) instead of one
  * n-way mux per column. Combinational.
  */
class BankRotator(n: Int, width: Int, outputs: Int) extends Module {
  require(n >= 1 && (n & (n - 1)) == 0, s"BankRotator: n = $n must be a power of two")
  require(outputs >= 1 && outputs <= n, s"BankRotator: outputs = $outputs must lie in 1..$n")
  val io = IO(new Bundle {
    val in = Input(Vec(n, UInt(width.W)))
    val amount = Input(UInt(math.max(1, log2Ceil(n)).W))
    val out = Output(Vec(outputs, UInt(width.W)))
  })
  private val rotated = (0 until log2Ceil(n)).foldLeft(io.in.toSeq: Seq[UInt]) { (cur, s) =>
    (0 until n).map(j => Mux(io.amount(s), cur((j + (1 << s)) % n), cur(j)))
  }
  for (j <- 0 until outputs) io.out(j) := rotated(j)
}

/** sadOut = sad(d) and legalOut = legal(d), d < dispMax + 1: one candidate lane's lookup into the costs of every
  * disparity. Combinational.
  */
class CostLookup(dispMax: Int, sadBits: Int) extends Module {
  val io = IO(new Bundle {
    val sad = Input(Vec(dispMax + 1, UInt(sadBits.W)))
    val legal = Input(Vec(dispMax + 1, Bool()))
    val d = Input(UInt(log2Ceil(dispMax + 1).W))
    val sadOut = Output(UInt(sadBits.W))
    val legalOut = Output(Bool())
  })
  io.sadOut := io.sad(io.d)
  io.legalOut := io.legal(io.d)
}
