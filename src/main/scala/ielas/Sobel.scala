package ielas

import chisel3._

/** The 3x3 Sobel of docs/ALGORITHM.md (descriptor, step 1) as combinational functions: integer, arithmetic shift,
  * unsigned saturation. `window` holds columns x-1, x, x+1, each as rows (y-1, y, y+1) of 8-bit pixels.
  */
object Sobel {
  /** S = I(y-1) + 2 I(y) + I(y+1): 0..1020. */
  def smooth(col: Seq[UInt]): SInt = (col(0) +& (col(1) << 1) +& col(2)).zext
  /** T = I(y-1) - I(y+1): -255..255. */
  def diff(col: Seq[UInt]): SInt = col(0).zext -& col(2).zext

  /** sat_u8((v >> 2) + 128); >> on SInt is arithmetic, i.e. floor division by 4. */
  private def offsetSaturate(v: SInt): UInt = {
    val shifted = (v >> 2) +& 128.S
    Mux(shifted < 0.S, 0.U(8.W), Mux(shifted > 255.S, 255.U(8.W), shifted.asUInt(7, 0)))
  }

  /** du = sat_u8(((S(x-1) - S(x+1)) >> 2) + 128): left minus right. */
  def du(window: Seq[Seq[UInt]]): UInt = duOf(smooth(window(0)), smooth(window(2)))
  /** du from the column sums S(x-1), S(x+1) (a pipeline may register them per column). */
  def duOf(smoothLeft: SInt, smoothRight: SInt): UInt = offsetSaturate(smoothLeft -& smoothRight)

  /** dv = sat_u8(((T(x-1) + 2 T(x) + T(x+1)) >> 2) + 128): top minus bottom. */
  def dv(window: Seq[Seq[UInt]]): UInt = dvOf(window.map(diff))
  /** dv from the column differences T(x-1), T(x), T(x+1). */
  def dvOf(diffs: Seq[SInt]): UInt = offsetSaturate(diffs(0) +& (diffs(1) << 1) +& diffs(2))
}
