package ielas

import chisel3._
import chisel3.util._

/** A beat between the post-processing steps: a value, the framing, and lastRow (every pixel of the frame's last
  * row, so a step knows H before the row ends).
  */
class PostBeat(bits: Int) extends Bundle {
  val data = SInt(bits.W)
  val sof = Bool()
  val eol = Bool()
  val eof = Bool()
  val lastRow = Bool()
  /** The frame width (on every pixel, so a step can start a row before its end). */
  val cols = UInt(14.W)
}

/** Row ring shared by the vertical post steps: B = above + below + 2 row slots of maxWidth words, one block-RAM
  * memory (SyncReadMem) per slot. The input writes rows in order; output pixel (v, u) is read once rows
  * v .. v + below - 1 have arrived and row v + below up to column u + 1 (or the frame's last row is among them); with
  * below = 0, once row v is complete. The input stalls only when the slot it needs still holds a row the window reads.
  * Build it inside a Module; `word` is what a slot stores per pixel; `centreOnly`: the step reads row v alone (the
  * rows below only make it ready), not the [[window]]. The output side reads every slot at one column:
  * the column it will hold next cycle ([[outColNext]], registered into the memories' read ports one cycle ahead).
  * No read that is used meets a write of the same cycle, so nothing is forwarded: a row being written is read only
  * 2 columns behind the input (a column written in cycle t is read from t + 1 on), and markers go to columns the
  * output has not reached in that row. Slots are wrapping counters (no `seq % B`); the input / output distance is one
  * small counter ([[ahead]]) and the output row's metadata sits in registers, so the handshake logic stays shallow;
  * the last-column flag, outCol + 1, the early-row test (input 2 columns ahead) and whether row v is ready are
  * registers formed a cycle ahead, so the take only selects the next read address (the early test sees the input a
  * cycle late: +1 clock).
  */
class RowRing(p: ElasParams, wordBits: Int, above: Int, below: Int, in: DecoupledIO[PostBeat], inWord: UInt,
    centreOnly: Boolean = false) {
  val B: Int = above + below + 2
  private val W = p.maxWidth
  private val sW = log2Ceil(B)
  def wrapInc(s: UInt): UInt = Mux(s === (B - 1).U, 0.U, s + 1.U)
  /** (slot - d) mod B for 0 <= slot < B and 0 <= d < B. */
  def wrapSub(slot: UInt, d: UInt): UInt = Mux(slot >= d, slot - d, slot +& B.U - d)(sW - 1, 0)

  // Read-first block RAM (a `Mem` read into a register): no read that is used meets a write of its cycle (below), so
  // a SyncReadMem's transparency would only add an address compare and a bypass multiplexer after the read address.
  val mems: Seq[Mem[UInt]] = Seq.fill(B)(Mem(W, UInt(wordBits.W)))
  val metaRow: Vec[UInt] = Reg(Vec(B, UInt(p.rowBits.W)))
  val metaLast: Vec[Bool] = Reg(Vec(B, Bool()))
  val metaW: Vec[UInt] = Reg(Vec(B, UInt(p.colBits.W)))
  private val metaWm1: Vec[UInt] = Reg(Vec(B, UInt(p.colBits.W))) // width - 1, for the output's last-column test

  // ---- input side ----
  // the input writes row outSeq + ahead into the slot of row outSeq + ahead - B; the window reaches back to outSeq - above
  private val maxAhead = B - above - 1
  /** Rows completed by the input minus rows completed by the output (0 .. B - above), with the input's room. */
  private val rows = new RowsAhead(log2Ceil(B + 1), maxAhead)
  val ahead: UInt = rows.ahead
  val inSlot: UInt = RegInit(0.U(sW.W)) // (rows completed) mod B
  val inCol: UInt = RegInit(0.U(p.colBits.W))
  val inRow: UInt = RegInit(0.U(p.rowBits.W))
  val outCol: UInt = RegInit(0.U(p.colBits.W))
  /** outCol is the row's last column: a register, set a cycle ahead (the handshake and the read address stay off
    * the column compare). */
  val atLastCol: Bool = RegInit(false.B)
  private val outColP1 = RegInit(1.U(p.colBits.W)) // outCol + 1, kept as a register
  /** The output takes pixel (v, outCol) this cycle (set by [[advanceOut]]). */
  private val advancing = WireDefault(false.B)
  /** outCol next cycle (the read address of every slot): both candidates are registers, the take only selects. */
  val outColNext: UInt = Mux(advancing, Mux(atLastCol, 0.U, outColP1), outCol)
  outCol := outColNext
  /** outColNext for slot s, from that slot's own copy of outCol and outCol + 1. With one shared address, the take's
    * select reached every slot's memory through one net (5.7 ns of routing in the whole top at tiny-w3-c8). Copy s
    * holds its values XOR s, or Yosys would merge the copies back into one (opt_merge); undoing the XOR only inverts
    * address bits, which the select's LUT absorbs. */
  private def slotReadAddress(s: Int): UInt = {
    val key = s & ((1 << p.colBits) - 1)
    val k = key.U(p.colBits.W)
    val colKeyed = RegInit(k) //                          outCol ^ key
    val colP1Keyed = RegInit((1 ^ key).U(p.colBits.W)) // outColP1 ^ key
    val nextKeyed = Mux(advancing, Mux(atLastCol, k, colP1Keyed), colKeyed)
    colKeyed := nextKeyed
    when(advancing) { colP1Keyed := Mux(atLastCol, (1 ^ key).U, ((colP1Keyed ^ k) + 1.U) ^ k) }
    nextKeyed ^ k
  }
  // (ready is the register `rows.free`, set from ahead's next value: the input's handshake and every slot's write
  // enable start at a flip-flop, not at a compare of `ahead`, which set the vertical mean's clock at small)
  in.ready := rows.free
  val col: UInt = Mux(in.bits.sof, 0.U, inCol)
  val row: UInt = Mux(in.bits.sof && inCol === 0.U, 0.U, inRow)
  /** Marker write into an earlier slot at the input's column (set by the step; slot must differ from inSlot). */
  val extraWrite: Bool = WireDefault(false.B)
  val extraSlot: UInt = WireDefault(0.U(sW.W))
  val extraWord: UInt = WireDefault(0.U(wordBits.W))
  val writeWord: UInt = WireDefault(inWord)
  private val readAddrs = (0 until B).map(slotReadAddress)
  private val writeEnables = (0 until B).map(s => in.fire && inSlot === s.U || extraWrite && extraSlot === s.U)
  /** Every slot's word at column outCol (read one cycle ahead at outColNext). */
  val column: Vec[UInt] = VecInit(mems.zipWithIndex.map { case (m, s) => // one write port per slot, always at `col`
    when(writeEnables(s)) { m.write(col, Mux(in.fire && inSlot === s.U, writeWord, extraWord)) }
    RegNext(m.read(readAddrs(s)))
  })
  val inRowDone: Bool = in.fire && in.bits.eol
  when(in.fire) {
    metaRow(inSlot) := row
    metaLast(inSlot) := in.bits.lastRow
    metaW(inSlot) := in.bits.cols
    metaWm1(inSlot) := in.bits.cols - 1.U
    inCol := col + 1.U
    when(in.bits.eol) {
      inCol := 0.U
      inSlot := wrapInc(inSlot)
      inRow := Mux(in.bits.lastRow, 0.U, row + 1.U)
    }
  }

  // ---- output side ----
  val outSlot: UInt = RegInit(0.U(sW.W)) // outSeq mod B
  private val outRowDone = WireDefault(false.B)
  rows.update(inRowDone, outRowDone)
  assert(rows.free === (ahead <= maxAhead.U), "RowRing: the input's room register")
  /** slotAt(k) = (outSeq + k) mod B, k = -above .. below, as registers that advance with outSeq. */
  private val rel: Map[Int, UInt] = (-above to below).map(k =>
    k -> (if (k == 0) outSlot else RegInit((((k % B) + B) % B).U(sW.W)))).toMap
  // (slotAt(k) + 1) mod B as registers too, so a row change only selects between two registers (and between two
  // metadata reads below, each from registers), with no increment and slot multiplexer after the handshake
  private val relSucc: Map[Int, UInt] = (-above to below).map(k => k -> RegInit((((k + 1) % B + B) % B).U(sW.W))).toMap
  private val relNext: Map[Int, UInt] = rel.map { case (k, r) => k -> Mux(outRowDone, relSucc(k), r) }
  private def metaNext[T <: Data](m: Vec[T], k: Int): T = Mux(outRowDone, m(relSucc(k)), m(rel(k)))
  def slotAt(k: Int): UInt = rel(k)
  private def complete(k: Int): Bool = ahead >= (k + 1).U
  // The metadata of rows outSeq .. outSeq + below, in registers reloaded every cycle from the slots they hold next
  // cycle. Read only for complete rows, whose metadata was written by their first pixel (rows are >= 2 wide).
  private val lastNext: Map[Int, Bool] = (0 to below).map(k => k -> metaNext(metaLast, k)).toMap
  private val lastRel: Map[Int, Bool] = lastNext.map { case (k, x) => k -> RegNext(x, false.B) }
  private def lastAt(k: Int): Bool = lastRel(k)
  // Row v + below may still be arriving: column u of row v only needs column u of that row (vertical windows and
  // the column pass's markers, which are written while that column is taken), read 2 columns behind the input.
  // inAhead2 = inCol > outCol + 1, as a register formed a cycle early from this cycle's counters (the output's move
  // is known; the input's is seen a cycle late, which only delays): the handshake no longer waits for a column
  // compare. An input row ending now makes the next one start at column 0 (false: that row then counts as complete
  // or is a new row the early rule must not see).
  // (the input 2 columns ahead of the output's column next cycle when the output stays, takes a column, ends its row)
  private val aheadIfStay = inCol > outCol +& 1.U
  private val aheadIfStep = inCol > outCol +& 2.U
  private val aheadIfRowDone = inCol > 1.U
  private val inAhead2Cols = Mux(advancing, Mux(atLastCol, aheadIfRowDone, aheadIfStep), aheadIfStay)
  private val inAhead2: Bool = RegNext(!inRowDone && inAhead2Cols, false.B)
  /** Row v can be read at column outCol, from the ring's counters (rows ahead, last-row flags, the early test). */
  private def readyOf(ahead: UInt, last: Int => Bool, inAhead2: Bool): Bool = {
    def complete(k: Int): Bool = ahead >= (k + 1).U
    val early = (0 until below).map(k => complete(k) && !last(k)).reduce(_ && _) && ahead === below.U && inAhead2
    complete(0) && (complete(below) || early || (0 until below).map(k => complete(k) && last(k)).reduce(_ || _))
  }
  /** With below > 0, a register formed a cycle ahead from the counters' next values: the take (every slot's read
    * address select) starts at flip-flops, not at the compares of `ahead` (the whole top's worst path at tiny-w3-c8).
    * The input's row end this cycle is left out (seen a clock late, which only delays: readiness only grows with
    * ahead, and the early test that an ending row could pass holds for the complete row it becomes). The three
    * cases of the output's move (none, a column, the row's last column) are evaluated apart and the take only
    * selects among them: its path from the next step's ready to this register is one select, not the slot
    * metadata reads and compares behind them (the whole top's next worst path at tiny-w3-c8). */
  val rowReady: Bool = if (below == 0) complete(0) else {
    val lastStay = (k: Int) => metaLast(rel(k))
    val stay = readyOf(ahead, lastStay, aheadIfStay)
    val step = readyOf(ahead, lastStay, aheadIfStep)
    val rowDone = readyOf(ahead - 1.U, (k: Int) => metaLast(relSucc(k)), aheadIfRowDone)
    RegNext(Mux(advancing, Mux(atLastCol, rowDone, step), stay), false.B)
  }
  if (below > 0) assert(!rowReady || readyOf(ahead, lastAt, inAhead2), "RowRing: the row-ready register")
  val v: UInt = RegNext(metaNext(metaRow, 0), 0.U).suggestName("outRowV")
  val width: UInt = RegNext(metaNext(metaW, 0), 0.U)
  private val widthM1: UInt = RegNext(metaNext(metaWm1, 0), 0.U)
  val isLast: Bool = lastAt(0)
  // the last-column flag and outCol + 1 next cycle (rows are at least 2 wide: column 0 is never the last; widthM1
  // holds the output row's width once that row is ready, so it is the right one whenever the output takes a pixel)
  when(advancing) {
    atLastCol := !atLastCol && outColP1 === widthM1
    outColP1 := Mux(atLastCol, 1.U, outColP1 + 1.U)
  }
  /** Window rows v + k, k = -above .. below, at column outCol; with whether that row exists in the frame. */
  def window: Seq[(UInt, Bool)] = {
    require(!centreOnly, "RowRing: the window of a ring built centreOnly")
    (-above to below).map(k => windowTap(k))
  }
  private def windowTap(k: Int): (UInt, Bool) = {
    val word = column(slotAt(k))
    val exists =
      if (k < 0) v >= (-k).U
      else if (k == 0) true.B
      else (0 until k).map(j => !lastAt(j)).reduce(_ && _) && (complete(k) || ahead === k.U && inAhead2)
    (word, exists)
  }
  /** Row v at column outCol. */
  def centre: UInt = column(outSlot)
  // The check of the argument above: every slot is read every clock, and the word of a window row that exists is
  // used when the output takes the pixel (with `centreOnly`, as the column-gap step builds it, row v's alone: the
  // rows below only count towards readiness and take markers); such a read never meets a write.
  for (s <- 0 until B) {
    val usedRows = if (centreOnly) Seq(0) else -above to below
    val used = advancing && usedRows.map(k => slotAt(k) === s.U && windowTap(k)._2).reduce(_ || _)
    CollisionFree.check(s"RowRing: slot $s", Seq(mems(s)), Seq(CollisionFree.Read(readAddrs(s), used)),
      Seq(CollisionFree.Write(writeEnables(s), col)))
  }
  /** Call when output pixel (v, outCol) is taken. */
  def advanceOut(): Unit = {
    advancing := true.B
    when(atLastCol) {
      outRowDone := true.B
      for (k <- -above to below) { rel(k) := relNext(k); relSucc(k) := wrapInc(relSucc(k)) }
    }
  }
}

/** The horizontal steps' window: a sliding window over the raster stream (no row memory). Entries 0..3 are the four
  * pixels before the centre (history), entry 4 the centre (column u), entries 5..8 the pixels after it that have
  * arrived (up to 4 pending after the centre plus one, so the input is never throttled in the steady state). The
  * centre may leave once pixel u + 3 is in, or the row ends among the pending pixels; taps u - 4 .. u + 3 of the
  * row are entries 0..7 whenever they lie in the row (the steps use the other taps only outside their range).
  */
class RowWindow(p: ElasParams, bits: Int, in: DecoupledIO[PostBeat]) {
  private val N = 9
  val ent: Vec[PostBeat] = Reg(Vec(N, new PostBeat(bits)))
  val pending: UInt = RegInit(0.U(3.W)) // entries 4 .. 4 + pending - 1 hold pixels
  private val colReg = RegInit(0.U(p.colBits.W)) // column of the centre
  // in.ready = pending < 5, kept as a register formed from pending's next value: the previous step's output
  // handshake starts at a flip-flop, not at this compare (the whole top's worst path at tiny-w3-c8 ran from it)
  private val inReady = RegInit(true.B)
  in.ready := inReady
  assert(inReady === (pending < 5.U), "RowWindow: the input-ready register")
  val centre: PostBeat = ent(4)
  val u: UInt = Mux(centre.sof, 0.U, colReg)
  private val rowEnds = (0 until 3).map(j => pending > j.U && ent(4 + j).eol).reduce(_ || _)
  /** The centre pixel can be computed. */
  val ready: Bool = pending =/= 0.U && (pending >= 4.U || rowEnds)
  def tap(k: Int): UInt = ent(4 + k).data.asUInt
  /** Set when the centre is taken. */
  val take: Bool = WireDefault(false.B)
  when(take) { colReg := Mux(centre.eol, 0.U, u + 1.U) }
  // Each entry's next value, chosen by the take among its own word, the next entry's and the input; the entry the
  // input goes to is decoded from `pending` (a register) for both cases, so the take only selects (it is not the
  // index of a write that is decoded after it).
  // (the input fires only with pending < 5, that is with inReady: for an entry it can reach, in.valid and the
  // pending compare imply the fire, so the selects need neither the ready register nor a decode of pending = 5)
  for (i <- 0 until N) {
    val inHereTake = in.valid && (if (i >= 3 && i - 3 < 5) pending === (i - 3).U else false.B)
    val inHereKeep = in.valid && (if (i >= 4 && i - 4 < 5) pending === (i - 4).U else false.B)
    val shifted = if (i < N - 1) ent(i + 1) else ent(i)
    ent(i) := Mux(take, Mux(inHereTake, in.bits, shifted), Mux(inHereKeep, in.bits, ent(i)))
  }
  private val pendingNext = pending + in.fire.asUInt - take.asUInt
  pending := pendingNext
  inReady := pendingNext < 5.U
}

object PostFilters {
  /** libelas gap fill of a run between valid a and b (sixteenths). */
  def gapValue(a: SInt, b: SInt): SInt = {
    // one subtraction: |a - b| < 48 as two compares of a - b with constants, a < b as its sign (an absolute value
    // and a compare of a with b were two more carry chains on the column-gap step's path at kitti)
    val d = a -& b
    Mux(d > (-48).S && d < 48.S, ((a +& b) >> 1).asSInt, Mux(d < 0.S, a, b))
  }
  /** Output register stage: `valid` when the ring has a pixel; returns (fire, register). */
  class OutReg(bits: Int, out: DecoupledIO[PostBeat]) {
    val reg = RegInit(0.U.asTypeOf(Valid(new PostBeat(bits))))
    out.valid := reg.valid
    out.bits := reg.bits
    val canLoad: Bool = !reg.valid || out.ready
    when(out.fire) { reg.valid := false.B }
    def load(data: SInt, sof: Bool, eol: Bool, eof: Bool, lastRow: Bool, width: UInt): Unit = {
      reg.valid := true.B
      reg.bits.cols := width
      reg.bits.data := data; reg.bits.sof := sof; reg.bits.eol := eol; reg.bits.eof := eof; reg.bits.lastRow := lastRow
    }
  }
}

/** Post step 2a: d -> d * 16 and the row gap pass (docs/ALGORITHM.md post 2, rows): runs of 1..ipolGapWidth
  * invalid pixels between two valid ones get gapValue; with addCorners the row's first / last valid value is
  * copied outwards over up to ipolGapWidth pixels. One row of look-ahead (the run's right end): a run table, keyed
  * by the run's first column, holds (end column, right value) written when the run ends.
  * Buffers: 2 slots x maxWidth x (dispBits + 1) + 2 x 2^colBits x (colBits + dispBits + 1) run table, all block RAM
  * (read-first). The run table is read as a pixel leaves the ring, at the column after the last valid pixel before
  * it; no write can meet that read: the output reads a complete row, the input writes the next one.
  */
class PostRowGaps(p: ElasParams) extends Module {
  private val vW = p.signedDispBits
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PostBeat(vW)))
    val out = Decoupled(new PostBeat(16))
  })
  private val gap = math.min(p.ipolGapWidth, p.maxWidth)
  val ring = new RowRing(p, vW, 0, 0, io.in, io.in.bits.data.asUInt, centreOnly = true)
  private val B = ring.B
  // One memory for both slots, addressed {slot, column}: the read address is then two registers and an increment.
  // Read-first: no read meets a write (below).
  val runEnd = Mem(B << p.colBits, UInt((p.colBits + vW).W))
  private def runAddr(slot: UInt, col: UInt): UInt = Cat(slot, col(p.colBits - 1, 0))
  val firstPos = Reg(Vec(B, UInt(p.colBits.W))); val firstVal = Reg(Vec(B, SInt(vW.W)))
  val lastPos = Reg(Vec(B, UInt(p.colBits.W))); val lastVal = Reg(Vec(B, SInt(vW.W)))
  val anyValid = Reg(Vec(B, Bool()))
  // input side: the last valid pixel of the row so far
  val inAny = Reg(Bool()); val inPrev = Reg(UInt(p.colBits.W))
  val x = io.in.bits.data
  val startRow = ring.col === 0.U
  val prevAny = !startRow && inAny
  // The run table write lands a clock late, from registers: its enable, formed from the input's start-of-frame
  // select and a column compare, drove every block RAM's write enable (PostProcess's worst path at kitti, 8.3 ns of
  // routing). The entry is first read for the row's output, which starts a clock after the row's last input at the
  // earliest, at its column 0, where the entry is not used (below).
  val runWrite = RegNext(io.in.fire && x >= 0.S && prevAny && ring.col > inPrev + 1.U, false.B)
  val runWriteAddr = RegNext(runAddr(ring.inSlot, inPrev + 1.U))
  val runWriteData = RegNext(Cat(ring.col, x.asUInt))
  when(runWrite) { runEnd.write(runWriteAddr, runWriteData) }
  when(io.in.fire && x >= 0.S) {
    when(!prevAny) { firstPos(ring.inSlot) := ring.col; firstVal(ring.inSlot) := x }
    lastPos(ring.inSlot) := ring.col; lastVal(ring.inSlot) := x
    inAny := true.B; inPrev := ring.col
  }
  when(io.in.fire && x < 0.S && startRow) { inAny := false.B }
  when(io.in.fire && io.in.bits.eol) { anyValid(ring.inSlot) := prevAny || x >= 0.S }

  // output side: the per-pixel recurrence (last valid pixel -> run table read address) in one cycle, then a stall
  // pipeline of 3 register stages (the pixel's inputs and its run table read; the fills without the entry and the
  // entry again; the run's fill) before the output register
  val o = new PostFilters.OutReg(16, io.out)
  val adv = o.canLoad
  val u = ring.outCol
  val s = ring.outSlot
  val c = ring.centre.asSInt
  val outAny = Reg(Bool()); val outPrevPos = Reg(UInt(p.colBits.W)); val outPrevVal = Reg(SInt(vW.W))
  val pAny = u =/= 0.U && outAny
  // The run table entry an invalid pixel needs is at the column after the last valid pixel before it: outPrevPos + 1,
  // read as the pixel leaves the ring, into stage 1 (the read register loads with stage 1), and registered again in
  // stage 2 before the arithmetic. Read a cycle ahead for the next pixel, the address waited for this pixel's word
  // from the ring's block RAM (its sign: valid or not), a block-RAM-to-block-RAM path (95 MHz at kitti on the ECP5).
  val runReadAddr = runAddr(s, outPrevPos + 1.U)
  val entry1 = RegEnable(runEnd.read(runReadAddr), adv)
  def x16(d: SInt): SInt = (d << 4).asSInt
  val go = ring.rowReady && adv
  // a pixel that leaves (go) is of a complete row, so the input writes the other slot, but for the late write of the
  // row's last run, which may meet the row's column 0: the entry is used only after a valid pixel (pAny)
  CollisionFree.check("PostRowGaps: runEnd", Seq(runEnd),
    Seq(CollisionFree.Read(runReadAddr, RegNext(go && pAny, false.B))), Seq(CollisionFree.Write(runWrite, runWriteAddr)))
  when(go) {
    when(c >= 0.S) { outAny := true.B; outPrevPos := u; outPrevVal := c }.elsewhen(u === 0.U) { outAny := false.B }
    ring.advanceOut()
  }
  private def st[T <: Data](x: T): T = RegEnable(x, adv)
  // 1: the pixel, its row's first / last valid pixel, the last valid pixel before it and the run table entry
  val last = ring.atLastCol
  val v1 = RegEnable(go, false.B, adv)
  val c1 = st(c); val u1 = st(u); val pAny1 = st(pAny); val any1 = st(anyValid(s))
  val firstPos1 = st(firstPos(s)); val firstVal1 = st(firstVal(s)); val lastPos1 = st(lastPos(s)); val lastVal1 = st(lastVal(s))
  val prevPos1 = st(outPrevPos); val prevVal1 = st(outPrevVal)
  val sof1 = st(ring.v === 0.U && u === 0.U); val eol1 = st(last); val isLast1 = st(ring.isLast); val w1 = st(ring.width)
  // 2: the fills that need no run table entry, and the entry registered out of its block RAM
  val v2 = RegEnable(v1, false.B, adv)
  val c2 = st(c1); val any2 = st(any1); val pAny2 = st(pAny1)
  val after2 = st(u1 > lastPos1)
  val firstOk2 = st(firstPos1 - u1 <= gap.U); val lastOk2 = st(u1 - lastPos1 <= gap.U)
  val firstFill2 = st(x16(firstVal1)); val lastFill2 = st(x16(lastVal1))
  val prevPos2 = st(prevPos1); val prevVal2 = st(prevVal1); val entry2 = st(entry1)
  val sof2 = st(sof1); val eol2 = st(eol1); val isLast2 = st(isLast1); val w2 = st(w1)
  val endCol = entry2(p.colBits + vW - 1, vW)
  val endVal = entry2(vW - 1, 0).asSInt
  // 3: the run's fill, and which fill applies
  val v3 = RegEnable(v2, false.B, adv)
  val c3 = st(c2); val any3 = st(any2); val pAny3 = st(pAny2); val after3 = st(after2)
  val firstOk3 = st(firstOk2); val lastOk3 = st(lastOk2); val firstFill3 = st(firstFill2); val lastFill3 = st(lastFill2)
  val runOk3 = st(endCol - prevPos2 - 1.U <= gap.U)
  val gapFill3 = st(PostFilters.gapValue(x16(prevVal2), x16(endVal)))
  val sof3 = st(sof2); val eol3 = st(eol2); val isLast3 = st(isLast2); val w3 = st(w2)
  val fill = Wire(SInt(16.W))
  fill := -1.S
  when(!any3) { fill := -1.S }
    .elsewhen(!pAny3) {
      if (p.addCorners) when(firstOk3) { fill := firstFill3 }
    }
    .elsewhen(after3) {
      if (p.addCorners) when(lastOk3) { fill := lastFill3 }
    }
    .otherwise {
      when(runOk3) { fill := gapFill3 }
    }
  val value = Mux(c3 >= 0.S, x16(c3), fill)
  when(adv && v3) { o.load(value, sof3, eol3, eol3 && isLast3, isLast3, w3) }
}

/** Post step 2b: the column gap pass over a G-row window, G = min(ipolGapWidth, ipolColumnWindow)
  * (docs/ALGORITHM.md post 2, columns). When a valid pixel ends a run of 1..G invalid pixels above it (or, with
  * addCorners, the top run of <= G rows, or at the last row the bottom run of <= G rows), a marker (fill value,
  * end row) is written into the run's first pixel, still in the window; the output side carries the fill down the
  * column in a per-column register memory.
  * Buffers: (G + 2) slots x maxWidth x (18 + rowBits); 2 x maxWidth column memories; all block RAM (SyncReadMem),
  * read one cycle ahead. The input-side column memory is read at the input's next column (the steps' streams are
  * framed exactly: a start of frame comes at column 0; at row 0 the word read is not used), the output-side one at
  * the ring's next output column; neither read meets a write of the same cycle (a row is at least 2 pixels wide).
  */
class PostColumnGaps(p: ElasParams) extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PostBeat(16)))
    val out = Decoupled(new PostBeat(16))
  })
  private val G = math.min(p.ipolGapWidth, p.ipolColumnWindow)
  private val rW = p.rowBits + 1
  // word: {marker, end row, value}; a marked pixel is invalid, so its value field holds the fill
  private val wordBits = 1 + rW + 16
  private def word(marker: Bool, end: UInt, value: SInt): UInt = Cat(marker, end.pad(rW), value.asUInt)
  // The input passes 2 register stages before the ring (a stall pipeline: both advance when the ring takes a pixel
  // or stage 2 is empty): 1 holds the pixel with its column's last valid pixel above; 2 the marker it writes.
  class In1 extends Bundle {
    val beat = new PostBeat(16); val r = UInt(p.rowBits.W); val lAny = Bool(); val lRow = UInt(p.rowBits.W)
    val lVal = SInt(16.W)
  }
  class In2 extends Bundle {
    val beat = new PostBeat(16); val writeWord = UInt(wordBits.W); val extra = Bool(); val back = UInt(rW.W)
    val extraWord = UInt(wordBits.W)
  }
  val ringIn = Wire(Decoupled(new PostBeat(16)))
  val s1 = RegInit(0.U.asTypeOf(Valid(new In1)))
  val s2 = RegInit(0.U.asTypeOf(Valid(new In2)))
  val adv = !s2.valid || ringIn.ready // the input stages advance
  io.in.ready := adv
  // the input's row and column (as the ring counts them)
  val inCol = RegInit(0.U(p.colBits.W)); val inRow = RegInit(0.U(p.rowBits.W))
  // per column, input side: the last valid pixel above (row, value) in this frame
  // read-first (a `Mem` read into a register): the read is at the next column (or 0 after a row's end), the write at
  // this one, so they never meet (rows are at least 2 wide)
  val lastMem = Mem(p.maxWidth, UInt((1 + p.rowBits + 16).W))
  val x = io.in.bits.data
  val r = Mux(io.in.bits.sof && inCol === 0.U, 0.U, inRow)
  val u = Mux(io.in.bits.sof, 0.U, inCol)
  val lastReadAddr = Mux(io.in.fire, Mux(io.in.bits.eol, 0.U, u + 1.U), inCol)
  val lw = RegNext(lastMem.read(lastReadAddr))
  CollisionFree.check("PostColumnGaps: lastMem", Seq(lastMem), Seq(CollisionFree.Read(lastReadAddr, true.B)),
    Seq(CollisionFree.Write(io.in.fire, u)))
  val lAny = r =/= 0.U && lw(p.rowBits + 16)
  val lRow = lw(p.rowBits + 15, 16)
  val lVal = lw(15, 0).asSInt
  when(io.in.fire) {
    lastMem.write(u, Mux(x >= 0.S, Cat(true.B, r, x.asUInt), Cat(lAny, lRow, lVal.asUInt)))
    inCol := u + 1.U
    when(io.in.bits.eol) { inCol := 0.U; inRow := Mux(io.in.bits.lastRow, 0.U, r + 1.U) }
  }
  when(adv) {
    s1.valid := io.in.valid
    s1.bits.beat := io.in.bits; s1.bits.r := r; s1.bits.lAny := lAny; s1.bits.lRow := lRow; s1.bits.lVal := lVal
  }
  // stage 1 -> 2: the marker (fill value, end row) for the first pixel of the run this pixel ends, back rows up
  val x1 = s1.bits.beat.data
  val r1 = s1.bits.r
  val gapRows = r1 - s1.bits.lRow - 1.U // invalid rows between the last valid pixel above and this one
  val markBack = WireDefault(0.U(rW.W)) // rows from the marked pixel down to this one
  val markEnd = WireDefault(0.U(rW.W))
  val markFill = WireDefault(0.S(16.W))
  val mark = WireDefault(false.B)
  when(x1 >= 0.S) {
    when(s1.bits.lAny) {
      when(gapRows >= 1.U && gapRows <= G.U) {
        mark := true.B; markBack := gapRows; markEnd := r1; markFill := PostFilters.gapValue(s1.bits.lVal, x1)
      }
    }.otherwise {
      if (p.addCorners) when(r1 >= 1.U && r1 <= G.U) { mark := true.B; markBack := r1; markEnd := r1; markFill := x1 }
    }
  }.elsewhen(s1.bits.beat.lastRow && s1.bits.lAny) {
    if (p.addCorners) when(r1 - s1.bits.lRow <= G.U) {
      mark := true.B; markBack := gapRows; markEnd := r1 +& 1.U; markFill := s1.bits.lVal
    }
  }
  val markHere = mark && markBack === 0.U
  when(adv) {
    s2.valid := s1.valid
    s2.bits.beat := s1.bits.beat
    s2.bits.writeWord := word(markHere, markEnd, Mux(markHere, markFill, x1))
    s2.bits.extra := mark && !markHere
    s2.bits.back := markBack
    s2.bits.extraWord := word(true.B, markEnd, markFill)
  }
  ringIn.valid := s2.valid
  ringIn.bits := s2.bits.beat
  val ring = new RowRing(p, wordBits, 0, G, ringIn, 0.U, centreOnly = true)
  ring.writeWord := s2.bits.writeWord
  ring.extraWrite := ringIn.fire && s2.bits.extra
  ring.extraSlot := ring.wrapSub(ring.inSlot, s2.bits.back)
  ring.extraWord := s2.bits.extraWord

  // output side: the fill running down each column
  val activeMem = SyncReadMem(p.maxWidth, UInt((1 + rW + 16).W))
  val o = new PostFilters.OutReg(16, io.out)
  val ou = ring.outCol
  val w = ring.centre
  val a = activeMem.read(ring.outColNext)
  // Two register stages (stall pipeline) between the memories and the value: the ring word, the column's running
  // fill, the row and the framing. Stage 1's copy of the fill is the block RAM's own output register (synthesis
  // merges it), whose clock-to-out leaves too little of the clock for the compare and select, so they start from
  // stage 2. The running fill of column u is written back from stage 2; the next read of column u (next row) is
  // issued width - 1 >= 2 cycles after stage 2 held column u, so it sees the write (rows are at least 32 wide).
  val oAdv = o.canLoad
  val goOut = ring.rowReady && oAdv
  when(goOut) { ring.advanceOut() }
  private def st[T <: Data](x: T): T = RegEnable(x, oAdv)
  val ov1 = RegEnable(goOut, false.B, oAdv)
  val w1 = st(w); val a1 = st(a); val v1 = st(ring.v); val u1 = st(ou)
  val sof1 = st(ring.v === 0.U && ou === 0.U); val eol1 = st(ring.atLastCol); val isLast1 = st(ring.isLast)
  val width1 = st(ring.width)
  val ov = RegEnable(ov1, false.B, oAdv)
  val w2 = st(w1); val a2 = st(a1); val v2 = st(v1); val u2 = st(u1)
  val sof2 = st(sof1); val eol2 = st(eol1); val isLast2 = st(isLast1); val width2 = st(width1)
  val wValue2 = w2(15, 0).asSInt
  val wEnd2 = w2(15 + rW, 16)
  val wMark2 = w2(wordBits - 1)
  val aOn = v2 =/= 0.U && a2(rW + 16) && v2 < a2(rW + 15, 16)
  val value = Mux(wMark2, wValue2, Mux(aOn, a2(15, 0).asSInt, wValue2)) // a marked word's value is its fill
  when(oAdv && ov) {
    o.load(value, sof2, eol2, eol2 && isLast2, isLast2, width2)
    activeMem.write(u2, Mux(wMark2, Cat(true.B, wEnd2, wValue2.asUInt), Mux(v2 === 0.U, 0.U, a2)))
  }
  // the read is 1 to 3 pixels after the write in raster order, never the same column (rows are at least 32 wide)
  CollisionFree.check("PostColumnGaps: activeMem", Seq(activeMem), Seq(CollisionFree.Read(ring.outColNext, true.B)),
    Seq(CollisionFree.Write(oAdv && ov, u2)))
}

/** The output framing of a filter step's pixel (what [[PostFilters.OutReg.load]] takes besides the value). */
class PostFrame(colBits: Int) extends Bundle {
  val sof = Bool(); val eol = Bool(); val eof = Bool(); val lastRow = Bool()
  val cols = UInt(colBits.W)
}

/** The taps of a filter step's centre pixel, from a [[RowRing]] (vertical) or a [[RowWindow]] (horizontal):
  * taps k = -before .. after, whether the window lies in the frame, whether the centre can be taken, its framing and
  * the call that takes it.
  */
class FilterTaps(p: ElasParams, bits: Int, above: Int, below: Int, vertical: Boolean, in: DecoupledIO[PostBeat]) {
  /** Vertical: every ring slot's word (block-RAM registers) and the slot of each tap, for a step that registers the
    * words before it orders them into taps. */
  var slotWords: Option[(Seq[UInt], Seq[UInt])] = None
  private def frame(sof: Bool, eol: Bool, eof: Bool, lastRow: Bool, cols: UInt): PostFrame = {
    val f = Wire(new PostFrame(p.colBits))
    f.sof := sof; f.eol := eol; f.eof := eof; f.lastRow := lastRow; f.cols := cols
    f
  }
  val (taps, inRange, ready, framing, take): (Seq[UInt], Bool, Bool, PostFrame, () => Unit) =
    if (vertical) {
      val ring = new RowRing(p, bits, above, below, in, in.bits.data.asUInt)
      val win = ring.window
      val u = ring.outCol
      val last = ring.atLastCol
      slotWords = Some((ring.column, (-above to below).map(ring.slotAt)))
      (win.map(_._1), win.map(_._2).reduce(_ && _), ring.rowReady,
        frame(ring.v === 0.U && u === 0.U, last, last && ring.isLast, ring.isLast, ring.width), () => ring.advanceOut())
    } else {
      val w = new RowWindow(p, bits, in)
      val c = w.centre
      ((-above to below).map(k => w.tap(k)), w.u >= above.U && w.u +& 4.U <= c.cols, w.ready,
        frame(c.sof, c.eol, c.eof, c.lastRow, c.cols), () => w.take := true.B)
    }
}

/** Post step 3: adaptive mean, one direction (docs/ALGORITHM.md post 3). Horizontal: taps p-4..p+3 of the row for
  * 4 <= p <= W-4, from a [[RowWindow]] over the stream; vertical: rows v-4..v+3 for 4 <= v <= H-4 (window rows
  * read from the ring at the same column).
  * A pipeline of 9 register stages (10 vertically: the ring's slot words first): taps; distances to the centre; weights; pair sums of the weighted taps;
  * numerator and denominator; dividend and reciprocal; the product as 4 partial products, then 3 terms, then whole
  * (each partial product fits one 18 x 18 multiplier). It never stalls: a pixel enters only with a credit for the
  * output queue ([[PostMean.outEntries]] entries, room for every pixel entered and not yet taken), so the
  * consumer's ready reaches the queue and the credit count, not the enable of every stage register (a stall
  * pipeline made that ready a net of several hundred enables across the part: the whole top's critical path).
  * Buffers: horizontal 9 pixel registers; vertical 9 slots x maxWidth x 16 (block RAM); the output queue.
  */
class PostMean(p: ElasParams, vertical: Boolean) extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PostBeat(16)))
    val out = Decoupled(new PostBeat(16))
  })
  val t = new FilterTaps(p, 16, 4, 3, vertical, io.in)
  val out = new CreditQueue(new PostBeat(16), PostMean.outEntries, "PostMean")
  io.out <> out.deq
  val go = t.ready && out.creditOk
  when(go) { t.take() }
  out.spend(go)
  private def st[T <: Data](x: T): T = { val r = Reg(chiselTypeOf(x)); r := x; r }
  private def stValid(x: Bool): Bool = RegNext(x, false.B)
  // 1: taps
  // 0 (vertical only): the ring slots' words registered as they are, before the slot select orders them into taps
  // (a block RAM's word through the 9:1 select into the tap register was PostProcess's critical path at `small`)
  val (v1, x1, r1, f1) = t.slotWords match {
    case Some((words, slots)) =>
      val v0 = stValid(go); val w0 = st(VecInit(words)); val s0 = st(VecInit(slots)); val r0 = st(t.inRange)
      val f0 = st(t.framing)
      (stValid(v0), st(VecInit(s0.map(s => w0(s).asSInt))), st(r0), st(f0))
    case None => (stValid(go), st(VecInit(t.taps.map(_.asSInt))), st(t.inRange), st(t.framing))
  }
  // 2: distances to the centre
  val v2 = stValid(v1); val x2 = st(x1); val r2 = st(r1); val f2 = st(f1)
  val d2 = st(VecInit(x1.map(xi => (xi - x1(4)).abs)))
  // 3: weights 0 / 2 / 4
  val weights = x2.zip(d2).map { case (xi, a) =>
    Mux(xi < 0.S, 0.U(3.W), Mux(a < 32.S, 4.U(3.W), Mux(a < 128.S, 2.U(3.W), 0.U(3.W))))
  }
  val v3 = stValid(v2); val x3 = st(x2); val r3 = st(r2); val f3 = st(f2)
  val w3 = st(VecInit(weights))
  // 4: pair sums of the weighted taps and of the weights
  // (a weight is 0, 2 or 4: a shift and a select, not a multiplier)
  val n3 = x3.zip(w3).map { case (xi, wi) =>
    val x = xi.asUInt(15, 0)
    Mux(wi(2), Cat(x, 0.U(2.W)), Mux(wi(1), Cat(x, 0.U(1.W)), 0.U))
  }
  val v4 = stValid(v3); val c4 = st(x3(4)); val r4 = st(r3); val f4 = st(f3)
  val n4 = st(VecInit(n3.grouped(2).map(g => g(0) +& g(1)).toSeq))
  val w4 = st(VecInit(w3.grouped(2).map(g => g(0) +& g(1)).toSeq))
  // 5: numerator and denominator
  val v5 = stValid(v4); val c5 = st(c4); val r5 = st(r4); val f5 = st(f4)
  val num = st(n4.reduce(_ +& _)); val den = st(w4.reduce(_ +& _))
  require(16 * p.dispMax * 32 < (1 << 20), s"dispMax = ${p.dispMax}: the adaptive mean's dividend must stay below 2^21")
  // roundDiv(num, den) = floor((2 num + den) / (2 den)) without a divider: 2 den is one of 8, 12, .., 64 and the
  // dividend is below 2^21, so n / d = (n * ceil(2^27 / d)) >> 27 exactly (the error n (m d - 2^27) stays below 2^27).
  private val recip = VecInit((0 to 32).map(d => if (d >= 4) ((BigInt(1) << 27) + 2 * d - 1) / (2 * d) else BigInt(0)).map(_.U(25.W)))
  // 6: dividend and reciprocal
  val v6 = stValid(v5); val c6 = st(c5); val r6 = st(r5); val f6 = st(f5)
  val dividend = st(((num << 1) +& den)(20, 0)); val rcp = st(recip(den(5, 0))) // den <= 32
  // 7: the four partial products of 17-bit halves (one 18 x 18 multiplier each)
  val v7 = stValid(v6); val c7 = st(c6); val r7 = st(r6); val f7 = st(f6)
  private def lo(x: UInt) = x(16, 0)
  private def hi(x: UInt) = x(x.getWidth - 1, 17)
  val pLL = st(lo(dividend) * lo(rcp)); val pLH = st(lo(dividend) * hi(rcp))
  val pHL = st(hi(dividend) * lo(rcp)); val pHH = st(hi(dividend) * hi(rcp))
  // 8: the middle terms summed
  val v8 = stValid(v7); val c8 = st(c7); val r8 = st(r7); val f8 = st(f7)
  val qL = st(pLL); val qM = st(pLH +& pHL); val qH = st(pHH)
  // 9: the product
  val v9 = stValid(v8); val c9 = st(c8); val r9 = st(r8); val f9 = st(f8)
  val prod = st(qL +& (qM << 17) +& (qH << 34))
  val mean = (prod >> 27)(15, 0)
  val value = Mux(r9 && c9 >= 0.S, mean.asSInt, c9)
  val outBeat = Reg(new PostBeat(16))
  outBeat.data := value; outBeat.sof := f9.sof; outBeat.eol := f9.eol; outBeat.eof := f9.eof
  outBeat.lastRow := f9.lastRow; outBeat.cols := f9.cols
  out.enq(RegNext(v9, false.B), outBeat)
}

object PostMean {
  /** Output queue entries: at full rate a pixel is owed for 13 clocks (the 10 stages of the vertical pass, the output
    * register, the queue, the credit's register), and one more. Fewer would leave bubbles, never lose a pixel. */
  val outEntries: Int = 14
}

/** Post step 4: 7-tap median, one direction (docs/ALGORITHM.md post 4), 4th smallest with invalid taps as -1.
  * Horizontal for 3 <= u <= W-4 where the pixel is valid (a [[RowWindow]] over the stream); vertical for
  * 3 <= v <= H-4 where the median's input was valid (carried as bit 16 of the horizontal result). A stall pipeline of
  * 2 register stages: taps; the pairwise comparisons. Buffers: horizontal 9 pixel registers, vertical 8 slots x
  * maxWidth (block RAM).
  */
class PostMedian(p: ElasParams, vertical: Boolean) extends Module {
  private val inBits = if (vertical) 17 else 16
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PostBeat(inBits)))
    val out = Decoupled(new PostBeat(if (vertical) 16 else 17))
  })
  val o = new PostFilters.OutReg(if (vertical) 16 else 17, io.out)
  val t = new FilterTaps(p, inBits, 3, 3, vertical, io.in)
  val adv = o.canLoad
  val go = t.ready && adv
  when(go) { t.take() }
  private def st[T <: Data](x: T): T = RegEnable(x, adv)
  private def stValid(x: Bool): Bool = RegEnable(x, false.B, adv)
  val centreValidNow = if (vertical) t.taps(3)(16) else t.taps(3)(15, 0).asSInt >= 0.S
  // 1: taps
  val v1 = stValid(go); val x1 = st(VecInit(t.taps.map(_(15, 0).asSInt))); val r1 = st(t.inRange)
  val cv1 = st(centreValidNow); val f1 = st(t.framing)
  // 2: rank selection: element i is the 4th smallest if exactly 3 elements sort before it (ties by index)
  val lessThan = x1.indices.map(i => x1.indices.filter(_ != i).map(j => if (j < i) x1(j) <= x1(i) else x1(j) < x1(i)))
  val v2 = stValid(v1); val x2 = st(x1); val r2 = st(r1); val cv2 = st(cv1); val f2 = st(f1)
  val b2 = st(VecInit(lessThan.map(l => VecInit(l))))
  val med = Mux1H(b2.map(l => PopCount(l) === 3.U), x2)
  val value = Mux(r2 && cv2, med, x2(3))
  when(adv && v2) {
    val data = if (vertical) value else Cat(cv2, value.asUInt(15, 0)).asSInt
    o.load(data, f2.sof, f2.eol, f2.eof, f2.lastRow, f2.cols)
  }
}
