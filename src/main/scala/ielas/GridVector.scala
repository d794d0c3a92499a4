package ielas

import chisel3._
import chisel3.util._

/** Stage `grid`: the grid vectors of both views from the filtered support lattice (docs/ALGORITHM.md "grid").
  *
  * Input: the [[SupportFilter]] stream (lattice raster order, every node, -1 = none, sof / eol / eof). Node (j, i)
  * sits at pixel (u, v) = (min(i step, W - 1), min(j step, H - 1)); frameWidth / frameHeight are sampled at the
  * input's start of frame (so the top holds them until the lattice stream of the frame begins; video IP holds them
  * for the whole frame), giving Gw = ceil(W / gridSize), Gh = ceil(H / gridSize). A support d marks d-1..d+1
  * (clipped to 0..dispMax) in cell (v / gridSize, x / gridSize), x = u (left view) or u - d (right view).
  * Output: one beat per grid cell in grid raster order (eol = last cell of a grid row, eof = last cell): the
  * smallest storedDisparities disparities of the 3x3 dilation (cells inside the grid) of the marks, ascending,
  * -1 = unused slot.
  *
  * Buffer: a ring of 4 grid-row slots per view (row gy in slot gy mod 4), one word of dispMax+1 mark bits per cell:
  *   mark bits = 2 views x 4 x gridColsMax x (dispMax + 1)   (kitti: 2 x 4 x 63 x 256 = 129,024 bits),
  * one SyncReadMem 1R1W per view (4 gridColsMax words of dispMax + 1 bits), plus per view a valid bit per slot and
  * cell (2 x 4 x gridColsMax flip-flops) so a slot is emptied in one cycle instead of being cleared word by word.
  * Nothing grows with the image height.
  * Grid row gy is emitted once every node of grid rows <= gy + 1 has been marked (a node of row gy + 2 has passed
  * the mark pipeline, or the frame's last node has); it reads rows gy - 1, gy, gy + 1 while row gy + 2 is marked
  * in the fourth slot. The input stalls only when it reaches grid row gy + 3 while row gy is still being emitted
  * (or when a new frame arrives while the previous one is still being emitted).
  *
  * Marking: a read-modify-write pipeline (register, read, OR + write) taking one node per clock; the write of the
  * previous cycle is forwarded. Emission: per column, the three rows' words are read one after another through the
  * same read port (marks have priority) and ORed (vertical dilation); a cell ORs three such columns (horizontal)
  * and a priority encoder takes `lanes` lowest set bits per cycle (lowest bit = m & -m, an adder carry chain and an
  * OR-tree encoder). A cell takes max(ceil(storedDisparities / lanes), 4) + 1 cycles without read-port contention
  * ([[GridVector.cellCycles]]), far below the gridSize^2 pixel clocks of one cell at 1 pixel per clock.
  */
class GridVector(p: ElasParams) extends Module {
  private val gs = p.gridSize
  private val nd = p.dispMax + 1
  private val sd = p.storedDisparities
  private val lanes = GridVector.lanes(p)
  private val slots = GridVector.slots
  private val colsMax = p.gridColsMax
  private val colW = log2Ceil(colsMax + 3) //   grid columns, up to Gw + 2 (fetches past the last column)
  private val rowW = log2Ceil(p.gridRowsMax + 4) // grid rows, up to Gh + 3 (stall compare)
  private val addrW = log2Ceil(slots * colsMax)
  private val cntW = log2Ceil(sd + 1)
  private val valueType = SInt((p.dispBits + 1).W)

  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(SInt((p.dispBits + 1).W))))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val out = Decoupled(new Framed(new GridCellPair(p)))
  })

  private def div(x: UInt): UInt = GridVector.divide(x, gs)

  // ---- frame state ----
  val width = RegInit(0.U(p.colBits.W))
  val height = RegInit(0.U(p.rowBits.W))
  val gw = RegInit(1.U(colW.W)) // grid columns of the frame
  val gh = RegInit(1.U(rowW.W)) // grid rows of the frame
  val inBusy = RegInit(false.B) //   lattice nodes of a frame are still expected
  val emitBusy = RegInit(false.B) // grid rows of a frame are still to be emitted
  val emitRow = RegInit(0.U(rowW.W)) // the grid row being (or next to be) emitted
  val markedRow = RegInit(0.U(rowW.W)) // grid row of the last node through the mark pipeline
  val markedAll = RegInit(false.B) //    the frame's last node went through the mark pipeline

  // ---- input: node position ----
  val nodeU = RegInit(0.U(p.colBits.W))
  val nodeV = RegInit(0.U(p.rowBits.W))
  val inRow = RegInit(0.U(rowW.W)) // nodeV / gridSize

  val start = io.in.valid && io.in.bits.sof && !inBusy && !emitBusy
  io.in.ready := Mux(inBusy, inRow < emitRow +& 3.U, !io.in.bits.sof || !emitBusy)
  val accept = io.in.fire && (inBusy || start)
  val w = Mux(start, io.frameWidth, width)
  val h = Mux(start, io.frameHeight, height)
  val u = Mux(start, 0.U, nodeU)
  val v = Mux(start, 0.U, nodeV)
  val row = Mux(start, 0.U, inRow)

  when(start) {
    width := io.frameWidth; height := io.frameHeight
    gw := div(io.frameWidth - 1.U) + 1.U
    gh := div(io.frameHeight - 1.U) + 1.U
    inBusy := true.B; emitBusy := true.B
    emitRow := 0.U; markedRow := 0.U; markedAll := false.B
    nodeV := 0.U; inRow := 0.U // the start beat is node (0, 0) and no row ends on it (Lw >= 2)
  }
  when(accept) {
    when(io.in.bits.eol) {
      val nextV = Mux(v +& p.candidateStep.U < h, v + p.candidateStep.U, h - 1.U)
      nodeU := 0.U
      nodeV := nextV
      inRow := div(nextV)
      when(io.in.bits.eof) { inBusy := false.B }
    }.otherwise {
      nodeU := Mux(u +& p.candidateStep.U < w, u + p.candidateStep.U, w - 1.U)
    }
  }

  // ---- mark pipeline: s1 = position (register), s2 = the words read for it (OR + write) ----
  class Mark extends Bundle {
    val node = Bool() //    a lattice node (with or without support)
    val support = Bool()
    val rightOk = Bool() // u - d >= 0 (always for checked supports; kept as the golden model keeps it)
    val bits = UInt(nd.W)
    val slot = UInt(2.W)
    val row = UInt(rowW.W)
    val colL = UInt(colW.W)
    val colR = UInt(colW.W)
    val last = Bool()
  }
  val d = io.in.bits.data
  val x = u.zext -& d
  def idle[T <: Data](gen: T)(valid: T => Bool): T = { val w = Wire(gen); w := DontCare; valid(w) := false.B; w }
  val s1 = RegInit(idle(new Mark)(_.node))
  s1.node := accept
  s1.support := d >= 0.S
  s1.rightOk := x >= 0.S
  s1.bits := ((7.U(3.W) << d.asUInt(p.dispBits - 1, 0)) >> 1)(nd - 1, 0) // d-1, d, d+1 clipped to 0..dispMax
  s1.slot := row(1, 0)
  s1.row := row
  s1.colL := div(u)
  s1.colR := div(x.asUInt(p.colBits - 1, 0))
  s1.last := io.in.bits.eof
  val s2 = RegInit(idle(new Mark)(_.node))
  s2 := s1

  val slotBase = VecInit((0 until slots).map(s => (s * colsMax).U(log2Ceil(slots * colsMax + 1).W)))
  def address(slot: UInt, col: UInt): UInt = (slotBase(slot) +& col)(addrW - 1, 0)

  val memL = SyncReadMem(slots * colsMax, UInt(nd.W))
  val memR = SyncReadMem(slots * colsMax, UInt(nd.W))
  /** A valid bit per slot and cell: a word whose bit is clear reads as empty. */
  val validL = RegInit(VecInit(Seq.fill(slots)(0.U(colsMax.W))))
  val validR = RegInit(VecInit(Seq.fill(slots)(0.U(colsMax.W))))

  // ---- emission column fetch: the words of rows gy-1, gy, gy+1 at column fCol, one per cycle, ORed ----
  val fCol = RegInit(0.U(colW.W))
  val fK = RegInit(3.U(2.W)) // rows issued so far (3 = all)
  val fDone = RegInit(true.B) // accL / accR hold the vertical OR of column fCol
  val accL = Reg(UInt(nd.W))
  val accR = Reg(UInt(nd.W))
  def fetch(col: UInt): Unit = {
    fCol := col; fK := 0.U; accL := 0.U; accR := 0.U
    fDone := col >= gw
  }

  val markRead = s1.node && s1.support // marks have the read ports
  val fIssue = !fDone && fK =/= 3.U && !markRead
  val fSlot = (emitRow + fK + 3.U)(1, 0) // slot of row emitRow - 1 + fK
  val fExists = MuxLookup(fK, false.B)(Seq(0.U -> (emitRow =/= 0.U), 1.U -> true.B, 2.U -> (emitRow + 1.U < gh)))
  val fAddr = address(fSlot, fCol)
  val rdL = memL.read(Mux(markRead, address(s1.slot, s1.colL), fAddr), markRead || fIssue)
  val rdR = memR.read(Mux(markRead, address(s1.slot, s1.colR), fAddr), markRead || fIssue)
  val fCapture = RegNext(fIssue, false.B)
  val fCaptureLast = RegNext(fIssue && fK === 2.U, false.B)
  val fUseL = RegNext(fExists && (validL(fSlot) >> fCol)(0))
  val fUseR = RegNext(fExists && (validR(fSlot) >> fCol)(0))
  when(fIssue) { fK := fK + 1.U }
  when(fCapture) {
    accL := accL | Mux(fUseL, rdL, 0.U)
    accR := accR | Mux(fUseR, rdR, 0.U)
    when(fCaptureLast) { fDone := true.B }
  }

  // ---- mark write (s2): old word (or the word written last cycle) OR the three bits ----
  class LastWrite extends Bundle {
    val en = Bool()
    val addr = UInt(addrW.W)
    val data = UInt(nd.W)
  }
  def markView(mem: SyncReadMem[UInt], valid: Vec[UInt], rd: UInt, col: UInt, en: Bool): Unit = {
    val addr = address(s2.slot, col)
    val last = Wire(new LastWrite)
    val prev = RegInit(idle(new LastWrite)(_.en))
    prev := last
    val old = Mux(prev.en && prev.addr === addr, prev.data, Mux((valid(s2.slot) >> col)(0), rd, 0.U))
    last.en := en
    last.addr := addr
    last.data := old | s2.bits
    when(en) {
      mem.write(addr, last.data)
      valid(s2.slot) := valid(s2.slot) | UIntToOH(col(log2Ceil(colsMax + 1) - 1, 0), colsMax)
    }
  }
  markView(memL, validL, rdL, s2.colL, s2.node && s2.support)
  markView(memR, validR, rdR, s2.colR, s2.node && s2.support && s2.rightOk)
  when(s2.node) {
    markedRow := s2.row
    when(s2.last) { markedAll := true.B }
  }

  // ---- emission ----
  val sIdle :: sPrime0 :: sPrime1 :: sExtract :: sEmit :: Nil = Enum(5)
  val state = RegInit(sIdle)
  val gx = RegInit(0.U(colW.W))
  val colBL = Reg(UInt(nd.W)) // vertical ORs of columns gx (B) and gx + 1 (C); column gx + 2 is being fetched
  val colBR = Reg(UInt(nd.W))
  val colCL = Reg(UInt(nd.W))
  val colCR = Reg(UInt(nd.W))
  val maskL = Reg(UInt(nd.W)) // dilated marks not yet taken
  val maskR = Reg(UInt(nd.W))
  val cntL = Reg(UInt(cntW.W))
  val cntR = Reg(UInt(cntW.W))
  val resL = Reg(Vec(sd, valueType))
  val resR = Reg(Vec(sd, valueType))

  val outValid = RegInit(false.B)
  val outBits = Reg(new Framed(new GridCellPair(p)))
  val outFree = !outValid || io.out.ready
  when(io.out.fire) { outValid := false.B }
  io.out.valid := outValid
  io.out.bits := outBits

  def beginCell(left: UInt, right: UInt): Unit = {
    maskL := left; maskR := right; cntL := 0.U; cntR := 0.U
    resL.foreach(_ := (-1).S); resR.foreach(_ := (-1).S)
    state := sExtract
  }

  /** Takes up to `lanes` lowest set bits of `mask` into res(cnt..); returns whether the cell is complete after it. */
  def extract(mask: UInt, cnt: UInt, res: Vec[SInt]): Bool = {
    var m = mask
    var c = cnt
    for (_ <- 0 until lanes) {
      val low = m & (~m + 1.U) // the lowest set bit
      val take = m.orR && c < sd.U
      val value = OHToUInt(low).pad(p.dispBits).zext
      for (k <- 0 until sd) when(take && c === k.U) { res(k) := value }
      m = Mux(take, m & ~low, m)
      c = Mux(take, c + 1.U, c)
    }
    mask := m
    cnt := c
    m === 0.U || c === sd.U
  }

  val rowReady = markedAll || markedRow >= emitRow +& 2.U

  switch(state) {
    is(sIdle) {
      when(emitBusy && rowReady) { fetch(0.U); state := sPrime0 }
    }
    is(sPrime0) {
      when(fDone) { colBL := accL; colBR := accR; fetch(1.U); state := sPrime1 }
    }
    is(sPrime1) {
      when(fDone) {
        colCL := accL; colCR := accR
        beginCell(colBL | accL, colBR | accR)
        gx := 0.U
        fetch(2.U)
      }
    }
    is(sExtract) {
      val doneL = extract(maskL, cntL, resL)
      val doneR = extract(maskR, cntR, resR)
      when(doneL && doneR) { state := sEmit }
    }
    is(sEmit) {
      when(outFree && fDone) {
        val eol = gx === gw - 1.U
        val lastRow = emitRow === gh - 1.U
        outValid := true.B
        outBits.data.left := resL
        outBits.data.right := resR
        outBits.sof := gx === 0.U && emitRow === 0.U
        outBits.eol := eol
        outBits.eof := eol && lastRow
        when(eol) {
          // row gy - 1 is read for the last time; the last row also frees its own slot
          val prevSlot = (emitRow + 3.U)(1, 0)
          when(emitRow =/= 0.U) { validL(prevSlot) := 0.U; validR(prevSlot) := 0.U }
          when(lastRow) {
            validL(emitRow(1, 0)) := 0.U; validR(emitRow(1, 0)) := 0.U
            emitBusy := false.B
          }
          emitRow := emitRow + 1.U
          state := sIdle
        }.otherwise {
          colBL := colCL; colBR := colCR
          colCL := accL; colCR := accR
          beginCell(colBL | colCL | accL, colBR | colCR | accR) // columns gx .. gx + 2 = the next cell's window
          gx := gx + 1.U
          fetch(gx + 3.U)
        }
      }
    }
  }
  // a new frame starts with every slot empty (also after a frame cut short upstream)
  when(start) { validL.foreach(_ := 0.U); validR.foreach(_ := 0.U) }
}

object GridVector {
  /** Grid-row slots per view: rows gy - 1 .. gy + 1 being emitted plus row gy + 2 being marked. */
  val slots: Int = 4

  /** Disparities the priority encoder takes per cycle: the fewest that keep a cell within gridSize^2 / 2 cycles. */
  def lanes(p: ElasParams): Int = {
    val budget = p.gridSize * p.gridSize / 2
    (1 to p.storedDisparities).find(l => (p.storedDisparities + l - 1) / l + 1 <= budget).getOrElse(p.storedDisparities)
  }

  /** Cycles per cell without read-port contention: extraction (at least the 4 cycles of the next column's fetch),
    * then the output transfer.
    */
  def cellCycles(p: ElasParams): Int = math.max((p.storedDisparities + lanes(p) - 1) / lanes(p), 4) + 1

  /** Cycles to emit one grid row of `w` pixels: two column fetches to prime, then every cell. */
  def rowCycles(p: ElasParams, w: Int): Int = 2 * 4 + p.gridCount(w) * cellCycles(p)

  /** (m, s) with floor(x / n) = (x m) >> s for every x < 2^bits, found and checked exhaustively at elaboration. */
  def reciprocal(n: Int, bits: Int): (BigInt, Int) = {
    val base = bits + log2Ceil(n)
    (base to base + 8).iterator.map(s => ((BigInt(1) << s) + n - 1) / n -> s).find { case (m, s) =>
      (0 until (1 << bits)).forall(x => ((BigInt(x) * m) >> s) == x / n)
    }.getOrElse(throw new IllegalArgumentException(s"gridSize = $n: no reciprocal for $bits-bit values"))
  }

  /** floor(x / n) for a constant n, as a constant multiply (no divider). */
  def divide(x: UInt, n: Int): UInt = {
    val (m, s) = reciprocal(n, x.getWidth)
    ((x * m.U) >> s).asUInt
  }

  def memorySummary(p: ElasParams): Seq[MemoryUse] = Seq(
    MemoryUse("Grid", "marks", slots * p.gridColsMax, 2 * (p.dispMax + 1),
      s"$slots grid-row slots x ${p.gridColsMax} cells of ${p.dispMax + 1} mark bits, one SyncReadMem 1R1W per view"))
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
  val support = Module(new SupportChain(p))
  val filter = Module(new SupportFilter(p))
  val grid = Module(new GridVector(p))
  support.io.in <> io.in
  support.io.frameWidth := io.frameWidth
  support.io.frameHeight := io.frameHeight
  filter.io.in <> support.io.out
  grid.io.in <> filter.io.out
  grid.io.frameWidth := io.frameWidth
  grid.io.frameHeight := io.frameHeight
  io.out <> grid.io.out
}
