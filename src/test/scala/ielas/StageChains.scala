package ielas

import chisel3._
import chisel3.util._

// The stage specs' devices under test: the pixel input through the stages up to the one a spec checks, wired as the
// top wires them. Test-only; `make simulate` and the top build their prefixes with [[Pipeline]].

/** Stage-test chain of the `descriptor` stage: pixel input -> [[Descriptor]], behind the frame size check the
  * top's guard also makes: a start of frame whose frameWidth/frameHeight lie outside 32x16..maxWidth x maxHeight
  * raises the sticky `error` bit (cleared by reset or a one-cycle `clearError`) and the whole frame is dropped up to
  * the next start of frame (the top's [[FrameGuard]] makes more checks; DescriptorSpec tests this one alone).
  */
class DescriptorChain(p: ElasParams) extends Module {
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

/** Ports of the stage-test chains that end in a lattice stream: pixel pairs in, lattice values out. */
class LatticeChainIO(p: ElasParams) extends Bundle {
  val in = Flipped(Decoupled(new PixelPair))
  val frameWidth = Input(UInt(p.colBits.W))
  val frameHeight = Input(UInt(p.rowBits.W))
  val out = Decoupled(new Framed(SInt(p.signedDispBits.W)))
}

/** A stage-test chain from pixel pairs to a lattice stream. */
abstract class LatticeChain(p: ElasParams) extends Module {
  val io = IO(new LatticeChainIO(p))
}

/** Stage-test chain: pixel input -> [[Descriptor]] -> [[SupportMatcher]] (frame size ports shared by both). */
class SupportChain(p: ElasParams) extends LatticeChain(p) {
  val descriptor = Module(new Descriptor(p))
  val matcher = Module(new SupportMatcher(p))
  descriptor.io.in <> io.in
  descriptor.io.frameWidth := io.frameWidth
  descriptor.io.frameHeight := io.frameHeight
  matcher.io.in <> descriptor.io.out
  matcher.io.frameWidth := io.frameWidth
  matcher.io.frameHeight := io.frameHeight
  io.out <> matcher.io.out
}

/** Stage-test chain: pixel input -> [[Descriptor]] -> [[SupportMatcher]] -> [[SupportFilter]]. */
class SupportFilterChain(p: ElasParams) extends LatticeChain(p) {
  val support = Module(new SupportChain(p))
  val filter = Module(new SupportFilter(p))
  support.io.in <> io.in
  support.io.frameWidth := io.frameWidth
  support.io.frameHeight := io.frameHeight
  filter.io.in <> support.io.out
  io.out <> filter.io.out
}

/** Stage-test chain: pixel input -> [[Descriptor]] -> [[SupportMatcher]] -> [[SupportFilter]] -> [[LatticeFill]]. */
class LatticeFillChain(p: ElasParams) extends LatticeChain(p) {
  val fill = Module(LatticeFill(p))
  fill.io.in <> StageChains.filtered(p, io.in, io.frameWidth, io.frameHeight)
  fill.io.frameWidth := io.frameWidth
  fill.io.frameHeight := io.frameHeight
  io.out <> fill.io.out
}

/** Ports of the grid stage-test chain: pixel pairs in, grid cells out. */
class GridVectorChainIO(p: ElasParams) extends Bundle {
  val in = Flipped(Decoupled(new PixelPair))
  val frameWidth = Input(UInt(p.colBits.W))
  val frameHeight = Input(UInt(p.rowBits.W))
  val out = Decoupled(new Framed(new GridCellPair(p)))
}

/** Stage-test chain: pixel input -> [[Descriptor]] -> [[SupportMatcher]] -> [[SupportFilter]] -> [[GridVector]]
  * (frame size ports shared by all).
  */
class GridVectorChain(p: ElasParams) extends Module {
  val io = IO(new GridVectorChainIO(p))
  val grid = Module(new GridVector(p))
  grid.io.in <> StageChains.filtered(p, io.in, io.frameWidth, io.frameHeight)
  grid.io.frameWidth := io.frameWidth
  grid.io.frameHeight := io.frameHeight
  io.out <> grid.io.out
}

/** One beat of the early path's two result streams, merged for EarlyPathSpec: a filled lattice node
  * (stage `interp`) or a grid cell of both views (stage `grid`), each with its own stream's framing.
  */
class EarlyBeat(p: ElasParams) extends Bundle {
  val isGrid = Bool()
  val lattice = new Framed(SInt(p.signedDispBits.W))
  val grid = new Framed(new GridCellPair(p))
}

/** Stage-test chain of the whole early path as the top builds it: pixel input -> [[Descriptor]] ->
  * [[SupportMatcher]] -> [[SupportFilter]] -> fork -> [[LatticeFill]] and [[GridVector]]. Both results leave through
  * one port (round-robin), tagged, so one testbench loop checks the four stages chained.
  */
class EarlyPathChain(p: ElasParams) extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PixelPair))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val out = Decoupled(new EarlyBeat(p))
  })
  val fork = Module(new StreamFork(new Framed(SInt(p.signedDispBits.W)), 2))
  fork.io.in <> StageChains.filtered(p, io.in, io.frameWidth, io.frameHeight)
  val fill = Module(LatticeFill(p))
  val grid = Module(new GridVector(p))
  fill.io.in <> fork.io.out(0)
  grid.io.in <> fork.io.out(1)
  fill.io.frameWidth := io.frameWidth
  fill.io.frameHeight := io.frameHeight
  grid.io.frameWidth := io.frameWidth
  grid.io.frameHeight := io.frameHeight

  val merge = Module(new RRArbiter(new EarlyBeat(p), 2))
  merge.io.in(0).valid := fill.io.out.valid
  merge.io.in(0).bits := DontCare
  merge.io.in(0).bits.isGrid := false.B
  merge.io.in(0).bits.lattice := fill.io.out.bits
  fill.io.out.ready := merge.io.in(0).ready
  merge.io.in(1).valid := grid.io.out.valid
  merge.io.in(1).bits := DontCare
  merge.io.in(1).bits.isGrid := true.B
  merge.io.in(1).bits.grid := grid.io.out.bits
  grid.io.out.ready := merge.io.in(1).ready
  io.out <> merge.io.out
}

object StageChains {
  /** A [[SupportFilterChain]] inside the calling module, fed from its pixel input and frame size: the filtered
    * support lattice that the interp and grid chains start from. */
  def filtered(p: ElasParams, in: DecoupledIO[PixelPair], width: UInt, height: UInt): DecoupledIO[Framed[SInt]] = {
    val chain = Module(new SupportFilterChain(p))
    chain.io.in <> in
    chain.io.frameWidth := width
    chain.io.frameHeight := height
    chain.io.out
  }
}
