package ielas

import chisel3._
import chisel3.util._

/** Stage `filter`: the inconsistency filter over a snapshot of the support lattice (docs/ALGORITHM.md / PINNED 4).
  *
  * Input and output: the lattice stream of [[SupportMatcher]] (lattice raster order, every node, -1 = none, with
  * sof / eol / eof). Node (j, i) is kept iff it holds a support d and at least inconMinSupport nodes (itself
  * included) of the (2k+1) x (2k+1) window around it (k = inconWindowSize, clipped to the lattice) hold a support
  * within inconThreshold of d. The lattice size is learned from the framing (the first eol gives Lw, eof gives Lh),
  * so the stage needs no frame size ports.
  *
  * Buffer: slots = 2k + 2 lattice rows, one memory per row slot (rows j-k .. j+k are read while row j+k+1 is
  * written into the remaining slot):
  *   buffer bits = (2k + 2) x latticeColsMax x (dispBits + 1)   (kitti: 12 x 250 x 9 = 27,000 bits).
  * Per node: the centre column is read while the previous node is emitted, then one column of 2k+1 rows per cycle
  * is read and held in registers, and goes through two counting stages (agreement bit per row, then their sum into
  * the count): 2k + 5 cycles for a support node (15 at k = 5), 3 for an empty node, against an average of
  * step^2 = 25 pixel clocks per node at 1 pixel per clock (a frame's first node, and a row's first node whose window
  * rows have not all arrived, wait a cycle more in sCentre). The input stalls only when the row slot to be written
  * is still inside the window being filtered (or a new frame arrives while the previous one is still being filtered).
  */
class SupportFilter(p: ElasParams) extends Module {
  private val k = p.inconWindowSize
  private val slots = SupportFilter.slots(p)
  private val colsMax = p.latticeColsMax
  private val colW = log2Ceil(colsMax + 1) + 1
  private val rowW = log2Ceil(p.latticeRowsMax + 1) + 1
  private val valueType = SInt(p.signedDispBits.W)

  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(SInt(p.signedDispBits.W))))
    val out = Decoupled(new Framed(SInt(p.signedDispBits.W)))
  })

  // ---- input side ----
  val inBusy = RegInit(false.B) //   lattice values of a frame are still expected
  val procBusy = RegInit(false.B) // nodes of a frame are still to be filtered
  val frameDone = RegInit(false.B) // eof received: rowsIn = Lh
  val colIn = RegInit(0.U(colW.W))
  val rowsIn = RegInit(0.U(rowW.W)) // complete rows received (= index of the row being written)
  val inSlot = RegInit(0.U(log2Ceil(slots).W))
  val lw = RegInit(0.U(colW.W))
  val procJ = RegInit(0.U(rowW.W))

  val start = io.in.valid && io.in.bits.sof && !inBusy && !procBusy
  // the slot of row rowsIn last held row rowsIn - slots: free when rowsIn - procJ <= k + 1, kept as a register
  // (the add and compare of rowsIn and procJ in front of ready set the unit's clock)
  val ahead = new RowsAhead(rowW, k + 1)
  val slotFree = ahead.free
  val rowsAhead = ahead.ahead
  io.in.ready := Mux(inBusy, slotFree, !io.in.bits.sof || !procBusy)
  val write = io.in.fire && (inBusy || start)
  val writeCol = Mux(start, 0.U, colIn)
  val writeRow = Mux(start, 0.U, rowsIn)
  val writeSlot = Mux(start, 0.U, inSlot)

  val rowMems = Seq.fill(slots)(SyncReadMem(colsMax, valueType))
  // Writes are registered (the input logic stays off the memories' read paths). A row is read only once the next
  // row has started (rowReady) or the frame is complete, so its last value is always written before it is read.
  val wrEnable = RegNext(write, false.B)
  val wrCol = RegNext(writeCol)
  val wrSlot = RegNext(writeSlot)
  val wrData = RegNext(io.in.bits.data)
  for ((mem, s) <- rowMems.zipWithIndex) when(wrEnable && wrSlot === s.U) { mem.write(wrCol, wrData) }

  when(start) {
    inBusy := true.B; procBusy := true.B; frameDone := false.B
    rowsIn := 0.U; inSlot := 0.U
  }
  when(write) {
    colIn := writeCol + 1.U
    when(io.in.bits.eol) {
      colIn := 0.U
      rowsIn := writeRow + 1.U
      inSlot := Mux(writeSlot === (slots - 1).U, 0.U, writeSlot + 1.U)
      when(writeRow === 0.U) { lw := writeCol + 1.U }
      when(io.in.bits.eof) { inBusy := false.B; frameDone := true.B }
    }
  }

  // rowsIn and procJ step at a row's eol (input and output side); start clears both (the previous frame is done)
  val rowIn = write && io.in.bits.eol
  val rowOut = WireDefault(false.B)
  ahead.update(start, rowIn, rowOut)

  // ---- filtering ----
  val sIdle :: sCentre :: sFirst :: sLoad :: sScan :: sDrain :: sCount :: sEmit :: Nil = Enum(8)
  val state = RegInit(sIdle)
  val procI = RegInit(0.U(colW.W))
  val procSlot = RegInit(0.U(log2Ceil(slots).W))
  val readCol = Wire(UInt(colW.W))
  readCol := procI
  val readData = rowMems.map(_.read(readCol(log2Ceil(colsMax) - 1, 0)))
  // Every column read is held a cycle: the block RAMs' outputs meet only a register, and the centre's slot
  // multiplexer and the agreeing range's adders start at flip-flops. A register fed by a memory's word alone is
  // merged into the memory by Yosys (its memory_dff pass), which moves it in front of the RAM and leaves the word's
  // path as it was, so the register takes the last written value instead while the stage is idle (when the held
  // words are not used): a 2:1 multiplexer that keeps the register in the fabric.
  val heldIdle = RegNext(state === sIdle, true.B)
  val readHeld = RegNext(VecInit(readData.map(w => Mux(heldIdle, wrData, w))))

  val centre = Reg(valueType)
  val count = Reg(UInt(log2Ceil((2 * k + 1) * (2 * k + 1) + 1).W))
  val scanCol = Reg(UInt(colW.W)) //  next column to read
  val scanLast = Reg(UInt(colW.W)) // last column of the window
  val lastRead = RegInit(false.B) //  the column read last cycle was the window's last
  // The next node's column, read in sEmit (its centre, so that sFirst follows sEmit directly), and its window, kept in
  // registers: procI is stable from a node's sFirst on, and sEmit comes at least two cycles later.
  val emitEol = procI === lw - 1.U
  val nextCol = RegNext(Mux(emitEol, 0.U, procI + 1.U))
  private def windowFirst(c: UInt): UInt = Mux(c > k.U, c - k.U, 0.U)
  private def windowLast(c: UInt): UInt = Mux(c +& k.U < lw, c + k.U, lw - 1.U)
  val nextFirst = RegNext(windowFirst(nextCol))
  val nextLast = RegNext(windowLast(nextCol))
  // the window's first and last column, registered, of the node whose centre is read now (sCentre or sEmit, the
  // cycle before sFirst)
  val firstCol = RegNext(Mux(state === sEmit, nextFirst, windowFirst(procI)))
  val lastCol = RegNext(Mux(state === sEmit, nextLast, windowLast(procI)))

  val rowReady = frameDone || rowsIn > procJ +& k.U
  // Agreement is counted per row slot, not per window row: the window's 2k + 1 rows sit in distinct slots, so the
  // count is the same, and each slot's comparison runs straight off its memory (no slot multiplexer per window row
  // between the memories and the comparisons). Slot procSlot + d (mod slots) holds window row d (d <= k) or
  // d - slots (d >= k + 2); d = k + 1 is outside the window. Whether that row exists is fixed once rowReady holds
  // (rows up to procJ + k are in, or the frame is complete), so it is set in sCentre, every cycle until then, and
  // in sFirst (a row's first node may come straight from sEmit; its first agreement bits are formed two cycles on).
  val slotInWindow = Reg(Vec(slots, Bool()))
  when(state === sCentre || state === sFirst) {
    val rowExists = (0 until slots).map { d =>
      if (d <= k) rowsAhead > d.U // row procJ + d < rowsIn
      else if (d == k + 1) false.B
      else procJ >= (slots - d).U // row procJ - (slots - d) >= 0
    }
    for (s <- 0 until slots) slotInWindow(s) := VecInit((0 until slots).map(ps => rowExists((s - ps + slots) % slots)))(procSlot)
  }
  val lo = Reg(SInt((p.dispBits + 2).W)) // max(centre - inconThreshold, 0): also excludes the empty nodes (-1)
  val hi = Reg(SInt((p.dispBits + 2).W)) // centre + inconThreshold
  // Counting, two stages: the column held (read two cycles ago) -> one agreement bit per slot -> count. A window
  // column is read in sFirst, sLoad and sScan until the last (lastRead); its bits count only when the node holds a
  // support (known in sLoad, before the first held column is compared).
  val windowRead = state === sFirst || ((state === sLoad || state === sScan) && !lastRead)
  val windowHeld = RegNext(RegNext(windowRead, false.B), false.B)
  val counting = RegInit(false.B) // the node in the scan holds a support
  val agree = RegNext(VecInit(readHeld.zip(slotInWindow).map { case (v, ok) => ok && v >= lo && v <= hi }))
  val agreeValid = RegNext(windowHeld && counting, false.B)
  when(agreeValid) { count := count + PopCount(agree) }

  val outValid = RegInit(false.B)
  val outBits = Reg(new Framed(valueType))
  val outFree = !outValid || io.out.ready
  when(io.out.fire) { outValid := false.B }
  io.out.valid := outValid
  io.out.bits := outBits

  def emit(value: SInt): Unit = when(outFree) {
    val eol = emitEol
    val eof = eol && frameDone && procJ === rowsIn - 1.U
    outValid := true.B
    outBits.data := value
    outBits.sof := procI === 0.U && procJ === 0.U
    outBits.eol := eol
    outBits.eof := eof
    // the next node's centre column is read now (nextCol): sFirst follows when its window rows are all in
    state := Mux(eol && !(frameDone || rowsAhead > (k + 1).U), sCentre, sFirst)
    procI := procI + 1.U
    when(eol) {
      rowOut := true.B
      procI := 0.U
      procJ := procJ + 1.U
      procSlot := Mux(procSlot === (slots - 1).U, 0.U, procSlot + 1.U)
    }
    when(eof) { state := sIdle; procBusy := false.B }
  }

  switch(state) {
    is(sIdle) {
      when(start) { procI := 0.U; procJ := 0.U; procSlot := 0.U; state := sCentre }
    }
    is(sCentre) { // reading the centre column of node (procJ, procI)
      when(rowReady) { state := sFirst }
    }
    is(sFirst) { // the centre column arrives (held next cycle); the window's first column is read
      readCol := firstCol
      count := 0.U
      scanCol := Mux(firstCol === lastCol, firstCol, firstCol + 1.U)
      scanLast := lastCol
      lastRead := firstCol === lastCol
      state := sLoad
    }
    is(sLoad, sScan) { // read the window's next column; after its last it is read again (the address stays in range)
      readCol := scanCol
      scanCol := Mux(scanCol === scanLast, scanCol, scanCol + 1.U)
      lastRead := scanCol === scanLast
      when(lastRead) { state := sDrain }.otherwise { state := sScan }
    }
    is(sDrain) { state := sCount } // the last column is held, then compared
    is(sCount) { state := sEmit } //  its agreement bits are added to count
    is(sEmit) {
      readCol := nextCol
      emit(Mux(count >= p.inconMinSupport.U, centre, (-1).S))
    }
  }
  // sLoad: the centre node, held from the read in sCentre or sEmit, sets the agreeing range; an empty node emits -1
  // (count 0 < inconMinSupport) from sEmit, and the reads it started count for nothing.
  when(state === sLoad) {
    val v = readHeld(procSlot)
    centre := v
    val vLo = v -& p.inconThreshold.S
    lo := Mux(vLo < 0.S, 0.S, vLo)
    hi := v +& p.inconThreshold.S
    counting := v >= 0.S
    when(v < 0.S) { state := sEmit }
  }
  // sCentre reads procI (the default), sEmit the next node's centre; a stall in sEmit reads it again.
}

object SupportFilter {
  /** Lattice row slots: the 2k + 1 rows of the window plus the row being written. */
  def slots(p: ElasParams): Int = 2 * p.inconWindowSize + 2

  def memorySummary(p: ElasParams): Seq[MemoryUse] = Seq(
    MemoryUse("Filter", "rows", p.latticeColsMax, slots(p) * p.signedDispBits,
      s"${slots(p)} lattice rows of ${p.signedDispBits}-bit values, one SyncReadMem 1R1W per row"))
}
