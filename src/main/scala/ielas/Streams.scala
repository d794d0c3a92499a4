package ielas

import chisel3._

/** One beat of the stereo pixel input, AXI4-Stream video style (INTERFACES.md §4):
  * tdata = {left, right}, tuser(0) = start of frame (first pixel), tlast = end of line (last pixel of each line).
  */
class PixelPair extends Bundle {
  val left = UInt(8.W)
  val right = UInt(8.W)
  /** tuser(0): start of frame. */
  val sof = Bool()
  /** tlast: end of line. */
  val eol = Bool()
}

/** A raster-order output beat with the same framing as the input plus tuser(1) = end of frame. */
class Framed[T <: Data](gen: T) extends Bundle {
  val data = gen
  val sof = Bool()
  val eol = Bool()
  /** tuser(1): last pixel of the frame. */
  val eof = Bool()
}

/** The descriptors of both views at one pixel. Byte k of a descriptor sits at bits 8k+7..8k (byte 0 = LSBs), so a
  * testbench reads a whole descriptor with one peek.
  */
class DescriptorPair(bytes: Int) extends Bundle {
  val left = UInt((8 * bytes).W)
  val right = UInt((8 * bytes).W)
}

/** The frame size ports (frameWidth, frameHeight) are sampled at start of frame. */
object FrameSize {
  /** The legal frame size range (INTERFACES.md §1): 32x16 up to the configuration's maximum. */
  val minWidth = 32
  val minHeight = 16

  def isLegal(p: ElasParams, width: UInt, height: UInt): Bool =
    width >= minWidth.U && width <= p.maxWidth.U && height >= minHeight.U && height <= p.maxHeight.U
}
