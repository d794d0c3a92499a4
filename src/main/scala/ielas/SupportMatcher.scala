package ielas

import chisel3._
import chisel3.util._

/** Stage `support`: ratio-tested support matches on the candidate lattice plus the left/right check
  * (docs/ALGORITHM.md / PINNED 3), streaming.
  *
  * Input: the [[Descriptor]] stream (raster order, both views' descriptors per pixel, framing). Output: support_L in
  * lattice raster order, every node (Lh x Lw values, -1 = none), with sof / eol (last node of a lattice row) / eof.
  * frameWidth / frameHeight are sampled at the descriptor stream's start of frame, so the top must hold them from
  * the pixel start of frame until at least descriptorMargin rows later (video IP holds them for the whole frame).
  *
  * Buffers. A lattice row at pixel row v reads only descriptor rows v - r and v + r (the four window corners of
  * both the reference and the target) and the texture test of row v. The capture side therefore keeps, for each of
  * `slots` lattice rows, the two descriptor rows of both views (128 bits per pixel) and one texture bit per pixel
  * and view. Each row kind is split into L = supportLanesUsed column banks (bank = x mod L, word = x / L, both
  * views in one memory, the right view's words after the left's), so one read of word j in every bank is the
  * aligned block of columns jL .. jL + L - 1 and lane k always reads bank k: no rotator, no column mux.
  *   descriptor buffer bits = 2 rows x 2 views x slots x L x ceil(maxWidth / L) x 128
  *   texture buffer bits    = slots x maxWidth x 2
  * (kitti: slots 2, L 32 -> 1,277,952 + 4,968 bits). slots = the smallest K with (K-1)*step >= 2r + 1: the top
  * row of lattice row j + K is written only after lattice row j is finished, which at one pixel every
  * cyclesPerPixel clocks leaves step pixel rows for the search of lattice row j. Nothing grows with the image height.
  *
  * Search (per searched node, one sweep per reference view over d = 0..dhi): the target columns t - r of the sweep
  * are c1 = minC1 .. maxC1 (left reference u: c1 = u - r - d; right reference u': c1 = u' - r + d), each with its
  * partner c1 + 2r. The sweep reads the blocks from the one holding maxC1 + 2r down to the one holding minC1; lane
  * k evaluates c1 = jL + k against the partner in the same block or in the block read the cycle before (its first
  * 2r columns are kept). The reference columns u ± r are read in one cycle (the L consecutive columns from u - r:
  * banks below (u - r) mod L read the next word) and kept in registers.
  *
  * Pipeline (for timing: at most two compare-selects per stage): issue (bank addresses registered) -> block read
  * (read and output registers) -> A: every lane's 16 quarter-descriptor SADs -> A2: two half costs per lane -> B1:
  * lane costs -> B: the lane tree's first level -> C, E: the rest of the lane tree, about half each -> merge into
  * the running best. A sweep's result is final 9 cycles after its last block was issued. The right sweep (u' = u - d1)
  * always runs, without waiting for the left ratio and texture tests; a rejected left result is dropped at the node's
  * decision.
  * Schedule: every sweep follows its own reference read, and two nodes are in flight so that the read port never
  * waits for the pipeline: L(n), L(n+1), R(n), L(n+2), R(n+1), ... (L = left reference read + left sweep, R = right
  * reference read + right sweep, its setup registered from the node's left result). A node's left result arrives
  * while the next node's left sweep runs. Node cycles: 2 reference reads + two sweeps of at least two
  * and at most ceil((dhi + 2r) / L) + 1 blocks (ElasParams.supportNodeCycles), within supportCyclesPerPoint = cyclesPerPixel x
  * step^2 at every named configuration. Only the last searched node of a lattice row (the next one is not searched, or
  * is in the next lattice row, whose slot differs) waits for its own left result: ElasParams.supportDrainCycles, once
  * per lattice row, paid by the row's first node, which lies in the margin and takes one cycle. The node's decision
  * (right result, then the ratio, texture, range and left/right tests, then the output register) overlaps the next
  * node's search; a node that is not searched waits for the previous decision (values stay in raster order).
  * Best/second best are merged over lanes and blocks in ascending d with the smaller d winning a tie (strict "<"
  * against the smaller-d operand), which equals the sequential definition (E1 min, d1 its smallest d, E2 the second
  * smallest of the multiset).
  *
  * Back-pressure: the input stalls only when a slot is still being searched (or a new frame arrives while the
  * previous one is still being searched); the output register stalls the walker (a node's last right block waits
  * while the previous node's decision has not left). Any gaps are fine.
  * A start of frame in the middle of a frame is treated as an ordinary pixel (the top's framing check handles it).
  */
class SupportMatcher(p: ElasParams) extends Module {
  private val r = p.windowRadius
  private val step = p.candidateStep
  private val margin = p.supportMargin
  private val lanes = p.supportLanesUsed
  private val banks = SupportMatcher.banks(p)
  private val bankBits = log2Ceil(banks)
  private val slots = SupportMatcher.slots(p)
  private val slotBits = math.max(1, log2Ceil(slots))
  private val wordsPerRow = SupportMatcher.wordsPerRow(p)
  private val descBits = 8 * p.descriptorBytes
  private val costBits = SupportMatcher.costBits(p)
  private val costInf = ((1 << costBits) - 1).U(costBits.W) // above every real cost
  private val colW = math.max(p.colBits, p.signedDispBits) + 2 // signed column arithmetic (window starts may be < 0)
  private val rowW = p.rowBits + 1
  private val baseW = p.dispBits + 2
  private val firstRow = (margin + step - 1) / step * step // first lattice row that can hold supports

  private def sad(x: UInt, y: UInt): UInt = {
    val unit = Module(new DescriptorSad(x.getWidth / 8))
    unit.io.x := x
    unit.io.y := y
    unit.io.sad
  }

  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(new DescriptorPair(p.descriptorBytes))))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val out = Decoupled(new Framed(SInt(p.signedDispBits.W)))
  })

  // ---- frame state ----
  val width = RegInit(0.U(p.colBits.W))
  val height = RegInit(0.U(p.rowBits.W))
  val capBusy = RegInit(false.B) //  descriptors of a frame are still expected
  val walkBusy = RegInit(false.B) // lattice nodes of a frame are still to be emitted

  // ---- walker position (declared early: the capture side checks slot reuse against it) ----
  val walkU = RegInit(0.U(p.colBits.W)) // pixel column of the current node (min(i*step, W-1))
  val walkV = RegInit(0.U(p.rowBits.W)) // pixel row of the current lattice row
  val walkSlot = RegInit(0.U(slotBits.W))

  // ---- capture: write the rows lattice rows need into their slot ----
  val capX = RegInit(0.U(p.colBits.W))
  val capY = RegInit(0.U(p.rowBits.W))

  /** The next lattice row (its pixel row v and slot) that still needs the pixel row v + offset. */
  class RowTracker(offset: Int) {
    val v = RegInit(firstRow.U(rowW.W))
    val slot = RegInit((firstRow / step % slots).U(slotBits.W))
    val hit: Bool = (capY.zext +& offset.S) === v.zext && v +& margin.U < height // only rows that hold supports
    def restart(): Unit = { v := firstRow.U; slot := (firstRow / step % slots).U }
    def advance(): Unit = { v := v + step.U; slot := Mux(slot === (slots - 1).U, 0.U, slot + 1.U) }
    def rowIs: Bool = (capY.zext +& offset.S) === v.zext
  }
  val topRow = new RowTracker(r)
  val centreRow = new RowTracker(0)
  val bottomRow = new RowTracker(-r)

  // io.in.ready drives the enables of the register slice in front, so it is formed from registers only: whether the
  // row being captured is one the top tracker waits on (constant within a row, set at each row's start), and whether
  // that row's slot is free. The slot of lattice row v is free once the walker has left lattice row v - slots*step;
  // `topSlotFree` is that compare a clock late. The walker only moves forward, so a late "free" stays true, except
  // after topRow.v moves or a frame starts: then it reads "not free" for a clock. (No bubble at a row's first pixel:
  // with candidateStep >= 2 the row after a top-row advance is never a top row.)
  // The top tracker's row is counted down (`topRowsAhead` = topRow.v - r - capY, 0 when topRow.rowIs), so the next
  // row's hit is a compare with 1, not the tracker's sum and compares after another sum.
  val topHitRow = RegInit(false.B)
  val topSlotFree = RegInit(false.B)
  val topRowsAhead = RegInit(0.U(rowW.W))
  val topInFrame = RegInit(false.B) // topRow.v + margin < height
  val topRowNow = topRowsAhead === 0.U // topRow.rowIs
  val startFrame = io.in.valid && io.in.bits.sof && !capBusy && !walkBusy
  io.in.ready := Mux(capBusy, !topHitRow || topSlotFree, !io.in.bits.sof || !walkBusy)
  val capture = io.in.fire && capBusy
  val endOfLine = capX === width - 1.U
  topSlotFree := walkV +& (slots * step).U > topRow.v && !startFrame && !(capture && endOfLine && topRowNow)
  assert(!capBusy || topHitRow === topRow.hit && topRowNow === topRow.rowIs,
    "SupportMatcher: the registered top-row hit differs from topRow.hit")

  when(startFrame) {
    width := io.frameWidth
    height := io.frameHeight
    capBusy := true.B
    walkBusy := true.B
    // the start-of-frame beat is pixel (0, 0): no lattice row needs pixel row 0, so only the counters move
    capX := 1.U
    capY := 0.U
    Seq(topRow, centreRow, bottomRow).foreach(_.restart())
    topHitRow := (r == firstRow).B && (firstRow + margin).U < io.frameHeight // topRow.hit at capY = 0
    topRowsAhead := (firstRow - r).U
    topInFrame := (firstRow + margin).U < io.frameHeight
  }
  when(capture) {
    capX := Mux(endOfLine, 0.U, capX + 1.U)
    when(endOfLine) {
      capY := capY + 1.U
      // the next row is the tracker's when it is one row ahead now (after an advance it is step >= 2 rows ahead)
      topHitRow := topRowsAhead === 1.U && topInFrame
      when(topRowNow) {
        topRowsAhead := (step - 1).U
        topInFrame := topRow.v +& (step + margin).U < height
      }.otherwise { topRowsAhead := topRowsAhead - 1.U }
      when(capY === height - 1.U) { capBusy := false.B }
      Seq(topRow, centreRow, bottomRow).foreach(t => when(t.rowIs) { t.advance() })
    }
  }

  def slotBase(slot: UInt, perSlot: Int): UInt =
    VecInit((0 until slots).map(s => (s * perSlot).U(log2Ceil(slots * perSlot + 1).W)))(slot)

  /** Row memory address: view * slots * words + slot * words + word (word < words always holds). */
  private val viewWords = slots * wordsPerRow
  private val addrW = log2Ceil(2 * viewWords)
  def rowAddress(view: UInt, slot: UInt, word: UInt): UInt =
    (Mux(view.asBool, viewWords.U, 0.U) +& slotBase(slot, wordsPerRow) +& word)(addrW - 1, 0)
  // The walker's row addresses start at these (its slot's rows of each view), kept in registers with walkSlot so
  // that a read address is one addition away from a register.
  val walkBase = RegInit(VecInit(0.U(addrW.W), viewWords.U(addrW.W)))
  def setWalkSlot(slot: UInt): Unit = {
    walkSlot := slot
    walkBase(0) := rowAddress(0.U, slot, 0.U)
    walkBase(1) := rowAddress(1.U, slot, 0.U)
  }
  def texAddress(slot: UInt, col: UInt): UInt =
    (slotBase(slot, p.maxWidth) +& col)(log2Ceil(slots * p.maxWidth) - 1, 0)

  /** Descriptor row memories: (row kind 0 = v - r, 1 = v + r)(bank), the right view's words after the left's: a
    * sweep reads one view at a time, so sharing the read port halves the block RAMs (they are read-width bound).
    * Read-first block RAM (a `Mem` whose read data is registered, see `data`): a sweep never reads the slot being
    * written, so the transparent read of a SyncReadMem would only buy Yosys' bypass logic (an address compare on the
    * read path and a 128-bit data mux per bank).
    */
  val rowMem = Seq.fill(2, banks)(Mem(2 * viewWords, UInt(descBits.W)))
  val texMem = SyncReadMem(slots * p.maxWidth, UInt(2.W)) // bit 0 left, bit 1 right: texture >= supportTexture

  val capBank = capX(bankBits - 1, 0)
  val capWord = capX >> bankBits
  // Writes are registered (the address logic stays off the memories' read paths): the left word is written one
  // cycle after the pixel, the right word two. That bank's next write is `banks` columns away, and a kind's captured
  // rows are step >= 2 pixel rows apart, so the two never meet; the sweeps never read the last r + 1 columns of a
  // row, whose writes may still be under way when the walker finds the row complete.
  // A kind captures consecutive columns of one row, so the left word of column x and the right word of column x - 1
  // written in one cycle go to banks of different parity: the write data and address are chosen once per bank
  // parity (two 128-bit multiplexers per kind) instead of once per bank.
  val leftData = RegNext(io.in.bits.data.left)
  val rightData = RegNext(RegNext(io.in.bits.data.right))
  val rowWrites = Seq(topRow, bottomRow).zipWithIndex.map { case (tracker, kind) =>
    val hit = capture && tracker.hit
    val leftPending = RegNext(hit, false.B)
    val leftBank = RegNext(capBank)
    val leftAddr = RegNext(rowAddress(0.U, tracker.slot, capWord))
    val byParity = (0 until 2).map { parity =>
      val nowLeft = hit && capBank(0) === parity.U
      val writeLeft = RegNext(nowLeft, false.B)
      val addr = RegNext(Mux(nowLeft, rowAddress(0.U, tracker.slot, capWord), leftAddr + viewWords.U))
      (addr, Mux(writeLeft, leftData, rightData))
    }
    (0 until banks).map { b => // one write port per memory
      val write = RegNext(hit && capBank === b.U || leftPending && leftBank === b.U, false.B)
      val (addr, data) = byParity(b % 2)
      when(write) { rowMem(kind)(b).write(addr, data) }
      CollisionFree.Write(write, addr)
    }
  }
  // texture test of the centre rows, one cycle later: half sums registered, then their sum compared
  def textureHalves(a: UInt): Vec[UInt] = {
    val w = a.getWidth / 2
    VecInit(SupportMatcher.texture(a(w - 1, 0)), SupportMatcher.texture(a(2 * w - 1, w)))
  }
  val texWrite = RegNext(capture && centreRow.hit, false.B)
  val texAddr = RegNext(texAddress(centreRow.slot, capX))
  val texHalves = RegNext(VecInit(textureHalves(io.in.bits.data.left), textureHalves(io.in.bits.data.right)))
  when(texWrite) {
    texMem.write(texAddr, Cat(texHalves(1).reduce(_ +& _) >= p.supportTexture.U,
      texHalves(0).reduce(_ +& _) >= p.supportTexture.U))
  }

  // ---- walker: every lattice node in raster order ----
  val sIdle :: sNode :: sSweep :: sRight :: Nil = Enum(4)
  val state = RegInit(sIdle)
  val phaseLeft = RegInit(true.B) // sweeping with the left view as reference
  val uRef = RegInit(0.U(p.colBits.W)) // reference column of the current sweep
  // the left sweep's reference u: u - r, u - r + dispMax and u + r + dispMax (the right sweep's bounds are these - d1)
  val refC0 = RegInit(0.U(colW.W))
  val refTop = RegInit(0.U((colW + 1).W))
  val refTop2 = RegInit(0.U((colW + 1).W))

  val rowActive = walkV >= margin.U && walkV +& margin.U < height
  val rowReady = !rowActive || bottomRow.v > walkV // both descriptor rows of this lattice row are in
  def dispMin(a: UInt): UInt = Mux(a > p.dispMax.U, p.dispMax.U, a)
  def dhiLOf(u: UInt): UInt = dispMin(u - margin.U)
  /** Node u of this lattice row is searched (else it holds no support): inside the margins, left range >= minimum. */
  def searched(u: UInt): Bool = rowActive && u >= margin.U && u +& margin.U < width && dhiLOf(u) >= p.supportMinRange.U
  // the next node of this row (when not eol): set when the walker moves, so that it is current one cycle later
  val uNext = RegInit(0.U(p.colBits.W))
  // per frame (width is held all frame): the last column t - r a right sweep may reach, W - 1 - margin - r, and + 2r
  val rightLimit = RegNext(width - (1 + margin + r).U)
  val rightLimit2 = RegNext(width - (1 + margin - r).U)

  // ---- reads: word j of every bank is the aligned block of columns jL .. jL + L - 1, lane k = bank k ----
  val blockW = log2Ceil(wordsPerRow + 1)
  def blockOf(col: UInt): UInt = (col >> bankBits)(blockW - 1, 0)
  val j = RegInit(0.U(blockW.W)) //   block the sweep reads this cycle (the sweep runs from j down to jLo)
  val jLo = RegInit(0.U(blockW.W))
  val sweepStart = RegInit(false.B) // the sweep's first block (its result starts the running best)
  // Block j is the sweep's last: a register, not j === jLo, because the walker's decisions hang on it (that compare
  // at the head of the last block's decisions was the whole top's worst path). A sweep issues at least two blocks, so
  // the first block is never the last: a sweep whose columns lie in one block also issues the block below it, whose
  // lanes all lie outside the sweep. ElasParams.supportSweepCycles counts at least two blocks per sweep already.
  val lastBlock = RegInit(false.B)
  val minC1 = RegInit(0.U(colW.W)) // target columns t - r of the sweep's disparities: minC1 .. maxC1
  val maxC1 = RegInit(0.U(colW.W))
  // One read per bank and cycle. A reference read fetches the L consecutive columns from c0 = u - r on (banks below
  // c0 mod L read the next word), so u - r and u + r (2r < L) arrive together; a sweep reads the aligned block j.
  val refIssue = WireDefault(false.B) // a left reference read is issued this cycle (else the sweep reads block j)
  val refC0Now = (walkU - r.U).pad(colW) // ... its first column (the walker's node u - r)
  val readC0 = RegInit(0.U(colW.W)) // c0 of that reference read
  val refRead = RegInit(false.B) //  the read of this cycle's registered addresses: the next sweep's references
  refRead := false.B
  def readLeftReference(): Unit = {
    refIssue := true.B
    readC0 := refC0Now
  }
  /** The addresses of a read of word `word` (banks >= `split` of a reference read) and word + 1 (banks below it):
    * two row addresses per read, each bank picks one.
    */
  class ReadAddress extends Bundle {
    val word = UInt(log2Ceil(2 * viewWords).W)
    val next = UInt(log2Ceil(2 * viewWords).W)
    val split = UInt(bankBits.W)
  }
  def readAddress(view: Bool, word: UInt, split: UInt): ReadAddress = {
    val a = Wire(new ReadAddress)
    val base = Mux(view, walkBase(1), walkBase(0))
    a.word := (base +& word)(addrW - 1, 0)
    a.next := (base +& (word +& 1.U)(blockW - 1, 0))(addrW - 1, 0)
    a.split := split
    a
  }
  def bankAddresses(a: ReadAddress): Vec[UInt] = VecInit((0 until banks).map(b => Mux(b.U < a.split, a.next, a.word)))
  // The sweep's and the left reference read's addresses are formed apart and selected last (a view multiplexer in
  // front of one shared adder put the state decode on the address path).
  val sweepWord = readAddress(phaseLeft, j, 0.U).word // sweep: the target view (the right one for the left sweep)
  val refAddr = bankAddresses(readAddress(false.B, blockOf(refC0Now), refC0Now(bankBits - 1, 0)))
  val bankAddr = WireDefault(Mux(refIssue, refAddr, VecInit(Seq.fill(banks)(sweepWord))))
  // Each bank's address is registered before the read: one register per bank drives only its own block RAMs (on the
  // ECP5 the unregistered address, fanned out to every bank, spent 10 ns in routing), at one more cycle of latency.
  // The read data is registered twice (the block RAM's read register and its output register), so the SADs start
  // from a flip-flop next to them, not from a block RAM's output across the device.
  val bankAddrReg = RegNext(bankAddr)
  val data = (0 until 2).map(kind => (0 until banks).map(b => RegNext(RegNext(rowMem(kind)(b).read(bankAddrReg(b))))))
  /** x SupportMatcher.readLatency cycles later: the issue cycle's view of a block, aligned with its data. */
  def atData[T <: Data](x: T): T = ShiftRegister(x, SupportMatcher.readLatency)
  val texReadAddr = texAddress(walkSlot, uRef)
  val texBits = texMem.read(texReadAddr)

  // ---- reference descriptors (columns c0 and c0 + 2r of a reference read), kept in registers ----
  /** The word of column `col`'s bank: a binary multiplexer tree (4:1 per LUT level), which maps to fewer LUTs than a
    * one-hot AND-OR of the banks.
    */
  def column(data: Seq[UInt], col: UInt): UInt = VecInit(data)(col(bankBits - 1, 0))
  // Every sweep follows its own reference read at once, so one register pair serves both kinds of sweep: the
  // previous sweep's last block has left stage A when the new references arrive.
  val refData = ShiftRegister(refRead, SupportMatcher.readLatency - 1, false.B, true.B) // its data is in `data`
  val refDataC0 = ShiftRegister(readC0, SupportMatcher.readLatency - 1)
  val refLo = Reg(Vec(2, UInt(descBits.W)))
  val refHi = Reg(Vec(2, UInt(descBits.W)))
  for (kind <- 0 until 2) {
    when(refData) { refLo(kind) := column(data(kind), refDataC0); refHi(kind) := column(data(kind), refDataC0 + (2 * r).U) }
  }

  // ---- search pipeline: issue (read) -> A: the SAD parts per lane -> A2: half costs -> B1: lane costs -> B: first
  // tree level -> C, E: the lane tree -> merge into the running best (the class comment gives the cycle count). ----
  class Tag extends Bundle {
    val left = Bool() //  the block belongs to a left sweep
    val first = Bool() // the sweep's first block
    val last = Bool() //  the sweep's last block
  }
  val hold = WireDefault(false.B) // the right sweep's last block waits for the previous node's decision
  val issue = state === sSweep && !hold
  val tag = Wire(new Tag)
  tag.left := phaseLeft; tag.first := sweepStart; tag.last := lastBlock
  val s0Valid = ShiftRegister(issue, SupportMatcher.readLatency, false.B, true.B) // the block's data is in `data`
  val s0Tag = atData(tag)
  // Which lanes of block j hold columns c1 = jL + k of the sweep (laneLo <= k < laneEnd), and lane k's d (left:
  // maxC1 - c1 = dBase - k, right: c1 - minC1 = dBase + k, modulo 2^baseW), decided per block in the issue cycle
  // so that a lane adds a constant instead of comparing and subtracting columns.
  private val laneW = bankBits + 1
  private def high(col: UInt): UInt = col >> bankBits
  private def low(col: UInt): UInt = col(bankBits - 1, 0)
  val blockStart = Cat(j, 0.U(bankBits.W))
  val s0LaneLo = atData(Mux(j > high(minC1), 0.U(laneW.W), Mux(j === high(minC1), low(minC1), banks.U)))
  val s0LaneEnd = atData(Mux(j < high(maxC1), banks.U(laneW.W), Mux(j === high(maxC1), low(maxC1) +& 1.U, 0.U)))
  val s0DBase = atData(Mux(phaseLeft, maxC1 - blockStart, blockStart - minC1)(baseW - 1, 0))
  // columns 0 .. 2r - 1 of the block issued before (block j + 1): the partners of the top 2r lanes
  val prevBlock = data.map(cols => RegEnable(VecInit(cols.take(2 * r).toSeq), s0Valid))

  class Best extends Bundle {
    val e1 = UInt(costBits.W)
    val d1 = UInt(baseW.W)
    val e2 = UInt(costBits.W)
  }
  def best(e1: UInt, d1: UInt, e2: UInt): Best = {
    val b = Wire(new Best); b.e1 := e1; b.d1 := d1; b.e2 := e2; b
  }
  /** b's E1 wins over a's; `bFirst` says b holds the smaller disparities: the smaller d wins a tie (first minimum). */
  def bWins(a: Best, b: Best, bFirst: Bool): Bool = Mux(bFirst, b.e1 <= a.e1, b.e1 < a.e1)
  /** Merges two results (a tie makes E2 = E1). */
  def merge(a: Best, b: Best, bFirst: Bool): Best = {
    val w = bWins(a, b, bFirst)
    best(Mux(w, b.e1, a.e1), Mux(w, b.d1, a.d1), Mux(w, SupportMatcher.min(a.e1, b.e2), SupportMatcher.min(a.e2, b.e1)))
  }
  /** Levels of the lane tree: neighbours merge (the higher lane holds the smaller d in a left sweep). */
  def treeLevels(xs: Seq[Best], levels: Int, left: Bool): Seq[Best] =
    (0 until levels).foldLeft(xs)((ys, _) => ys.grouped(2).map(g => merge(g(0), g(1), left)).toSeq)

  // A: per lane (target column c1 = jL + k and its partner c1 + 2r, in this block or the one issued before) the
  // four SADs as 16 quarter-descriptor SADs, registered (a whole SAD from the block's data is 10 LUT levels deep);
  // whether c1 is in the sweep and its d (left d = maxC1 - c1, right c1 - minC1)
  private val sadParts = 4
  private val partBits = 8 * p.descriptorBytes / sadParts
  require(partBits * sadParts == 8 * p.descriptorBytes)
  private def partSads(x: UInt, y: UInt): Seq[UInt] =
    (0 until sadParts).map(i => sad(x((i + 1) * partBits - 1, i * partBits), y((i + 1) * partBits - 1, i * partBits)))
  val aValid = RegNext(s0Valid, false.B)
  val aTag = RegEnable(s0Tag, s0Valid)
  val aParts = (0 until lanes).map { k =>
    val parts = (0 until 2).flatMap { kind =>
      val cur = data(kind)
      val partner = if (k + 2 * r < banks) cur(k + 2 * r) else prevBlock(kind)(k + 2 * r - banks)
      partSads(refLo(kind), cur(k)) ++ partSads(refHi(kind), partner)
    }
    RegEnable(VecInit(parts), s0Valid)
  }
  val aLane = (0 until lanes).map { k =>
    val inSweep = k.U >= s0LaneLo && k.U < s0LaneEnd
    val d = s0DBase + Mux(s0Tag.left, (((1 << baseW) - k) % (1 << baseW)).U(baseW.W), k.U(baseW.W))
    (RegEnable(inSweep, s0Valid), RegEnable(d, s0Valid))
  }
  // A2: two half costs per lane (the left and right descriptor kinds' SAD pairs): B adds them and compares in one
  // adder depth
  val a2Valid = RegNext(aValid, false.B)
  val a2Tag = RegEnable(aTag, aValid)
  val aSad = aParts.map(parts => RegEnable(VecInit(parts.grouped(2 * sadParts).map(SupportMatcher.sumTree).toSeq), aValid))
  val a2Lane = aLane.map { case (inSweep, d) => (RegEnable(inSweep, aValid), RegEnable(d, aValid)) }
  // B1: lane costs, registered (adder and compare in one clock were SupportMatcher's worst path on the ECP5, whose
  // lanes spread over a third of the device: 84 MHz at small)
  val b1Valid = RegNext(a2Valid, false.B)
  val b1Tag = RegEnable(a2Tag, a2Valid)
  val laneCost = aSad.map(h => RegEnable(SupportMatcher.sumTree(h), a2Valid))
  val b1Lane = a2Lane.map { case (inSweep, d) => (RegEnable(inSweep, a2Valid), RegEnable(d, a2Valid)) }
  // B: the lane tree's first level (a lane's E2 is "none", so a pair's E2 is its larger E1)
  private val levels = log2Ceil(lanes)
  private val levelsB = 1
  private val levelsC = (levels - levelsB + 1) / 2
  val bValid = RegNext(b1Valid, false.B)
  val bTag = RegEnable(b1Tag, b1Valid)
  // The first level compares the raw lane costs and folds "lane in the sweep" into the decision and the outputs, so
  // no costInf multiplexer sits before the compare.
  require(levelsB == 1)
  val bBest = (0 until lanes by 2).map { k =>
    val (ia, da) = b1Lane(k); val (ib, db) = b1Lane(k + 1)
    val (ea, eb) = (laneCost(k), laneCost(k + 1))
    // lane k + 1 wins (merge's rule on costs with costInf outside the sweep; it holds the smaller d when left)
    val w = Mux(b1Tag.left, Mux(ib, !ia || eb <= ea, !ia), ib && (!ia || eb < ea))
    val eaOr = Mux(ia, ea, costInf); val ebOr = Mux(ib, eb, costInf)
    RegEnable(best(Mux(w, ebOr, eaOr), Mux(w, db, da), Mux(w, eaOr, ebOr)), b1Valid)
  }
  // C, E: the rest of the lane tree (ascending lanes, ties to the smaller d), about half of its levels each
  val cValid = RegNext(bValid, false.B)
  val cTag = RegEnable(bTag, bValid)
  val cBest = treeLevels(bBest, levelsC, bTag.left).map(RegEnable(_, bValid))
  val eValid = RegNext(cValid, false.B)
  val eTag = RegEnable(cTag, cValid)
  val blockBest = RegEnable(treeLevels(cBest, levels - levelsB - levelsC, cTag.left).head, cValid)
  // merge: each later block holds higher d (left sweep) or lower d (right sweep)
  val running = Reg(new Best)
  val merged = Mux(eTag.first, blockBest, merge(running, blockBest, !eTag.left))
  when(eValid) { running := merged }
  val leftDone = eValid && eTag.last && eTag.left //   this cycle's merged is the left sweep's result
  val rightDone = eValid && eTag.last && !eTag.left // ... the right sweep's

  val nodeEol = walkU === width - 1.U
  val nodeEof = nodeEol && walkV === height - 1.U
  val nodeSof = walkU === 0.U && walkV === 0.U

  // ---- nodes whose left sweep is issued and whose right sweep is not (at most two: the walker's and the one before)
  class LeftNode extends Bundle {
    val flags = Vec(3, Bool()) // sof, eol, eof
    val c0 = UInt(colW.W) //       u - r, u - r + dispMax, u + r + dispMax (the right sweep's bounds are these - d1)
    val top = UInt((colW + 1).W)
    val top2 = UInt((colW + 1).W)
    val left = new Best //         the left sweep's result (when done)
    val texL = Bool() //           texture bit at u
    val done = Bool()
  }
  val leftNodes = Reg(Vec(2, new LeftNode))
  val lnCount = RegInit(0.U(2.W))
  val lnHead = RegInit(0.U(1.W)) //   the oldest (the next right sweep's)
  val lnResult = RegInit(0.U(1.W)) // the one the next left result belongs to
  val lnTail = lnHead + lnCount(0) // where the next node goes (count < 2)
  val enqueue = WireDefault(false.B)
  val dequeue = WireDefault(false.B)
  lnCount := lnCount + enqueue.asUInt - dequeue.asUInt
  when(dequeue) { lnHead := ~lnHead }
  when(enqueue) {
    val n = leftNodes(lnTail)
    n.flags := VecInit(nodeSof, nodeEol, nodeEof)
    n.c0 := refC0; n.top := refTop; n.top2 := refTop2
    n.done := false.B
  }
  // the texture bit at u is read from uRef, which holds u from the reference read until the next one: one cycle
  // after the last left block it is in (a sweep has at least one block)
  val texLAt = RegEnable(lnTail, enqueue)
  when(RegNext(enqueue, false.B)) { leftNodes(texLAt).texL := texBits(0) }
  when(leftDone) {
    leftNodes(lnResult).left := merged
    leftNodes(lnResult).done := true.B
    lnResult := ~lnResult
  }
  val headReady = lnCount =/= 0.U && leftNodes(lnHead).done

  // ---- the node whose right sweep is done waits here for its decision and the output register ----
  val pendBusy = RegInit(false.B)
  val pendStage = RegInit(0.U(2.W)) // 1: its right result is in, 2: the decision is in pendOk
  val pendFlags = Reg(Vec(3, Bool())) // sof, eol, eof
  val pendLeft = Reg(new Best) //  the left sweep's result
  val pendRight = Reg(new Best)
  val pendTexL = Reg(Bool())
  val pendTexR = Reg(Bool())
  val pendRangeOk = Reg(Bool()) // the right sweep's range reaches supportMinRange
  val pendOk = Reg(Bool()) // every test but the right result's ratio (its products are registered first)
  // The ratio test e1 * 100 < e2 * threshold% as products registered before the compare (product and compare in one
  // clock were the whole top's worst path). Each product is a sum of shifted copies (`timesConstant`), logic placed
  // beside its registers: as an ECP5 multiplier block, in a column of its own, it was the whole top's worst path
  // again (two nets of 3.7 and 4.5 ns around the block). The left
  // result's products follow pendLeft every clock: it is loaded at the last right block's issue, at least a clock
  // before that block's result ends the sweep (rightDone), so they are current when the decision is made.
  private val ratioW = costBits + log2Ceil(math.max(100, p.supportThresholdPercent) + 1)
  val pendLeftRatio = Reg(Vec(2, UInt(ratioW.W)))
  val pendRightRatio = Reg(Vec(2, UInt(ratioW.W)))
  def ratioTerms(b: Best): Vec[UInt] =
    VecInit(Seq(SupportMatcher.timesConstant(b.e1, 100), SupportMatcher.timesConstant(b.e2, p.supportThresholdPercent))
      .map(_.pad(ratioW)(ratioW - 1, 0)))
  def ratioOk(terms: Vec[UInt]): Bool = terms(0) < terms(1)
  pendLeftRatio := ratioTerms(pendLeft)

  // ---- output register ----
  val output = new OutputRegister(io.out)

  def output(value: SInt, sof: Bool, eol: Bool, eof: Bool): Unit = {
    output.valid := true.B
    output.bits.data := value
    output.bits.sof := sof
    output.bits.eol := eol
    output.bits.eof := eof
  }
  /** Moves the walker to the next node. */
  def advance(): Unit = {
    state := sNode
    when(nodeEol) {
      walkU := 0.U
      uNext := Mux(step.U < width, step.U, width - 1.U)
      walkV := Mux(walkV +& step.U < height, walkV + step.U, height - 1.U)
      setWalkSlot(Mux(walkSlot === (slots - 1).U, 0.U, walkSlot + 1.U))
      when(nodeEof) { state := sIdle; walkBusy := false.B }
    }.otherwise {
      walkU := uNext
      uNext := Mux(uNext +& step.U < width, uNext + step.U, width - 1.U)
    }
  }
  /** Sets up the left sweep of node u (its references are read this cycle). */
  def startLeft(u: UInt): Unit = {
    val dhiL = dhiLOf(u)
    phaseLeft := true.B; uRef := u
    refC0 := u - r.U
    refTop := (u - r.U) +& p.dispMax.U
    refTop2 := u +& (r + p.dispMax).U
    sweepStart := true.B
    lastBlock := false.B
    minC1 := u - r.U - dhiL
    maxC1 := u - r.U
    j := blockOf(u + r.U)
    jLo := blockOf(u - r.U - dhiL)
    state := sSweep
  }
  val none = (-1).S(p.signedDispBits.W)

  // The oldest left node's right sweep setup (reference u' = u - d1), registered: its reference read issues from
  // registers, one cycle after the left result is in.
  class RightSetup extends Bundle {
    val uPrime = UInt(p.colBits.W)
    val c0 = UInt(colW.W) //   u' - r
    val maxC1 = UInt(colW.W) // u' - r + min(W - 1 - margin - u', dispMax)
    val j = UInt(blockW.W)
    val jLo = UInt(blockW.W)
    val bankAddr = Vec(banks, UInt(addrW.W)) // each bank's address of the right reference read
  }
  def rightSetup(n: LeftNode): RightSetup = {
    val s = Wire(new RightSetup)
    val d = n.left.d1(p.dispBits - 1, 0)
    s.c0 := n.c0 - d
    s.uPrime := (n.c0 - d + r.U)(p.colBits - 1, 0)
    val top = n.top - d
    val top2 = n.top2 - d
    s.maxC1 := Mux(top > rightLimit, rightLimit, top)(colW - 1, 0)
    s.j := blockOf(Mux(top2 > rightLimit2, rightLimit2, top2))
    s.jLo := blockOf(s.c0)
    s.bankAddr := bankAddresses(readAddress(true.B, blockOf(s.c0), s.c0(bankBits - 1, 0)))
    s
  }
  val headSetup = RegNext(rightSetup(leftNodes(lnHead)))
  val headSetupValid = RegNext(headReady && !dequeue, false.B) // headSetup is the current head's
  val rightIssue = state === sRight && headSetupValid
  /** After the last block of a sweep: the next node's left sweep goes first when it is searched in this lattice row
    * and only the walker's node waits (its result then arrives while the next node is swept: no cycle waits for the
    * search pipeline); else the oldest node's right sweep. A left sweep's walker waits when it is the only left node;
    * after a right sweep the walker moves on when no other node waits, and else when the next node is searched.
    * Registered: their inputs (the walker, its next node and the left-node count) change only at a sweep's last block
    * or in sNode, and every sweep starts after at least one cycle in sNode or sRight, so the flags are current at
    * every issue.
    */
  def leftAdvancesNow: Bool = lnCount === 0.U && !nodeEol && searched(uNext)
  def rightAdvancesNow: Bool = lnCount === 1.U || !nodeEol && searched(uNext)
  val leftAdvances = RegNext(leftAdvancesNow, false.B)
  val rightAdvances = RegNext(rightAdvancesNow, false.B)

  switch(state) {
    is(sIdle) {
      when(startFrame) {
        walkU := 0.U; walkV := 0.U; setWalkSlot(0.U)
        uNext := Mux(step.U < io.frameWidth, step.U, io.frameWidth - 1.U)
        state := sNode
      }
    }
    is(sNode) {
      readLeftReference() // the node's references (u - r), used if it is searched (keeps the test off the address)
      when(!searched(walkU)) {
        // emitted here, after the previous node's decision
        when(rowReady && output.free && !pendBusy) {
          output(none, nodeSof, nodeEol, nodeEof)
          advance()
        }
      }.elsewhen(rowReady) {
        refRead := true.B
        startLeft(walkU)
      }
    }
    is(sSweep) {
      when(issue) {
        sweepStart := false.B
        j := j - 1.U
        lastBlock := j - 1.U === jLo || sweepStart && j === jLo
        when(lastBlock) {
          assert(j === jLo || j + 1.U === jLo, "SupportMatcher: lastBlock is not the sweep's last block")
          assert(leftAdvances === leftAdvancesNow && rightAdvances === rightAdvancesNow,
            "SupportMatcher: the registered walker decision lags its inputs")
          when(phaseLeft) {
            enqueue := true.B
            when(leftAdvances) { advance() }.otherwise { state := sRight }
          }.otherwise { // hand the oldest node to the decision
            dequeue := true.B
            val n = leftNodes(lnHead)
            pendBusy := true.B
            pendFlags := n.flags
            pendLeft := n.left
            pendTexL := n.texL
            pendRangeOk := maxC1 - minC1 >= p.supportMinRange.U
            when(rightAdvances) { advance() }.otherwise { state := sRight }
          }
        }
      }
    }
    is(sRight) { // the right sweep of the oldest left node starts once its setup is in
      when(rightIssue) {
        phaseLeft := false.B
        uRef := headSetup.uPrime
        readC0 := headSetup.c0
        refRead := true.B
        sweepStart := true.B
        lastBlock := false.B
        minC1 := headSetup.c0
        maxC1 := headSetup.maxC1
        j := headSetup.j
        jLo := headSetup.jLo
        state := sSweep
      }
    }
  }
  when(rightIssue) { bankAddr := headSetup.bankAddr } // the right references, u' - r .. u' + r
  // the last right block of a node waits until the previous node's decision has left
  when(state === sSweep && !phaseLeft && lastBlock && pendBusy) { hold := true.B }

  // decision of the pending node: its right result, then the tests, then the output register
  val texRTaken = RegNext(state === sSweep && issue && !phaseLeft && lastBlock, false.B)
  when(texRTaken) { pendTexR := texBits(1) } // at u'
  // No used read meets a write: used reads (a reference read, a sweep's blocks) read only the walker's slot once its
  // rows are complete; captures write the slots of later lattice rows, and the last columns' registered writes land
  // before the first used read (node 0 is never searched). The reads issued every clock while the walker waits, and
  // a block read's banks outside the sweep, meet captures, unused. The texture bits likewise: their row's centre row
  // was written long before; the read at a stale column while the walker waits is not taken.
  val rowReadUsed = RegNext(refRead || RegNext(issue, false.B), false.B)
  for (kind <- 0 until 2; b <- 0 until banks)
    CollisionFree.check(s"SupportMatcher: rowMem($kind)($b)", Seq(rowMem(kind)(b)),
      Seq(CollisionFree.Read(bankAddrReg(b), rowReadUsed)), Seq(rowWrites(kind)(b)))
  CollisionFree.check("SupportMatcher: texMem", Seq(texMem), Seq(CollisionFree.Read(texReadAddr,
    RegNext(enqueue, false.B) || texRTaken)),
    Seq(CollisionFree.Write(texWrite, texAddr)))
  when(rightDone) { pendRight := merged; pendStage := 1.U }
  when(pendStage === 1.U) {
    val diff = Mux(pendLeft.d1 > pendRight.d1, pendLeft.d1 - pendRight.d1, pendRight.d1 - pendLeft.d1)
    assert(pendLeftRatio === ratioTerms(pendLeft), "support: the left ratio's products lag pendLeft")
    pendOk := pendTexL && ratioOk(pendLeftRatio) && pendRangeOk && pendTexR && diff <= p.lrThreshold.U
    pendRightRatio := ratioTerms(pendRight)
    pendStage := 2.U
  }
  when(pendStage === 2.U && output.free) {
    val ok = pendOk && ratioOk(pendRightRatio)
    output(Mux(ok, pendLeft.d1(p.dispBits - 1, 0).zext, none), pendFlags(0), pendFlags(1), pendFlags(2))
    pendBusy := false.B
    pendStage := 0.U
  }
}

object SupportMatcher {
  /** x * k for a constant k >= 0: the copies of x shifted by k's set bits, added in a balanced tree. */
  def timesConstant(x: UInt, k: Int): UInt = {
    require(k >= 0, s"timesConstant: k = $k (legal: 0 or more)")
    def tree(terms: Seq[UInt]): UInt =
      if (terms.size == 1) terms.head else tree(terms.grouped(2).map(g => g.reduce(_ +& _)).toSeq)
    val shifted = (0 until 31).filter(i => ((k >> i) & 1) == 1).map(i => x << i)
    if (shifted.isEmpty) 0.U else tree(shifted)
  }

  /** Cycles from a read's issue to its data in the `data` registers: the bank address register, the block RAM's
    * read register and its output register.
    */
  val readLatency: Int = 3

  /** Lattice rows whose descriptor rows are buffered at once (see the class doc). */
  def slots(p: ElasParams): Int = (2 to 64).find(k => (k - 1) * p.candidateStep >= 2 * p.windowRadius + 1).get

  /** Column-interleaved banks, one per lane (lane k always reads bank k): ElasParams.supportLanesUsed, a power of
    * two above 2r.
    */
  def banks(p: ElasParams): Int = p.supportLanesUsed

  def wordsPerRow(p: ElasParams): Int = (p.maxWidth + banks(p) - 1) / banks(p)

  /** Bits of a cost: 4 descriptors x 16 bytes x 255, plus room for the "no disparity" value above it. */
  def costBits(p: ElasParams): Int = log2Ceil(4 * p.descriptorBytes * 255 + 2)

  /** Cycles of the search for one searched node with left/right ranges dhiL/dhiR at the worst block alignment: the
    * sweeps' blocks and the two reference reads (ElasParams.supportNodeCycles; a lattice row's last searched node adds
    * ElasParams.supportDrainCycles).
    */
  def nodeCycles(p: ElasParams, dhiL: Int, dhiR: Int): Int =
    ElasParams.supportOverheadCycles + ElasParams.supportSweepCycles(dhiL, p.windowRadius, p.supportLanesUsed) +
      ElasParams.supportSweepCycles(dhiR, p.windowRadius, p.supportLanesUsed)

  /** Rows of latency behind the descriptor stream: the search of the last lattice row may take step rows. */
  def latencyRows(p: ElasParams): Int = p.candidateStep

  def min(a: UInt, b: UInt): UInt = Mux(a < b, a, b)

  /** Balanced adder tree (sums widen by one bit per level). */
  def sumTree(xs: Seq[UInt]): UInt = if (xs.length == 1) xs.head else {
    val (lo, hi) = xs.splitAt(xs.length / 2)
    sumTree(lo) +& sumTree(hi)
  }

  /** Sum of |a_k - b_k| over the bytes of two descriptors. */
  def sad(a: UInt, b: UInt): UInt = {
    val n = a.getWidth / 8
    sumTree((0 until n).map { k =>
      val (x, y) = (a(8 * k + 7, 8 * k), b(8 * k + 7, 8 * k))
      Mux(x > y, x - y, y - x)
    })
  }

  /** out(j) = in((amount + j) mod n), n a power of two: a log2(n)-stage barrel rotator (n x width x log2 n two-way
    * muxes for all columns, instead of one n-way mux per column).
    */
  def rotate(in: Seq[UInt], amount: UInt): Seq[UInt] =
    (0 until log2Ceil(in.length)).foldLeft(in) { (cur, s) =>
      cur.indices.map(j => Mux(amount(s), cur((j + (1 << s)) % cur.length), cur(j)))
    }

  /** texture = sum_k |byte_k - 128|. */
  def texture(a: UInt): UInt = {
    val n = a.getWidth / 8
    sumTree((0 until n).map { k =>
      val x = a(8 * k + 7, 8 * k)
      Mux(x >= 128.U, x - 128.U, 128.U - x)
    })
  }

  def memorySummary(p: ElasParams): Seq[MemoryUse] = Seq(
    MemoryUse("Support", "rows", 2 * slots(p) * wordsPerRow(p), 2 * banks(p) * 8 * p.descriptorBytes,
      s"2 views x ${slots(p)} slots x rows v-r, v+r, ${banks(p)} banks of read-first 1R1W memories (Mem + read register; both views per bank)"),
    MemoryUse("Support", "texture", slots(p) * p.maxWidth, 2, s"${slots(p)} slots x 2 views, SyncReadMem 1R1W")
  )
}
