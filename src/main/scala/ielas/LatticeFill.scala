package ielas

import chisel3._
import chisel3.util._

/** Stage `interp`: every node of the filtered support lattice gets a disparity (docs/ALGORITHM.md "interp"), with the
  * rule `p.fillRule` chosen at elaboration.
  *
  * Input: the [[SupportFilter]] stream (lattice raster order, every node, -1 = none, sof / eol / eof). Output: the
  * filled lattice (every node in 0..dispMax) with the same framing. The lattice size comes from the framing (first
  * eol gives Lw, eof gives Lh); frameWidth / frameHeight (sampled at the input start of frame) give the nodes' pixel
  * positions min(i * step, W - 1), which only the paper rule needs. The fill's start of frame comes rows after the
  * pixel start of frame, so the top must hold the frame size ports until then (video IP holds them for the frame).
  *
  * Row storage. Each input lattice row goes into one of `slots` row slots as a list of its supports, (column, value)
  * in ascending column, plus a count: walking a row in order, the next support of the list is the nearest support
  * at or right of the node, and the last one passed the nearest left of it, so neither rule scans a row.
  *   list bits = slots x latticeColsMax x (idxBits + dispBits),  idxBits = log2Ceil(latticeColsMax + 1)
  *
  * r7 (slots = 4: row 0 waits for rows 1 and 2, and one slot is being written):
  *   filled row above: latticeColsMax x dispBits bits (one memory; node i is read before it is overwritten).
  *   Interpolation is linear in the lattice index: F(a + t) = d_a + floor((G + 2 t D) / (2G)), G = b - a,
  *   D = d_b - d_a. One sequential divider (dispBits cycles) splits 2D = 2G qd + rd once per pair of supports;
  *   along the pair F is then updated with one add and at most one carry per node.
  * paper (slots = R + 3, R = floor(sDelta / step), at most latticeRowsMax + 1): rows j .. j + R + 1 are needed
  *   for the vertical pair below node (j, i) (the extra row: a clipped last row H - 1 may lie within sDelta); the
  *   full values of every slot sit in one memory per slot, so one cycle reads a whole column of the look-ahead:
  *   ring bits  = slots x latticeColsMax x (dispBits + 1)
  *   lastAbove bits = latticeColsMax x (1 + coordBits + dispBits): per column the last support above (valid, pixel
  *   row, value), rewritten in full at lattice row 0 so nothing of the previous frame survives.
  *   (kitti: R = 10, 13 slots: ring 13 x 250 x 9 = 29,250 bits, lists 13 x 250 x 16 = 52,000 bits, lastAbove
  *   250 x 20 = 5,000 bits; r7: lists 4 x 250 x 16 = 16,000 bits, row above 250 x 8 = 2,000 bits.)
  *   Vertical pairs read supports only (never filled values), so no filled row is kept.
  *
  * Schedule: 3 cycles per node (memory read, decide, emit) plus, r7 only, dispBits + 1 cycles per interpolated pair
  * of supports, so a row takes at most [[LatticeFill.rowCycles]] = 3 Lw + ceil(Lw / 2) (dispBits + 1) + 2 cycles
  * (kitti r7: 1,877, paper: 752) against step x W = 6,210 pixel clocks per lattice row at 1 pixel per clock. The input
  * stalls only when the slot of the row to be written is still needed (or a new frame arrives while the previous
  * one is still being filled); the output register stalls the walk. Any gaps are fine.
  */
abstract class LatticeFill(p: ElasParams) extends Module {
  override def desiredName = "LatticeFill" // one Verilog module name for either rule
  protected val step = p.candidateStep
  protected val slots = LatticeFill.slots(p)
  private val slotBits = log2Ceil(slots)
  protected val colsMax = p.latticeColsMax
  protected val idxW = LatticeFill.idxBits(p) // column index or count 0..colsMax
  private val rowW = log2Ceil(p.latticeRowsMax + slots + 1) + 1
  protected val coordW = LatticeFill.coordBits(p)
  protected val dBits = p.dispBits
  protected val valueType = SInt((dBits + 1).W)

  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(SInt(p.signedDispBits.W))))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val out = Decoupled(new Framed(SInt(p.signedDispBits.W)))
  })

  def nextSlot(s: UInt): UInt = Mux(s === (slots - 1).U, 0.U, s + 1.U)
  /** Writes `data` at `addr` one cycle later, from registers: no logic runs into a memory's write port (LUT-RAM
    * writes are synchronous anyway, and the synthesis depth proxy would follow false paths through it). Safe here:
    * a row's list is read no earlier than the cycle its last write lands (the walk forwards that write), and a node's
    * entry of the row above is rewritten only after it was read. Returns the write's registers (enable, address, data).
    */
  def lateWrite[T <: Data](mem: MemBase[T], en: Bool, addr: UInt, data: T): (Bool, UInt, T) = {
    val e = RegNext(en, false.B)
    val a = RegEnable(addr, en)
    val d = RegEnable(data, en)
    when(e) { mem.write(a, d) }
    (e, a, d)
  }

  // ---- input side: each row's supports into its slot's list ----
  val inBusy = RegInit(false.B) //    lattice values of a frame are still expected
  val procBusy = RegInit(false.B) //  rows of a frame are still to be filled
  val frameDone = RegInit(false.B) // eof received: rowsIn = Lh
  val colIn = RegInit(0.U(idxW.W))
  val cntIn = RegInit(0.U(idxW.W))
  val rowsIn = RegInit(0.U(rowW.W)) // complete rows received (= index of the row being written)
  val inSlot = RegInit(0.U(slotBits.W))
  val counts = Reg(Vec(slots, UInt(idxW.W)))
  val lw = RegInit(0.U(idxW.W))
  val wLast = RegInit(0.U(p.colBits.W)) // W - 1
  val hLast = RegInit(0.U(p.rowBits.W)) // H - 1
  val procJ = RegInit(0.U(rowW.W))

  val start = io.in.valid && io.in.bits.sof && !inBusy && !procBusy
  // the slot of row rowsIn last held row rowsIn - slots: free when rowsIn - procJ < slots, kept as a register
  // (the add and compare of rowsIn and procJ in front of ready set the unit's clock)
  val ahead = new RowsAhead(rowW, slots - 1)
  val slotFree = ahead.free
  io.in.ready := Mux(inBusy, slotFree, !io.in.bits.sof || !procBusy)
  val write = io.in.fire && (inBusy || start)
  val writeCol = Mux(start, 0.U, colIn)
  val writeCnt = Mux(start, 0.U, cntIn)
  val writeRow = Mux(start, 0.U, rowsIn)
  val writeSlot = Mux(start, 0.U, inSlot)
  val isSupport = io.in.bits.data >= 0.S

  /** List address of entry `k` of slot `s` (k < colsMax). */
  private val listW = log2Ceil(slots * colsMax)
  def slotBase(s: UInt): UInt = VecInit((0 until slots).map(x => (x * colsMax).U(listW.W)))(s)
  def listAddr(s: UInt, k: UInt): UInt = (slotBase(s) +& k)(listW - 1, 0)
  /** A column index as a row-memory address (the index is < colsMax whenever the read matters). */
  def col(x: UInt): UInt = x(log2Ceil(colsMax) - 1, 0)
  // read-first (a `Mem` read into a register): the one write a read can meet is forwarded below, so Yosys needs no
  // transparency logic of its own
  val list = Mem(slots * colsMax, UInt((idxW + dBits).W))
  val (listWen, listWaddr, listWdata) =
    lateWrite(list, write && isSupport, listAddr(writeSlot, writeCnt), Cat(writeCol, io.in.bits.data.asUInt(dBits - 1, 0)))

  when(start) {
    inBusy := true.B; procBusy := true.B; frameDone := false.B
    rowsIn := 0.U; inSlot := 0.U
    wLast := io.frameWidth - 1.U; hLast := io.frameHeight - 1.U
  }
  when(write) {
    val cnt = writeCnt + isSupport.asUInt
    colIn := writeCol + 1.U
    cntIn := cnt
    when(io.in.bits.eol) {
      colIn := 0.U
      cntIn := 0.U
      counts(writeSlot) := cnt
      rowsIn := writeRow + 1.U
      inSlot := nextSlot(writeSlot)
      when(writeRow === 0.U) { lw := writeCol + 1.U }
      when(io.in.bits.eof) { inBusy := false.B; frameDone := true.B }
    }
  }

  private val rowOut = WireDefault(false.B) // the walk leaves row procJ
  ahead.update(start, write && io.in.bits.eol, rowOut)

  // ---- the walk over the rows ----
  val sIdle :: sRowWait :: sRead :: sNode :: sDiv :: sEmit :: Nil = Enum(6)
  val state = RegInit(sIdle)
  val procSlot = RegInit(0.U(slotBits.W)) // slot of row procJ
  val listPtr = Reg(UInt(listW.W)) //        list address of entry k of the row's source slot (r7 row 0: row 1 or 2)
  val listPtrNext = WireDefault(listPtr); listPtr := listPtrNext
  val n = Reg(UInt(idxW.W)) //               supports in the source row
  val i = Reg(UInt(idxW.W))
  val k = Reg(UInt(idxW.W)) //               next list entry: the first support at or right of i
  val aValid = Reg(Bool()) //                a support left of i was passed: a
  val aIdx = Reg(UInt(idxW.W))
  val aVal = Reg(UInt(dBits.W))
  // r7 row modes
  val useList = Reg(Bool()) //  the row has supports (else: r7 copies the row above, or 0 for row 0)
  val useAbove = Reg(Bool()) // jumps choose against the filled row above (false on row 0)
  val zeros = Reg(Bool()) //    row 0 with no support in rows 0..2
  // pixel positions (paper)
  val uRaw = Reg(UInt(coordW.W)) // i * step
  val vRaw = Reg(UInt(coordW.W)) // procJ * step

  val kIn = k < n
  // The list is read at the entry listPtr takes next, so its word arrives in sRead and is registered there: sNode's
  // decision (and the enables of the registers it loads) starts at flip-flops, not at a block-RAM output. A row's
  // first entry is read in the cycle its row becomes ready, when the row's last support may still be landing
  // (lateWrite): that write is forwarded.
  // sRowWait reads the row's first entry every cycle, whether or not the row is ready: the read address does not
  // wait for rowReady's compare of the row counters (that chain was 7 LUT levels at small).
  protected val rowWaitAddr = WireDefault(slotBase(procSlot))
  val listReadAddr = Mux(state === sRowWait, rowWaitAddr, listPtrNext)
  val listWord = RegNext(list.read(listReadAddr))
  val listHit = RegNext(listWen && listWaddr === listReadAddr, false.B)
  val listWritten = RegNext(listWdata)
  val entry = Reg(UInt((idxW + dBits).W)) // past the last entry (k = n) it holds a value that is not used
  when(state === sRead) { entry := Mux(listHit, listWritten, listWord) }
  val bIdx = entry(idxW + dBits - 1, dBits)
  val bVal = entry(dBits - 1, 0)
  val bHere = kIn && bIdx === i
  val both = aValid && kIn

  val output = new OutputRegister(io.out)

  def absDiff(x: UInt, y: UInt): UInt = Mux(x > y, x - y, y - x)

  val eol = i === lw - 1.U
  val eof = eol && frameDone && procJ === rowsIn - 1.U

  /** The rule's decision for node i, driven by the subclass: the value to emit, whether the node holds a support (and
    * its value), and whether the node is emitted this cycle (in sEmit, when the output register is free). */
  protected val value = Wire(UInt(dBits.W))
  protected val here = Wire(Bool())
  protected val hereVal = Wire(UInt(dBits.W))
  protected val doEmit = Wire(Bool())
  /** The rows the rule needs before row procJ starts are in. */
  protected val rowReady = Wire(Bool())

  // ---- row sequencing ----
  val c = counts
  switch(state) {
    is(sIdle) {
      when(start) { procJ := 0.U; procSlot := 0.U; vRaw := 0.U; state := sRowWait }
    }
    is(sRowWait) {
      when(rowReady) {
        i := 0.U; k := 0.U; aValid := false.B; uRaw := 0.U
        listPtrNext := rowWaitAddr
        n := c(procSlot)
        useList := c(procSlot) =/= 0.U
        useAbove := procJ =/= 0.U
        zeros := false.B
        state := sRead
      }
    }
    is(sRead) { state := sNode } // list entry k arrives (registered), column i is read this cycle
  }
  when(doEmit) { // in sEmit
    output.valid := true.B
    output.bits.data := value.zext
    output.bits.sof := i === 0.U && procJ === 0.U
    output.bits.eol := eol
    output.bits.eof := eof
    when(here) { aValid := true.B; aIdx := i; aVal := hereVal; k := k + 1.U; listPtrNext := listPtr + 1.U }
    i := i + 1.U
    uRaw := uRaw + step.U
    state := sRead
    when(eol) {
      rowOut := true.B
      procJ := procJ + 1.U
      procSlot := nextSlot(procSlot)
      vRaw := vRaw + step.U
      state := sRowWait
    }
    when(eof) { state := sIdle; procBusy := false.B }
  }
}

/** The r7 rule (the class doc of [[LatticeFill]]): a support keeps its value; a node between two supports within
  * fillEpsilon is interpolated linearly, between two farther apart it takes the one nearer the filled value above (the
  * lower one on row 0 or a tie), beside one support only it takes that one; a row without a support copies the row above; row
  * 0 is filled from the first of rows 1..2 with a support (all 0 if neither has one).
  */
class LatticeFillR7(p: ElasParams) extends LatticeFill(p) {
  private val pairStep = WireDefault(false.B) // an interpolated node advances the pair's (q, r)
  val eps = p.fillEpsilon
  val above = SyncReadMem(colsMax, UInt(dBits.W)) // the filled row above; node i read before it is rewritten
  val up = above.read(col(i))
  val near = absDiff(aVal, bVal) <= eps.U

  // The pair's division: 2D = 2G qd + rd with 0 <= rd < 2G (D = bVal - aVal, G = bIdx - aIdx), then per node
  // (q, r) <- (q + qd, r + rd), carrying 2G into q: q = d_a + floor((G + 2tD) / (2G)) at node a + t.
  val gW = idxW
  val segReady = Reg(Bool())
  val g = Reg(UInt(gW.W))
  val qd = Reg(SInt((dBits + 2).W))
  val rd = Reg(UInt((gW + 1).W))
  val segQ = Reg(SInt((dBits + 2).W))
  val segR = Reg(UInt((gW + 2).W))
  val divNum = Reg(UInt(dBits.W)) // |D| shifted out, quotient shifted in
  val divRem = Reg(UInt(gW.W))
  val divCnt = Reg(UInt(log2Ceil(dBits + 1).W))
  val divNeg = Reg(Bool())

  val rSum = segR +& rd
  val carry = rSum >= (g << 1)
  val qNext = segQ + qd + carry.asUInt.zext
  val rNext = Mux(carry, rSum - (g << 1), rSum)
  // (q, r) of the node being decided, registered in sNode: the pair's add-and-carry then stays out of sEmit's
  // output path (segQ, segR hold from sNode until the node is emitted)
  val pairQ = Reg(SInt((dBits + 2).W))
  val pairR = Reg(UInt((gW + 2).W))

  val needDiv = useList && !bHere && both && near && !segReady

  // decide (sNode) into registers, emit (sEmit): the memory reads and the jump / pair arithmetic sit in
  // different cycles (3 cycles per node). sNode registers the candidates and the choices, so sEmit only selects
  // among registers.
  val selHere = Reg(Bool()) //  a support: fixedVal
  val selPair = Reg(Bool()) //  interpolated: pairQ
  val fixedVal = Reg(UInt(dBits.W)) // a support, a copy, row 0 all zero, or one side only
  // The jump takes the one of lo = min(aVal, bVal), hi = max(aVal, bVal) nearer the value above, a tie to lo:
  // |hi - up| < |lo - up| exactly when
  // 2 up > lo + hi = aVal + bVal (for lo < hi; for lo = hi both give the same value), one add and one compare.
  // As one choice of bVal or aVal: the jump takes bVal when "hi" and "b is the higher" agree. The two are registered
  // apart and compared in sEmit's select: the row above's read and the compare already fill sNode's clock.
  val jumpHi = useAbove && (up << 1) > (aVal +& bVal)
  val selJump = Reg(Bool())
  val jumpHiReg = Reg(Bool())
  val bHigher = Reg(Bool())
  val jumpA = Reg(UInt(dBits.W))
  val jumpBVal = Reg(UInt(dBits.W))
  when(state === sNode && !needDiv) {
    selHere := useList && bHere
    selPair := useList && !bHere && both && near
    // the jump's choice is registered beside both candidates (choosing in sNode put it behind the list read)
    selJump := !(zeros || !useList || bHere || !aValid || !kIn)
    jumpHiReg := jumpHi
    bHigher := aVal < bVal
    jumpA := aVal
    jumpBVal := bVal
    fixedVal := Mux(zeros, 0.U, Mux(!useList, up, Mux(bHere || !aValid, bVal, aVal)))
    pairQ := qNext
    pairR := rNext
    state := sEmit
  }
  value := Mux(selPair, pairQ.asUInt(dBits - 1, 0), Mux(selJump, Mux(jumpHiReg === bHigher, jumpBVal, jumpA), fixedVal))

  when(state === sNode && needDiv) {
    val gNew = bIdx - aIdx
    g := gNew
    divNum := absDiff(bVal, aVal)
    divNeg := bVal < aVal
    divRem := 0.U
    divCnt := 0.U
    state := sDiv
  }
  when(state === sDiv) {
    val shifted = Cat(divRem, divNum(dBits - 1))
    val ge = shifted >= g
    val rem = Mux(ge, shifted - g, shifted)
    divRem := rem
    divNum := Cat(divNum(dBits - 2, 0), ge)
    divCnt := divCnt + 1.U
    when(divCnt === (dBits - 1).U) {
      // floor and a non-negative remainder for a negative D: qd = -q0 (rem = 0) or -q0 - 1, rd = 2 (g - rem). Both
      // outcomes of the last step's compare are formed from registers beside it, which then only selects one: with
      // q0 = 2n + ge, -q0 = -2n - ge; rem = shifted - g or shifted, g - rem = 2g - shifted or g - shifted.
      val twiceN = Cat(divNum(dBits - 2, 0), 0.U(1.W)).zext
      val (zeroIfGe, zeroIfLt) = (shifted === g, shifted === 0.U)
      val qdIfLt = Mux(divNeg, Mux(zeroIfLt, -twiceN, -twiceN - 1.S), twiceN)
      val qdIfGe = Mux(divNeg, Mux(zeroIfGe, -twiceN - 1.S, -twiceN - 2.S), twiceN + 1.S)
      qd := Mux(ge, qdIfGe, qdIfLt)
      val rdIfLt = Mux(divNeg && !zeroIfLt, g - shifted, shifted)
      val rdIfGe = Mux(divNeg && !zeroIfGe, (g << 1) - shifted, shifted - g)
      rd := Mux(ge, rdIfGe, rdIfLt) << 1
      segQ := aVal.zext
      segR := g
      segReady := true.B
      state := sNode
    }
  }
  lateWrite(above, doEmit, col(i), value)
  when(doEmit) {
    when(pairStep) { segQ := pairQ; segR := pairR }
    when(selHere) { segReady := false.B }
  }
  when(state === sRowWait) { segReady := false.B }
  pairStep := selPair
  doEmit := state === sEmit && output.free
  here := selHere
  hereVal := fixedVal

  rowReady := frameDone || Mux(procJ === 0.U, rowsIn >= 3.U, rowsIn > procJ)
  // row 0 (never a support row): the first of rows 1..2 with a support, filled without a row above
  val rowZeroFromBelow = procJ === 0.U && counts(0) === 0.U
  val one = rowsIn > 1.U && counts(1) =/= 0.U
  val two = rowsIn > 2.U && counts(2) =/= 0.U
  when(rowZeroFromBelow) { rowWaitAddr := Mux(one, colsMax.U, (2 * colsMax).U) }
  when(state === sRowWait && rowReady && rowZeroFromBelow) {
    n := Mux(one, counts(1), counts(2))
    useList := one || two
    zeros := !one && !two
  }
}

/** The paper's rule (the class doc of [[LatticeFill]]): a support keeps its value; otherwise a horizontal pair of
  * supports within sDelta pixels, else a vertical one, gives their mean (or the smaller when they differ by more
  * than epsilon); otherwise fillC.
  */
class LatticeFillPaper(p: ElasParams) extends LatticeFill(p) {
  private val reach = p.sDelta / step // R: lattice rows within sDelta of a node (plus possibly a clipped last row)
  // the full values of every slot, one memory per slot (a column of the look-ahead per read), written as lateWrite
  // does, with one set of registers for all slots
  val ring = Seq.fill(slots)(SyncReadMem(colsMax, valueType))
  locally {
    val e = RegNext(VecInit((0 until slots).map(s => write && writeSlot === s.U)), VecInit(Seq.fill(slots)(false.B)))
    val a = RegEnable(col(writeCol), write)
    val d = RegEnable(io.in.bits.data, write)
    for ((mem, s) <- ring.zipWithIndex) when(e(s)) { mem.write(a, d) }
  }
  val sDelta = p.sDelta.U
  def clip(x: UInt, last: UInt): UInt = Mux(x > last, last, x)
  def pair(x: UInt, y: UInt): UInt = Mux(absDiff(x, y) <= p.epsilon.U, ((x +& y +& 1.U) >> 1)(dBits - 1, 0), Mux(x < y, x, y))

  val aU = Reg(UInt(coordW.W))
  val u = clip(uRaw, wLast)
  // b right of i within sDelta px: (b - i) step <= sDelta unless b is the last column, whose pixel column W - 1
  // may be nearer than a step (a support left of i is never the last column, so aU = a step)
  val bReach = Mux(bIdx === lw - 1.U, wLast - uRaw <= sDelta, bIdx - i <= reach.U)
  val horizontal = aValid && u - aU <= sDelta && kIn && bReach

  // last support above in this column (valid, pixel row, value)
  val lastAbove = SyncReadMem(colsMax, UInt((1 + coordW + dBits).W))
  val la = lastAbove.read(col(i))
  val laValid = la(coordW + dBits)
  val laV = la(coordW + dBits - 1, dBits)
  val laVal = la(dBits - 1, 0)
  val v = Reg(UInt(coordW.W)) // pixel row of procJ, set at row start
  val topOk = procJ =/= 0.U && laValid && v - laV <= sDelta

  // nearest support below within sDelta px: offsets 1 .. R + 1 of the ring (R + 2 is never within reach, and its
  // slot may be the one being written), first hit wins
  val column = ring.map(_.read(col(i)))
  // Whether row procJ + o exists and lies within sDelta px is fixed for the whole row (every such row is complete
  // before the row starts): one register per offset, set at row start.
  val offsets = 1 to math.min(reach + 1, slots - 1)
  val rowOk = Reg(Vec(offsets.length, Bool()))
  when(state === sRowWait) {
    v := clip(vRaw, hLast)
    for ((o, x) <- offsets.zipWithIndex)
      rowOk(x) := procJ +& o.U < rowsIn && clip(vRaw +& (o * step).U, hLast) - clip(vRaw, hLast) <= sDelta
  }
  val below = offsets.zipWithIndex.map { case (o, x) =>
    val d = VecInit((0 until slots).map(s => column((s + o) % slots)))(procSlot) // row procJ + o
    (rowOk(x) && d >= 0.S, d.asUInt(dBits - 1, 0))
  }
  val bottomOk = below.map(_._1).reduce(_ || _)
  val bottom = PriorityMux(below.map(_._1) :+ true.B, below.map(_._2) :+ 0.U(dBits.W))
  val vertical = topOk && bottomOk

  // decide (sNode) into registers, then emit (sEmit): the memory reads and the pair arithmetic sit in different
  // cycles (3 cycles per node, far below step^2)
  val selSup = Reg(Bool())
  val selPair = Reg(Bool())
  val pa = Reg(UInt(dBits.W))
  val pb = Reg(UInt(dBits.W))
  when(state === sNode) {
    selSup := bHere
    selPair := horizontal || vertical
    pa := Mux(bHere || horizontal, Mux(bHere, bVal, aVal), laVal)
    pb := Mux(horizontal, bVal, bottom)
    state := sEmit
  }
  value := Mux(selSup, pa, Mux(selPair, pair(pa, pb), p.fillC.U))
  here := selSup
  hereVal := pa
  doEmit := state === sEmit && output.free

  when(doEmit && selSup) { aU := u }
  lateWrite(lastAbove, doEmit && (procJ === 0.U || selSup), col(i), Cat(selSup, v, pa)) // row 0 clears the previous frame

  rowReady := frameDone || rowsIn > procJ +& (reach + 1).U
}

object LatticeFill {
  /** The fill unit of the configuration's rule. */
  def apply(p: ElasParams): LatticeFill = p.fillRule match {
    case FillRule.R7 => new LatticeFillR7(p)
    case FillRule.Paper => new LatticeFillPaper(p)
  }
  /** Row slots: r7 keeps rows 0..2 for row 0 plus the row being written; paper keeps rows j .. j + R + 1 plus the
    * row being written (R = floor(sDelta / step)), never more than the whole lattice plus one.
    */
  def slots(p: ElasParams): Int = p.fillRule match {
    case FillRule.R7 => 4
    case FillRule.Paper => math.max(2, math.min(p.sDelta / p.candidateStep + 3, p.latticeRowsMax + 1))
  }
  def idxBits(p: ElasParams): Int = log2Ceil(p.latticeColsMax + 1)
  /** Pixel coordinates of nodes, including the unclipped i * step + (slots + 1) * step of the look-ahead. */
  def coordBits(p: ElasParams): Int =
    log2Ceil(math.max(p.maxWidth, p.maxHeight) + (slots(p) + 2) * p.candidateStep + 1)

  /** Worst-case cycles for one lattice row of `lw` nodes (r7: every other node a support, each pair divided). */
  def rowCycles(p: ElasParams, lw: Int): Int = p.fillRule match {
    case FillRule.R7 => 3 * lw + (lw + 1) / 2 * p.signedDispBits + 2
    case FillRule.Paper => 3 * lw + 2
  }

  def memorySummary(p: ElasParams): Seq[MemoryUse] = {
    val s = slots(p)
    val lists = MemoryUse("LatticeFill", "lists", s * p.latticeColsMax, idxBits(p) + p.dispBits,
      s"$s row slots of (column, value) support lists, one Mem 1R1W read into a register (read-first; the write " +
        "of the read's clock is forwarded)")
    p.fillRule match {
      case FillRule.R7 => Seq(lists,
        MemoryUse("LatticeFill", "above", p.latticeColsMax, p.dispBits, "the filled row above, SyncReadMem 1R1W"))
      case FillRule.Paper => Seq(lists,
        MemoryUse("LatticeFill", "ring", p.latticeColsMax, s * p.signedDispBits,
          s"$s lattice rows of ${p.signedDispBits}-bit values, one SyncReadMem 1R1W per row"),
        MemoryUse("LatticeFill", "lastAbove", p.latticeColsMax, 1 + coordBits(p) + p.dispBits,
          "per column the last support above (valid, pixel row, value), SyncReadMem 1R1W"))
    }
  }
}
