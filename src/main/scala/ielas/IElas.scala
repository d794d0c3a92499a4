package ielas

import chisel3._
import chisel3.util._

/** The accelerator top, as built so far: pixel input -> [[Descriptor]] -> descriptor stream.
  *
  * Frame size check (INTERFACES.md §4): a start of frame whose frameWidth/frameHeight lie outside
  * 32x16..maxWidth x maxHeight raises the sticky `error` bit (cleared by reset or a one-cycle `clearError`) and the
  * whole frame is dropped up to the next start of frame. Line-length and line-count checks come with the later
  * stages.
  */
class IElas(p: ElasParams) extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PixelPair))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val error = Output(Bool())
    val clearError = Input(Bool())
    val out = Decoupled(new Framed(new DescriptorPair(p.descriptorBytes)))
  })

  val descriptor = Module(new Descriptor(p))

  val error = RegInit(false.B)
  val dropping = RegInit(false.B) // inside a frame whose size was illegal
  val sof = io.in.valid && io.in.bits.sof
  val illegalSize = !FrameSize.isLegal(p, io.frameWidth, io.frameHeight)
  val drop = Mux(sof, illegalSize, dropping)

  when(io.clearError) { error := false.B }
  when(sof && illegalSize) { error := true.B }
  when(io.in.fire) { dropping := drop }

  descriptor.io.in.valid := io.in.valid && !drop
  descriptor.io.in.bits := io.in.bits
  io.in.ready := drop || descriptor.io.in.ready
  descriptor.io.frameWidth := io.frameWidth
  descriptor.io.frameHeight := io.frameHeight
  io.out <> descriptor.io.out
  io.error := error
}

object IElas {
  def memorySummary(p: ElasParams): Seq[MemoryUse] = Descriptor.memorySummary(p)

  /** The top's no-stall bound N + latencyRows * W + cycleSlack (INTERFACES.md §4); the sweep's cycle model reads
    * these (`Main config`), so they must follow the stages wired in here.
    */
  def latencyRows(p: ElasParams): Int = Descriptor.latencyRows(p)
  def cycleSlack(p: ElasParams): Int = Descriptor.cycleSlack(p)
}
