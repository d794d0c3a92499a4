package ielas

import chisel3._
import chisel3.util._

/** Stage `grid`: the grid vectors of both views from the filtered support lattice (docs/ALGORITHM.md "grid").
  *
  * Input: the [[SupportFilter]] stream (lattice raster order, every node, -1 = none, sof / eol / eof). Node (j, i)
  * sits at pixel (u, v) = (min(i step, W - 1), min(j step, H - 1)); frameWidth / frameHeight are sampled at the
  * input's start of frame (so the top holds them until the lattice stream of the frame begins; video IP holds them
  * for the whole frame). A support d marks d-1..d+1 (clipped to 0..dispMax) in cell (v / gridSize, x / gridSize),
  * x = u (left view) or u - d (right view). No divider: u and v are walked as quotient and remainder by gridSize,
  * and (u - d) / gridSize subtracts d / gridSize and d mod gridSize from a table (2^dispBits entries). The grid size
  * follows from the stream: Gw - 1 = the cell column of a lattice row's last node (u = W - 1), Gh - 1 = the cell
  * row of the frame's last node.
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
  * and a priority encoder takes `lanes` lowest set bits per cycle (lowest bit = m & -m in two levels of 16-bit
  * groups; the bit's index is encoded and stored a clock later). A cell takes
  * max(ceil(storedDisparities / lanes) + 1, 4) + 1 cycles without read-port contention (the + 1: a cell's end is
  * decided on the registered mask, which keeps the encoder and the 256-bit zero test in separate cycles and gives
  * the last taken index its clock to be stored; [[GridVector.cellCycles]]; 22 at storedDisparities 20 with 1 lane),
  * far below the gridSize^2 pixel clocks of
  * one cell at 1 pixel per clock (400 at gridSize 20). Exception: at gridSize 2 a cell has only 4 pixel clocks and
  * the stage back-pressures (about 1.3x the pixel time); gridSize >= 3 keeps up.
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
  private val valueType = SInt(p.signedDispBits.W)

  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(SInt(p.signedDispBits.W))))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val out = Decoupled(new Framed(new GridCellPair(p)))
  })

  // ---- frame state ----
  val gw = RegInit(1.U(colW.W)) // grid columns of the frame: column of the last node of a lattice row + 1
  val inBusy = RegInit(false.B) //   lattice nodes of a frame are still expected
  val emitBusy = RegInit(false.B) // grid rows of a frame are still to be emitted
  val emitRow = RegInit(0.U(rowW.W)) // the grid row being (or next to be) emitted
  val markedRow = RegInit(0.U(rowW.W)) // grid row of the last node through the mark pipeline
  val markedAll = RegInit(false.B) //    the frame's last node went through the mark pipeline (markedRow = Gh - 1)

  // ---- input: node position (u, v) and its grid cell, kept as quotient and remainder by gridSize (no divider) ----
  // A node is step pixels after the previous one, or the last pixel when less than a step is left. The walk keeps
  // the pixels left to the last one (room) and whether a full step fits, both a cycle ahead, and the cell and
  // remainder of the last pixel in registers: the next node is then a constant step of the remainder or a register
  // copy, never an add feeding a compare feeding an add in one cycle.
  private val step = p.candidateStep
  private val remW = log2Ceil(gs).max(1)
  class Position(posW: Int) extends Bundle {
    val cell = UInt(colW.max(rowW).W)
    val rem = UInt(remW.W)
    val room = UInt(posW.W) // limit - 1 - position
    val fits = Bool() //       room >= step: the next node is a full step away, else it is the last pixel
  }
  /** Cell and remainder of a position, as a bundle for the last-pixel registers. */
  class CellRem extends Bundle {
    val cell = UInt(colW.max(rowW).W)
    val rem = UInt(remW.W)
  }
  /** The first node of a row (or column) of `limit` pixels. */
  def origin(posW: Int, limit: UInt): Position = {
    val o = Wire(new Position(posW))
    o.cell := 0.U; o.rem := 0.U; o.room := limit - 1.U; o.fits := limit > step.U
    o
  }
  /** The next node: a full step (rem + step wraps at most once, as step <= gridSize) or the last pixel. */
  def advance(at: Position, last: CellRem): Position = {
    val next = Wire(chiselTypeOf(at))
    val carry = stepCarries(at)
    val steppedRem = Mux(carry, at.rem - (gs - step).U, at.rem + step.U)
    next.cell := Mux(at.fits, at.cell + carry, last.cell)
    next.rem := Mux(at.fits, steppedRem, last.rem)
    next.room := Mux(at.fits, at.room - step.U, 0.U)
    next.fits := at.fits && at.room >= (2 * step).U
    next
  }
  def stepCarries(at: Position): Bool = at.rem >= (gs - step).U
  /** rem + room, the last pixel's remainder before it wraps (< gridSize + 2 step <= 3 gridSize while exact). */
  def lastSum(at: Position): UInt = {
    val nearBits = math.min(log2Ceil(2 * step + 1), at.room.getWidth)
    at.rem +& at.room(nearBits - 1, 0)
  }
  /** The next node lies in the next cell: a full step carries, or the last pixel is in a later cell. */
  def nextCellUp(at: Position): Bool = Mux(at.fits, stepCarries(at), lastSum(at) >= gs.U)
  /** Cell and remainder of the last pixel (position + room), exact while room < 2 step. That holds one node before
    * the last step and stays true (the target does not move), so registering it each cycle has it ready in time.
    */
  def lastPixel(at: Position): CellRem = {
    val sum = lastSum(at)
    val wraps = Mux(sum >= (2 * gs).U, 2.U, Mux(sum >= gs.U, 1.U, 0.U))
    val l = Wire(new CellRem)
    l.cell := at.cell + wraps
    l.rem := sum - Mux(sum >= (2 * gs).U, (2 * gs).U, Mux(sum >= gs.U, gs.U, 0.U))
    l
  }
  val nodeU = RegInit(0.U.asTypeOf(new Position(p.colBits)))
  val nodeV = RegInit(0.U.asTypeOf(new Position(p.rowBits)))
  val rowOrigin = Reg(new Position(p.colBits)) // the first node of every lattice row of the frame
  val lastU = Reg(new CellRem)
  val lastV = Reg(new CellRem)

  // Grid rows from the row being emitted to the next node's row (nodeV.cell - emitRow, 0..3 while inBusy), counted
  // so that ready is a register test: the compare nodeV.cell < emitRow + 3 ran through the input slice's handshake
  // into inBusy, the whole top's worst path. The input stalls at 3 (row gy + 3 while row gy is still emitted).
  val rowsAhead = RegInit(0.U(2.W))
  val emitRowDone = WireDefault(false.B) // the emission's last cell of row emitRow goes out
  val start = io.in.valid && io.in.bits.sof && !inBusy && !emitBusy
  io.in.ready := Mux(inBusy, rowsAhead =/= 3.U, !io.in.bits.sof || !emitBusy)
  val accept = io.in.fire && (inBusy || start)
  val startU = origin(p.colBits, io.frameWidth)
  val startV = origin(p.rowBits, io.frameHeight)
  val u = Mux(start, startU, nodeU)
  val v = Mux(start, startV, nodeV)
  // the start beat's targets are computed from the frame size directly (the registers hold the previous frame's)
  lastU := Mux(start, lastPixel(startU), lastPixel(nodeU))
  lastV := Mux(start, lastPixel(startV), lastPixel(nodeV))

  when(start) {
    inBusy := true.B; emitBusy := true.B
    emitRow := 0.U; markedRow := 0.U; markedAll := false.B
    rowOrigin := startU
    nodeV := startV // the start beat is node (0, 0) and no row ends on it (Lw >= 2)
  }
  // The start beat's next position is computed from the frame size side by side with the registers' (its last
  // pixel, if the first step already reaches it, is the frame width - 1 < step: cell 0), so the start decision
  // only selects between them.
  def startLast(limit: UInt): CellRem = { val l = Wire(new CellRem); l.cell := 0.U; l.rem := limit - 1.U; l }
  when(accept) {
    when(io.in.bits.eol) {
      nodeU := rowOrigin
      nodeV := Mux(start, advance(startV, startLast(io.frameHeight)), advance(nodeV, lastV))
      when(io.in.bits.eof) { inBusy := false.B }
    }.otherwise {
      nodeU := Mux(start, advance(startU, startLast(io.frameWidth)), advance(nodeU, lastU))
    }
  }
  // start sets nodeV.cell and emitRow to 0 (its beat never ends a row: Lw >= 2); a row end moves the next node to
  // the next grid row when the step carries into it or the last pixel lies in it. That test is registered like
  // lastV: nodeV changes only at a row end or a start, and a row end is at least two beats after either.
  val rowUpAhead = RegNext(Mux(start, nextCellUp(startV), nextCellUp(nodeV)), false.B)
  val nodeRowUp = accept && io.in.bits.eol && !start && rowUpAhead
  rowsAhead := Mux(start, 0.U, rowsAhead + nodeRowUp.asUInt - emitRowDone.asUInt)
  assert(!inBusy || (nodeV.cell >= emitRow && nodeV.cell === emitRow +& rowsAhead),
    "GridVector: rowsAhead differs from nodeV.cell - emitRow")
  assert(!(start && io.in.bits.eol), "GridVector: a frame's first lattice node ends its row")

  // ---- mark pipeline: s1 = position (register), s2 = the words read for it (OR + write) ----
  class Mark extends Bundle {
    val node = Bool() //    a lattice node (with or without support)
    val support = Bool()
    val rightOk = Bool() // u - d >= 0 (always for checked supports; kept as the golden model keeps it)
    val d = UInt(p.dispBits.W)
    val slot = UInt(2.W)
    val row = UInt(rowW.W)
    val colL = UInt(colW.W)
    val colR = UInt(colW.W)
    val eol = Bool()
    val last = Bool()
  }
  // right view: (u - d) / gridSize from u's quotient and remainder and a table of d / gridSize, d mod gridSize
  val d = io.in.bits.data.asUInt(p.dispBits - 1, 0)
  val dQuot = VecInit((0 until (1 << p.dispBits)).map(k => (k / gs).U))(d)
  val dRem = VecInit((0 until (1 << p.dispBits)).map(k => (k % gs).U(remW.max(1).W)))(d)
  val colR = u.cell.zext -& dQuot.zext -& (u.rem < dRem).asUInt.zext // negative exactly when u - d < 0
  def idle[T <: Data](gen: T)(valid: T => Bool): T = { val w = Wire(gen); w := DontCare; valid(w) := false.B; w }
  val s1 = RegInit(idle(new Mark)(_.node))
  s1.node := accept
  s1.support := io.in.bits.data >= 0.S
  s1.rightOk := colR >= 0.S
  s1.d := d
  s1.slot := v.cell(1, 0)
  s1.row := v.cell
  s1.colL := u.cell
  s1.colR := colR.asUInt
  s1.eol := io.in.bits.eol
  s1.last := io.in.bits.eof
  val s2 = RegInit(idle(new Mark)(_.node))
  s2 := s1
  val markBits = ((7.U(3.W) << s2.d) >> 1)(nd - 1, 0) // d-1, d, d+1 clipped to 0..dispMax

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
  val fExists = MuxLookup(fK, false.B)(Seq(0.U -> (emitRow =/= 0.U), 1.U -> true.B, 2.U -> (!markedAll || emitRow < markedRow)))
  val fAddr = address(fSlot, fCol)
  val readAddrL = Mux(markRead, address(s1.slot, s1.colL), fAddr)
  val readAddrR = Mux(markRead, address(s1.slot, s1.colR), fAddr)
  val rdL = memL.read(readAddrL, markRead || fIssue)
  val rdR = memR.read(readAddrR, markRead || fIssue)
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
  // The write address and the cell's valid bit are registered from s1, which keeps the address adder and the valid
  // bit select off the forwarding compare's path. A valid bit set by the write during s1 is covered by the
  // forwarding (that write is `prev` in s2); slots are only cleared when no mark for them is in flight.
  /** Returns the write and whether the word read for it is used (not forwarded, of a valid cell). */
  def markView(mem: SyncReadMem[UInt], valid: Vec[UInt], rd: UInt, s1Col: UInt, col: UInt, en: Bool): (LastWrite, Bool) = {
    val addr = RegNext(address(s1.slot, s1Col))
    val wasValid = RegNext((valid(s1.slot) >> s1Col)(0))
    val last = Wire(new LastWrite)
    val prev = RegInit(idle(new LastWrite)(_.en))
    prev := last
    val old = Mux(prev.en && prev.addr === addr, prev.data, Mux(wasValid, rd, 0.U))
    last.en := en
    last.addr := addr
    last.data := old | markBits
    when(en) {
      mem.write(addr, last.data)
      valid(s2.slot) := valid(s2.slot) | UIntToOH(col(log2Ceil(colsMax + 1) - 1, 0), colsMax)
    }
    (last, en && !(prev.en && prev.addr === addr) && wasValid)
  }
  val (writeL, markUsedL) = markView(memL, validL, rdL, s1.colL, s2.colL, s2.node && s2.support)
  val (writeR, markUsedR) = markView(memR, validR, rdR, s1.colR, s2.colR, s2.node && s2.support && s2.rightOk)
  // A mark reads while the previous node writes, often the same cell: that write is forwarded (`prev`) and the word
  // is not used. Emission reads rows whose marks are done (marks then go to a row two slots on).
  CollisionFree.check("GridVector: memL", Seq(memL), Seq(CollisionFree.Read(readAddrL, markUsedL || fCapture && fUseL)),
    Seq(CollisionFree.Write(writeL.en, writeL.addr)))
  CollisionFree.check("GridVector: memR", Seq(memR), Seq(CollisionFree.Read(readAddrR, markUsedR || fCapture && fUseR)),
    Seq(CollisionFree.Write(writeR.en, writeR.addr)))
  when(s2.node) {
    markedRow := s2.row
    when(s2.eol) { gw := s2.colL + 1.U } // every lattice row ends at u = W - 1; row 0 is through long before emission
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

  val output = new OutputRegister(io.out)

  def beginCell(left: UInt, right: UInt): Unit = {
    maskL := left; maskR := right; cntL := 0.U; cntR := 0.U
    resL.foreach(_ := (-1).S); resR.foreach(_ := (-1).S)
    state := sExtract
  }

  // The lowest set bit of a word of dispMax + 1 marks, in two levels so no carry chain runs the whole word: the
  // lowest non-zero group of 16 bits (a 16-bit carry over the groups' OR) and each group's lowest bit (16-bit carries
  // side by side). The taken bit's index is encoded a clock later from the two one-hot words; the cell's end is
  // decided on the registered mask a clock after the last take anyway, so the result is complete in time.
  private val groupW = GridVector.groupWidth
  private val groups = (nd + groupW - 1) / groupW
  class Taken extends Bundle {
    val valid = Bool()
    val slot = UInt(cntW.W) //   result slot
    val group = UInt(groups.W) // one-hot: the group of the taken bit
    val bit = UInt(groupW.W) //   one-hot: the taken bit within its group
  }
  val takenL = RegInit(VecInit(Seq.fill(lanes)(0.U.asTypeOf(new Taken))))
  val takenR = RegInit(VecInit(Seq.fill(lanes)(0.U.asTypeOf(new Taken))))

  private def lowest(x: UInt): UInt = x & (~x + 1.U)

  /** Takes up to `lanes` lowest set bits of `mask` into taken (written to res(cnt..) next cycle). */
  def extract(mask: UInt, cnt: UInt, taken: Vec[Taken]): Unit = {
    var m = mask
    var c = cnt
    for (l <- 0 until lanes) {
      val words = (0 until groups).map(g => m(math.min(nd, (g + 1) * groupW) - 1, g * groupW).pad(groupW))
      val nonZero = VecInit(words.map(_.orR)).asUInt
      val group = lowest(nonZero)
      val bits = words.map(lowest)
      val low = Cat((0 until groups).reverse.map(g => Mux(group(g), bits(g), 0.U(groupW.W))))(nd - 1, 0)
      val take = nonZero.orR && c < sd.U
      taken(l).valid := take
      taken(l).slot := c
      taken(l).group := group
      taken(l).bit := Mux1H(group, bits)
      m = Mux(take, m & ~low, m)
      c = Mux(take, c + 1.U, c)
    }
    mask := m
    cnt := c
  }

  /** Writes the values taken a clock ago into their result slots. */
  def store(taken: Vec[Taken], res: Vec[SInt]): Unit = for (t <- taken) {
    val value = (if (groups == 1) OHToUInt(t.bit) else Cat(OHToUInt(t.group), OHToUInt(t.bit))).pad(p.dispBits).zext
    for (k <- 0 until sd) when(t.valid && t.slot === k.U) { res(k) := value }
  }
  takenL.foreach(_.valid := false.B)
  takenR.foreach(_.valid := false.B)
  store(takenL, resL)
  store(takenR, resR)

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
      // done is decided on the registers (one cycle after the last take), not on the extraction's result
      def done(mask: UInt, cnt: UInt): Bool = mask === 0.U || cnt === sd.U
      when(done(maskL, cntL) && done(maskR, cntR)) { state := sEmit }
        .otherwise { extract(maskL, cntL, takenL); extract(maskR, cntR, takenR) }
    }
    is(sEmit) {
      when(output.free && fDone) {
        val eol = gx === gw - 1.U
        val lastRow = markedAll && emitRow === markedRow
        output.valid := true.B
        output.bits.data.left := resL
        output.bits.data.right := resR
        output.bits.sof := gx === 0.U && emitRow === 0.U
        output.bits.eol := eol
        output.bits.eof := eol && lastRow
        when(eol) {
          // row gy - 1 is read for the last time; the last row also frees its own slot
          val prevSlot = (emitRow + 3.U)(1, 0)
          when(emitRow =/= 0.U) { validL(prevSlot) := 0.U; validR(prevSlot) := 0.U }
          when(lastRow) {
            validL(emitRow(1, 0)) := 0.U; validR(emitRow(1, 0)) := 0.U
            emitBusy := false.B
          }
          emitRow := emitRow + 1.U
          emitRowDone := true.B
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

  /** Mark bits per group of the two-level lowest-bit search (a power of two: the index is group and offset). */
  val groupWidth: Int = 16

  /** Disparities the priority encoder takes per cycle: the fewest that keep a cell within gridSize^2 / 2 cycles;
    * where nothing does (gridSize 2 or 3), the fewest that hide the extraction behind the 4-cycle column fetch.
    */
  def lanes(p: ElasParams): Int = {
    val budget = p.gridSize * p.gridSize / 2
    (1 to p.storedDisparities).find(l => cellCycles(p, l) <= budget).getOrElse((p.storedDisparities + 3) / 4)
  }

  /** Cycles per cell without read-port contention: extraction (at least the 4 cycles of the next column's fetch),
    * then the output transfer. Within the gridSize^2 pixel clocks of a cell for gridSize >= 3; at gridSize 2 (4
    * pixel clocks per cell) the stage cannot keep up with 1 pixel per clock and back-pressures.
    */
  def cellCycles(p: ElasParams, lanes: Int): Int = math.max((p.storedDisparities + lanes - 1) / lanes + 1, 4) + 1
  def cellCycles(p: ElasParams): Int = cellCycles(p, lanes(p))

  /** Cycles to emit one grid row of `w` pixels: two column fetches to prime, then every cell. */
  def rowCycles(p: ElasParams, w: Int): Int = 2 * 4 + p.gridCount(w) * cellCycles(p)

  def memorySummary(p: ElasParams): Seq[MemoryUse] = Seq(
    MemoryUse("Grid", "marks", slots * p.gridColsMax, 2 * (p.dispMax + 1),
      s"$slots grid-row slots x ${p.gridColsMax} cells of ${p.dispMax + 1} mark bits, one SyncReadMem 1R1W per view"))
}
