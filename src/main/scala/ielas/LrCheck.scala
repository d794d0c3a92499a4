package ielas

import chisel3._
import chisel3.util._

/** Stage `lrcheck`: dense left/right consistency (docs/ALGORITHM.md "lrcheck", golden/src/lr_check.cpp).
  *
  * Input: the dense stream (dense_L, dense_R per pixel, raster order, -1 = invalid, sof / eol / eof). Output: the
  * same framing with lrcheck_L / lrcheck_R. Per pixel u of a row of width W, reading the input maps only:
  *   left:  d = L(u) kept iff d >= 0, u - d >= 0, R(u - d) >= 0 and |R(u - d) - d| <= lrThreshold, else -1;
  *   right: d = R(u) kept iff d >= 0, u + d < W,  L(u + d) >= 0 and |L(u + d) - d| <= lrThreshold, else -1.
  * The explicit ">= 0" test on the other view matters: with -1 as invalid, |-1 - d| <= 2 would pass for d <= 1.
  *
  * Rows are independent, so the stage has no frame state: each row's width is learned from the framing (its own
  * eol), and the output framing copies the input's (sof of a row's first beat, eol, eof of its last beat). Frames
  * of different sizes may follow each other with no gap. No frame size port is needed.
  *
  * Buffer: 3 row slots, each one SyncReadMem per view of maxWidth entries with a read/write port (the writer's
  * pixels, or the processor's sequential read of L(u), R(u)) and a read port (R(u - d) or L(u + d)):
  *   buffer bits = 3 x 2 x maxWidth x (dispBits + 1)   (kitti: 3 x 2 x 1242 x 9 = 67,068 bits).
  * A row is processed once its eol has arrived (the right check looks up to dispMax columns ahead), in a
  * 5-stage pipeline (sequential read, its data register, lookup read, its data register, compare into the output
  * register; each step a few LUTs deep, docs/timing.md). The third slot is what
  * makes it stall-free: row v + 3 overwrites row v's slot, which retired about W cycles earlier; with two slots
  * the writer would wait for the pipeline's drain at every row. Nothing grows with the image height.
  *
  * Throughput: 1 pixel per clock; N input pixels of frames of one size with no stalls leave in
  * N + W + [[LrCheck.cycleSlack]] cycles. A frame after a wider one keeps the wider row's lag (its first row is
  * processed only once the wide row has left, and at one pixel per clock the lag is not made up), so for frames of
  * mixed sizes W is the widest. When a frame follows a more than twice as wide one, its first rows fill
  * the two free slots before the wide last row has left, so the input waits once, for at most the wide width plus cycleSlack
  * ([[LrCheck.narrowingSlack]]); a 4th slot would not remove that, only a buffer addressed by pixel instead of by row.
  * Back-pressure: the output register (draining into a 2-entry queue) stalls the whole pipeline (memory reads are re-issued at the held addresses,
  * which is safe because a slot is never written while any of its pixels is in the pipeline); the input stalls only
  * when all three slots are occupied. A row longer than maxWidth keeps its first maxWidth - 1 pixels and its last
  * one (the top's frame guard never lets such a row through).
  */
class LrCheck(p: ElasParams) extends Module {
  private val slots = LrCheck.slots
  private val addrW = log2Ceil(p.maxWidth)
  private val valueType = SInt(p.signedDispBits.W)

  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(new DisparityPair(p))))
    val out = Decoupled(new Framed(new DisparityPair(p)))
  })

  // ---- slot bookkeeping ----
  val busy = RegInit(VecInit(Seq.fill(slots)(false.B)))   // holds a complete row that has not left the pipeline
  val pending = RegInit(VecInit(Seq.fill(slots)(false.B))) // holds a complete row not yet issued to the pipeline
  val rowLen = Reg(Vec(slots, UInt(p.colBits.W)))
  val rowSof = Reg(Vec(slots, Bool()))
  val rowEof = Reg(Vec(slots, Bool()))

  def nextSlot(s: UInt): UInt = Mux(s === (slots - 1).U, 0.U, s + 1.U)

  // ---- writer ----
  val wSlot = RegInit(0.U(2.W))
  val wCol = RegInit(0.U(p.colBits.W))
  io.in.ready := !busy(wSlot)
  val write = io.in.fire
  when(write) {
    when(wCol === 0.U) { rowSof(wSlot) := io.in.bits.sof }
    when(wCol =/= (p.maxWidth - 1).U) { wCol := wCol + 1.U } // an over-long row overwrites its last entry
    when(io.in.bits.eol) {
      wCol := 0.U
      wSlot := nextSlot(wSlot)
      busy(wSlot) := true.B
      pending(wSlot) := true.B
      rowLen(wSlot) := wCol + 1.U
      rowEof(wSlot) := io.in.bits.eof
    }
  }

  // ---- pipeline registers ----
  // The output register drains into a 2-entry queue, so io.out.ready reaches no memory address. The pipeline moves
  // when the output register is empty or the queue has room, and that is a register of its own, set a cycle ahead:
  // at `small`, where the memories are LUT-RAM read at addresses the move selects, the queue's pointer compare and
  // the OR before the address multiplexers made the path 7 LUT levels. Next cycle the output register is empty
  // only if it moves now without a beat from s3 (a register that does not move is full), and the queue has room if
  // it holds fewer than 2 beats after this cycle's moves.
  val outQueue = Module(new Queue(new Framed(new DisparityPair(p)), 2))
  val output = new OutputRegister(outQueue.io.enq)
  val advance = RegInit(true.B)
  val s3Valid = RegInit(false.B)
  advance := advance && !s3Valid ||
    outQueue.io.count +& outQueue.io.enq.fire.asUInt - outQueue.io.deq.fire.asUInt < 2.U
  assert(advance === output.free, "LrCheck: the move register")

  // s0: the next pixel to issue
  val pSlot = RegInit(0.U(2.W))
  val pU = RegInit(0.U(p.colBits.W))
  val issue = advance && pending(pSlot)

  // s1: L(u), R(u) arrive from the read/write ports
  val s1Valid = RegInit(false.B)
  val s1Slot = Reg(UInt(2.W))
  val s1U = Reg(UInt(p.colBits.W))
  val s1Len = Reg(UInt(p.colBits.W))
  val s1Sof = Reg(Bool())
  val s1Eol = Reg(Bool())
  val s1Eof = Reg(Bool())

  // s1b: L(u), R(u) registered (a LUT-RAM slot reads combinationally from its address register)
  val s1bValid = RegInit(false.B)
  val s1bSlot = Reg(UInt(2.W))
  val s1bU = Reg(UInt(p.colBits.W))
  val s1bLen = Reg(UInt(p.colBits.W))
  val s1bDL = Reg(valueType)
  val s1bDR = Reg(valueType)
  val s1bSof = Reg(Bool())
  val s1bEol = Reg(Bool())
  val s1bEof = Reg(Bool())

  // s2: R(u - dL), L(u + dR) arrive from the read ports
  val s2Valid = RegInit(false.B)
  val s2Slot = Reg(UInt(2.W))
  val s2DL = Reg(valueType)
  val s2DR = Reg(valueType)
  val s2InL = Reg(Bool()) // dL >= 0 and u - dL >= 0
  val s2InR = Reg(Bool()) // dR >= 0 and u + dR < W
  val s2AddrR = Reg(UInt(addrW.W))
  val s2AddrL = Reg(UInt(addrW.W))
  val s2Sof = Reg(Bool())
  val s2Eol = Reg(Bool())
  val s2Eof = Reg(Bool())

  // ---- memories ----
  // Port A: the writer's pixel, else the sequential read of the pixel s1 holds next cycle (s0's on advance, s1's own
  // again on a stall). Port B: the lookups of the pixel s2 holds next cycle. The writer and the pipeline never
  // touch the same slot (busy), so port A of a slot is either written or read, never both.
  val writeAddr = wCol(addrW - 1, 0)
  val seqAddr = Mux(advance, pU, s1U)(addrW - 1, 0)
  val lookR = Wire(UInt(addrW.W))
  val lookL = Wire(UInt(addrW.W))
  val memL = Seq.fill(slots)(SyncReadMem(p.maxWidth, valueType))
  val memR = Seq.fill(slots)(SyncReadMem(p.maxWidth, valueType))
  val seqL = Wire(Vec(slots, valueType))
  val seqR = Wire(Vec(slots, valueType))
  val lookDataR = Wire(Vec(slots, valueType))
  val lookDataL = Wire(Vec(slots, valueType))
  for (s <- 0 until slots) {
    val w = write && wSlot === s.U
    val addr = Mux(w, writeAddr, seqAddr)
    seqL(s) := memL(s).readWrite(addr, io.in.bits.data.left, true.B, w)
    seqR(s) := memR(s).readWrite(addr, io.in.bits.data.right, true.B, w)
    lookDataR(s) := memR(s).read(lookR)
    lookDataL(s) := memL(s).read(lookL)
  }
  // The pipeline reads only busy slots (the row they hold is complete) and the writer fills only a slot that is not
  // busy. Port B reads every slot at the lookups' columns, so it meets the writes of the slot being filled, unused.
  for (s <- 0 until slots) {
    val w = CollisionFree.Write(write && wSlot === s.U, writeAddr)
    val seqUsed = advance && s1Valid && s1Slot === s.U
    val lookUsed = advance && s2Valid && s2Slot === s.U
    CollisionFree.check(s"LrCheck: memL($s)", Seq(memL(s)),
      Seq(CollisionFree.Read(seqAddr, seqUsed), CollisionFree.Read(lookL, lookUsed)), Seq(w))
    CollisionFree.check(s"LrCheck: memR($s)", Seq(memR(s)),
      Seq(CollisionFree.Read(seqAddr, seqUsed), CollisionFree.Read(lookR, lookUsed)), Seq(w))
  }

  // ---- s1b: bounds of the lookups ----
  val dL = s1bDL
  val dR = s1bDR
  val tl = s1bU.zext - dL // left pixel u sees right column u - d
  val tr = s1bU +& dR.asUInt // right pixel u sees left column u + d (only read when dR >= 0)
  val inL = dL >= 0.S && tl >= 0.S
  val inR = dR >= 0.S && tr < s1bLen
  val addrR = Mux(inL, tl.asUInt, s1bU)(addrW - 1, 0) // an address that exists when the lookup is not needed
  val addrL = Mux(inR, tr, s1bU)(addrW - 1, 0)
  lookR := Mux(advance, addrR, s2AddrR)
  lookL := Mux(advance, addrL, s2AddrL)

  // ---- s3: the looked-up values registered, then the comparisons ----
  val s3 = Reg(new Bundle {
    val dL = SInt(p.signedDispBits.W); val dR = SInt(p.signedDispBits.W); val inL = Bool(); val inR = Bool()
    val otherR = SInt(p.signedDispBits.W); val otherL = SInt(p.signedDispBits.W) // R(u - dL), L(u + dR)
    val sof = Bool(); val eol = Bool(); val eof = Bool()
  })
  // |other - d| <= threshold as two compares side by side: no negation after the subtraction (7 LUT levels at small)
  def consistent(d: SInt, other: SInt): Bool =
    other >= 0.S && (other -& d) <= p.lrThreshold.S && (d -& other) <= p.lrThreshold.S
  val keepL = s3.inL && consistent(s3.dL, s3.otherR)
  val keepR = s3.inR && consistent(s3.dR, s3.otherL)

  when(advance) {
    // output register
    output.valid := s3Valid
    output.bits.data.left := Mux(keepL, s3.dL, (-1).S)
    output.bits.data.right := Mux(keepR, s3.dR, (-1).S)
    output.bits.sof := s3.sof
    output.bits.eol := s3.eol
    output.bits.eof := s3.eof

    // s2 -> s3
    s3Valid := s2Valid
    s3.dL := s2DL
    s3.dR := s2DR
    s3.inL := s2InL
    s3.inR := s2InR
    s3.otherR := lookDataR(s2Slot)
    s3.otherL := lookDataL(s2Slot)
    s3.sof := s2Sof
    s3.eol := s2Eol
    s3.eof := s2Eof
    when(s2Valid && s2Eol) { busy(s2Slot) := false.B } // the row's last lookups are done: its slot may be rewritten

    // s1b -> s2
    s2Valid := s1bValid
    s2Slot := s1bSlot
    s2DL := dL
    s2DR := dR
    s2InL := inL
    s2InR := inR
    s2AddrR := addrR
    s2AddrL := addrL
    s2Sof := s1bSof
    s2Eol := s1bEol
    s2Eof := s1bEof

    // s1 -> s1b
    s1bValid := s1Valid
    s1bSlot := s1Slot
    s1bU := s1U
    s1bLen := s1Len
    s1bDL := seqL(s1Slot)
    s1bDR := seqR(s1Slot)
    s1bSof := s1Sof
    s1bEol := s1Eol
    s1bEof := s1Eof

    // s0 -> s1
    s1Valid := issue
    when(issue) {
      val last = pU === rowLen(pSlot) - 1.U
      s1Slot := pSlot
      s1U := pU
      s1Len := rowLen(pSlot)
      s1Sof := pU === 0.U && rowSof(pSlot)
      s1Eol := last
      s1Eof := last && rowEof(pSlot)
      pU := pU + 1.U
      when(last) {
        pU := 0.U
        pending(pSlot) := false.B
        pSlot := nextSlot(pSlot)
      }
    }
  }

  io.out <> outQueue.io.deq
}

object LrCheck {
  /** Row slots: the row being written, the row being processed, and one so that neither waits for the other. */
  val slots: Int = 3

  /** Rows of latency: the throughput bound is N + latencyRows * W + cycleSlack cycles for N input pixels. */
  val latencyRows: Int = 1

  /** Cycles beyond one row: the slot flags, the two memory reads, their two data registers, the output register and
    * the output queue.
    */
  val cycleSlack: Int = 7

  /** Extra input wait, once, when a frame of width `narrow` follows one of width `wide`: rows narrower than half
    * the previous row fill the other two slots before the wide row has left the pipeline. Bounded by `wide`.
    */
  def narrowingSlack(wide: Int, narrow: Int): Int = if (2 * narrow < wide + cycleSlack) wide + cycleSlack else 0

  def memorySummary(p: ElasParams): Seq[MemoryUse] = Seq(
    MemoryUse("LrCheck", "rows", p.maxWidth, slots * 2 * p.signedDispBits,
      s"$slots row slots x {left, right} ${p.signedDispBits}-bit disparities, one SyncReadMem (1RW + 1R) per slot and view"))
}
