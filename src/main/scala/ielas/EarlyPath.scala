package ielas

import chisel3._
import chisel3.util._

/** One beat of the early path's two result streams, merged for tests and `make simulate`: a filled lattice node
  * (stage `interp`) or a grid cell of both views (stage `grid`), each with its own stream's framing.
  */
class EarlyBeat(p: ElasParams) extends Bundle {
  val isGrid = Bool()
  val lattice = new Framed(SInt((p.dispBits + 1).W))
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
  val filtered = Module(new SupportFilterChain(p))
  filtered.io.in <> io.in
  filtered.io.frameWidth := io.frameWidth
  filtered.io.frameHeight := io.frameHeight
  val fork = Module(new StreamFork(new Framed(SInt((p.dispBits + 1).W)), 2))
  fork.io.in <> filtered.io.out
  val fill = Module(new LatticeFill(p))
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
