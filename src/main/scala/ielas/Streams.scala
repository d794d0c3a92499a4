package ielas

import chisel3._
import chisel3.util._

/** One beat of the stereo pixel input, AXI4-Stream video style (docs/interfaces.md §4):
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
  /** The legal frame size range (docs/interfaces.md §1): 32x16 up to the configuration's maximum. */
  val minWidth = 32
  val minHeight = 16

  def isLegal(p: ElasParams, width: UInt, height: UInt): Bool =
    width >= minWidth.U && width <= p.maxWidth.U && height >= minHeight.U && height <= p.maxHeight.U
}

/** One grid cell of both views' grid vectors (stage `grid`): up to storedDisparities candidates each, ascending,
  * -1 = unused slot. Cells stream in grid raster order (eol = last cell of a grid row, eof = last cell).
  */
class GridCellPair(p: ElasParams) extends Bundle {
  val left = Vec(p.storedDisparities, SInt(p.signedDispBits.W))
  val right = Vec(p.storedDisparities, SInt(p.signedDispBits.W))
}

/** One plane (stage `planes`, docs/ALGORITHM.md): d(u, v) = (c + a (u - anchorU) + b (v - anchorV) + 2^15) >> 16. */
class PlaneCoeffs(p: ElasParams) extends Bundle {
  val a = SInt(32.W)
  val b = SInt(32.W)
  val c = SInt(32.W)
  val anchorU = SInt((p.colBits + 1).W) // right view: x0 - D_BL, may be negative
  val anchorV = UInt(p.rowBits.W)
  val valid = Bool()
}

/** One lattice cell (stage `planes`): triangle 0 = (TL, TR, BL) and 1 = (TR, BR, BL) in both views, plus the four
  * corner disparities the rasteriser needs for the right view (TL, TR, BL, BR). Cells stream in raster order over
  * (latticeRows - 1) x (latticeCols - 1) (eol = last cell of a cell row, eof = last cell).
  */
class PlaneCell(p: ElasParams) extends Bundle {
  val left = Vec(2, new PlaneCoeffs(p))
  val right = Vec(2, new PlaneCoeffs(p))
  val corners = Vec(4, UInt(p.dispBits.W))
}

/** Both views' disparities at one pixel (stages `dense` and `lrcheck`), -1 = invalid; raster order. */
class DisparityPair(p: ElasParams) extends Bundle {
  val left = SInt(p.signedDispBits.W)
  val right = SInt(p.signedDispBits.W)
}

/** A stage's output register, the last register of its pipeline: it holds one beat until `out` takes it. A stage
  * loads a beat (`valid := true.B` and the fields of `bits`) only in a cycle where `free` holds; a load in the cycle
  * `out` takes the previous beat replaces it. The registers are outValid and outBits in the Verilog.
  */
class OutputRegister[T <: Data](out: DecoupledIO[T]) {
  val valid: Bool = RegInit(false.B).suggestName("outValid")
  val bits: T = Reg(chiselTypeOf(out.bits)).suggestName("outBits")
  /** The register is empty or is being emptied: a beat may be loaded. */
  val free: Bool = (!valid || out.ready).suggestName("outFree")
  when(out.fire) { valid := false.B }
  out.valid := valid
  out.bits := bits
}

/** The output queue of a pipeline that never stalls. A beat enters the pipeline only with a credit (`creditOk`, one
  * per queue entry), and a credit comes back a clock after its beat leaves the queue (registered: the queue's
  * pointer compare stays off the count). The consumer's ready then reaches the queue and the count only, not the
  * enable of every pipeline register. `entries` must cover the beats in flight at full rate; fewer leave bubbles
  * and never lose a beat (the enqueue asserts room). Verilog names: outQueue, owed, creditOk, takenLate.
  */
class CreditQueue[T <: Data](gen: T, entries: Int, owner: String) {
  val queue: Queue[T] = Module(new Queue(gen, entries)).suggestName("outQueue")
  val creditOk: Bool = RegInit(true.B).suggestName("creditOk") // owed < entries
  private val owed = RegInit(0.U(log2Ceil(entries + 1).W)).suggestName("owed") // entered and not yet taken
  private val takenLate = RegNext(queue.io.deq.fire, false.B).suggestName("takenLate")
  val deq: DecoupledIO[T] = queue.io.deq
  /** Call once per cycle: `entered` = a beat took a credit this cycle (it reaches [[enq]] through the pipeline). */
  def spend(entered: Bool): Unit = {
    val owedNext = owed + entered.asUInt - takenLate.asUInt
    owed := owedNext
    creditOk := owedNext < entries.U
  }
  def enq(valid: Bool, bits: T): Unit = {
    queue.io.enq.valid := valid
    queue.io.enq.bits := bits
    assert(!valid || queue.io.enq.ready, s"$owner: output queue full (credits)")
  }
}

/** A stream boundary with registered outputs and a registered ready: `out.valid`, `out.bits` and `in.ready` are
  * flip-flops, so neither a consumer's ready logic nor a producer's valid logic reaches through it (the top puts one
  * between stages, so a register-to-register path stays inside one stage). One beat per clock, one clock of latency;
  * a second register holds the beat taken in the cycle the output stalls.
  */
class RegisterSlice[T <: Data](gen: T) extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(gen))
    val out = Decoupled(gen)
  })
  val outValid = RegInit(false.B)
  val outBits = Reg(gen)
  val heldValid = RegInit(false.B) // a beat taken while the output stalled
  val heldBits = Reg(gen)
  io.in.ready := !heldValid
  io.out.valid := outValid
  io.out.bits := outBits
  when(!outValid || io.out.ready) {
    outValid := heldValid || io.in.valid
    outBits := Mux(heldValid, heldBits, io.in.bits)
    heldValid := false.B
  }.elsewhen(io.in.valid && !heldValid) {
    heldValid := true.B
  }
  when(!heldValid) { heldBits := io.in.bits } // while empty: its enable is a flip-flop, not the consumer's ready
}

object RegisterSlice {
  def apply[T <: Data](in: DecoupledIO[T]): DecoupledIO[T] = {
    val m = Module(new RegisterSlice(chiselTypeOf(in.bits)))
    m.io.in <> in
    m.io.out
  }
}

/** A first-in first-out queue of `entries` beats in one block RAM whose read address is a register. (Chisel's
  * `Queue` with a synchronous memory reads at the next dequeue pointer, chosen by the dequeue handshake and the
  * pointers' compare: that chain ran into the pixel band's block-RAM addresses, the whole top's worst path.) The
  * memory is read at `readPtr` every clock; a beat is taken out of it (`issue`) only while the output queue behind it
  * has room for it, counting the beat still in the read, so three registered entries sustain one beat per clock.
  * `in.ready` is a register (the memory is not full); latency is three clocks. Holds `entries` + 3 beats.
  */
class BlockQueue[T <: Data](gen: T, val entries: Int) extends Module {
  require(entries >= 2, s"BlockQueue: entries = $entries (legal: 2 or more)")
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(gen))
    val out = Decoupled(gen)
  })
  override def desiredName = s"BlockQueue$entries"
  private val ptrW = log2Ceil(entries)
  private def wrapInc(ptr: UInt): UInt = Mux(ptr === (entries - 1).U, 0.U, ptr + 1.U)
  val mem = SyncReadMem(entries, gen)
  val writePtr = RegInit(0.U(ptrW.W))
  val readPtr = RegInit(0.U(ptrW.W))
  val stored = RegInit(0.U(log2Ceil(entries + 1).W)) // beats in the memory
  val nonEmpty = RegInit(false.B) //                     stored =/= 0
  val full = RegInit(false.B) //                         stored === entries
  val output = Module(new Queue(gen, 3))
  val owed = RegInit(0.U(2.W)) // beats in the output queue or in the read (<= 3)
  val issue = nonEmpty && owed < 3.U // the beat at readPtr goes to the output queue (next clock)
  val inRead = RegNext(issue, false.B)
  io.in.ready := !full
  when(io.in.fire) {
    mem.write(writePtr, io.in.bits)
    writePtr := wrapInc(writePtr)
  }
  when(issue) { readPtr := wrapInc(readPtr) }
  val storedNext = stored + io.in.fire.asUInt - issue.asUInt
  stored := storedNext
  nonEmpty := storedNext =/= 0.U
  full := storedNext === entries.U
  owed := owed + issue.asUInt - io.out.fire.asUInt
  output.io.enq.valid := inRead
  output.io.enq.bits := mem.read(readPtr)
  // a used read (issue) needs a stored beat, so writePtr = readPtr + stored is another entry; an empty queue's read
  // meets the write of its first beat, and is not issued
  CollisionFree.check("BlockQueue", Seq(mem), Seq(CollisionFree.Read(readPtr, inRead)),
    Seq(CollisionFree.Write(io.in.fire, writePtr)))
  assert(!inRead || output.io.enq.ready, "BlockQueue: output queue full")
  io.out <> output.io.deq
}

object BlockQueue {
  def apply[T <: Data](in: DecoupledIO[T], entries: Int): DecoupledIO[T] = {
    val m = Module(new BlockQueue(chiselTypeOf(in.bits), entries))
    m.io.in <> in
    m.io.out
  }
}

/** Hands every beat of `in` to all `n` outputs. Each output may take it in a different cycle; the beat leaves `in`
  * once every output has taken it, so a stalled consumer holds back only the beats it has not yet seen.
  */
class StreamFork[T <: Data](gen: T, n: Int) extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(gen))
    val out = Vec(n, Decoupled(gen))
  })
  val taken = RegInit(VecInit(Seq.fill(n)(false.B)))
  for (k <- 0 until n) {
    io.out(k).valid := io.in.valid && !taken(k)
    io.out(k).bits := io.in.bits
  }
  io.in.ready := (0 until n).map(k => taken(k) || io.out(k).ready).reduce(_ && _)
  for (k <- 0 until n) taken(k) := Mux(io.in.fire, false.B, taken(k) || io.out(k).fire)
}

/** The rows a row buffer holds ahead of its reader (rowsIn - procJ) as a counter of its own, and whether the slot of
  * the next input row is free (ahead <= maxAhead) as a register set from the counter's next value: an input ready
  * built on `free` waits on no adder or compare of two counters. `clear` (start of frame) resets both counts.
  */
class RowsAhead(width: Int, maxAhead: Int) {
  require(maxAhead >= 1)
  val ahead: UInt = RegInit(0.U(width.W)).suggestName("rowsAhead")
  val free: Bool = RegInit(true.B).suggestName("slotFree")
  /** One cycle: an input row completes (rowIn) and/or the reader leaves a row (rowOut). */
  def update(clear: Bool, rowIn: Bool, rowOut: Bool): Unit = {
    ahead := Mux(clear, 0.U, ahead) + rowIn.asUInt - rowOut.asUInt
    setFree(clear, rowIn, rowOut)
  }
  /** The same for a buffer that is never cleared: ahead + 1 and ahead - 1 are formed from the register, and the row
    * ends only select. (With a clear, this form put LatticeFill at 7 LUT levels.) */
  def update(rowIn: Bool, rowOut: Bool): Unit = {
    ahead := Mux(rowIn === rowOut, ahead, Mux(rowIn, ahead + 1.U, ahead - 1.U))
    setFree(false.B, rowIn, rowOut)
  }
  private def setFree(clear: Bool, rowIn: Bool, rowOut: Bool): Unit = {
    free := clear || Mux(rowIn === rowOut, ahead <= maxAhead.U,
      Mux(rowIn, ahead <= (maxAhead - 1).U, ahead <= (maxAhead + 1).U))
  }
}

/** `depth` credits counted down as they are taken and up as they come back, with "a credit is free" in a register of
  * its own (from the count and this clock's moves), so a handshake that needs a credit reads one flip-flop.
  * Call [[update]] once per clock. Verilog names: `name` (the count) and `okName`.
  */
class Credits(depth: Int, name: String, okName: String) {
  val count: UInt = RegInit(depth.U(log2Ceil(depth + 1).W)).suggestName(name)
  val ok: Bool = RegInit(true.B).suggestName(okName) // count =/= 0
  val full: Bool = count === depth.U // every credit is back
  def update(taken: Bool, back: Bool): Unit = {
    count := count - taken.asUInt + back.asUInt
    ok := Mux(taken === back, count =/= 0.U, Mux(taken, count =/= 1.U, true.B))
  }
}
