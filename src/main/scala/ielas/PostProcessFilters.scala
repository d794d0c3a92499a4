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
  * v .. v + below - 1 have arrived and row v + below up to column u (or the frame's last row is among them); with
  * below = 0, once row v is complete. The input stalls only when the slot it needs still holds a row the window reads.
  * Build it inside a Module; `word` is what a slot stores per pixel. The output side reads every slot at one column:
  * the column it will hold next cycle ([[outColNext]], registered into the memories' read ports one cycle ahead);
  * a write in that cycle to that column of a slot (the row being written, early, or a marker) is forwarded.
  * Slots are wrapping counters (no `seq % B`).
  */
class RowRing(p: ElasParams, wordBits: Int, above: Int, below: Int, in: DecoupledIO[PostBeat], inWord: UInt) {
  val B: Int = above + below + 2
  private val W = p.maxWidth
  private val seqW = 16
  private val sW = log2Ceil(B)
  private def seqGe(a: UInt, b: UInt): Bool = !(a - b)(seqW - 1)
  def wrapInc(s: UInt): UInt = Mux(s === (B - 1).U, 0.U, s + 1.U)
  /** (slot - d) mod B for 0 <= slot < B and 0 <= d < B. */
  def wrapSub(slot: UInt, d: UInt): UInt = Mux(slot >= d, slot - d, slot +& B.U - d)(sW - 1, 0)

  val mems: Seq[SyncReadMem[UInt]] = Seq.fill(B)(SyncReadMem(W, UInt(wordBits.W)))
  val metaRow: Vec[UInt] = Reg(Vec(B, UInt(p.rowBits.W)))
  val metaLast: Vec[Bool] = Reg(Vec(B, Bool()))
  val metaW: Vec[UInt] = Reg(Vec(B, UInt(p.colBits.W)))

  // ---- input side ----
  val inSeq: UInt = RegInit(0.U(seqW.W)) // rows completed
  val inSlot: UInt = RegInit(0.U(sW.W)) // inSeq mod B
  val inCol: UInt = RegInit(0.U(p.colBits.W))
  val inRow: UInt = RegInit(0.U(p.rowBits.W))
  val outSeq: UInt = RegInit(0.U(seqW.W))
  val outCol: UInt = RegInit(0.U(p.colBits.W))
  /** outCol next cycle (the read address of every slot). */
  val outColNext: UInt = WireDefault(outCol)
  outCol := outColNext
  // slot of row inSeq last held row inSeq - B; the window of row outSeq reaches back to outSeq - above
  in.ready := seqGe(outSeq - above.U + B.U, inSeq + 1.U)
  val col: UInt = Mux(in.bits.sof, 0.U, inCol)
  val row: UInt = Mux(in.bits.sof && inCol === 0.U, 0.U, inRow)
  /** Marker write into an earlier slot (set by the step; slot must differ from inSlot). */
  val extraWrite: Bool = WireDefault(false.B)
  val extraSlot: UInt = WireDefault(0.U(sW.W))
  val extraCol: UInt = WireDefault(0.U(p.colBits.W))
  val extraWord: UInt = WireDefault(0.U(wordBits.W))
  val writeWord: UInt = WireDefault(inWord)
  /** Every slot's word at column outCol (read one cycle ahead at outColNext, with the write of that cycle forwarded). */
  val column: Vec[UInt] = VecInit(mems.zipWithIndex.map { case (m, s) => // one write port per slot
    val here = in.fire && inSlot === s.U
    val wen = here || extraWrite && extraSlot === s.U
    val wAddr = Mux(here, col, extraCol)
    val wData = Mux(here, writeWord, extraWord)
    when(wen) { m.write(wAddr, wData) }
    val hit = RegNext(wen && wAddr === outColNext, false.B)
    val fwd = RegEnable(wData, wen)
    Mux(hit, fwd, m.read(outColNext))
  })
  when(in.fire) {
    metaRow(inSlot) := row
    metaLast(inSlot) := in.bits.lastRow
    metaW(inSlot) := in.bits.cols
    inCol := col + 1.U
    when(in.bits.eol) {
      inCol := 0.U
      inSeq := inSeq + 1.U
      inSlot := wrapInc(inSlot)
      inRow := Mux(in.bits.lastRow, 0.U, row + 1.U)
    }
  }

  // ---- output side ----
  val outSlot: UInt = RegInit(0.U(sW.W)) // outSeq mod B
  /** slotAt(k) = (outSeq + k) mod B, k = -above .. below, as registers that advance with outSeq. */
  private val rel: Map[Int, UInt] = (-above to below).map(k =>
    k -> (if (k == 0) outSlot else RegInit((((k % B) + B) % B).U(sW.W)))).toMap
  def slotAt(k: Int): UInt = rel(k)
  private def complete(k: Int): Bool = seqGe(inSeq, outSeq + (k + 1).U)
  private def lastAt(k: Int): Bool = metaLast(slotAt(k))
  // Row v + below may still be arriving: column u of row v only needs column u of that row (vertical windows and
  // the column pass's markers, which are written while that column is taken).
  private val early: Bool = if (below == 0) false.B
    else (0 until below).map(k => complete(k) && !lastAt(k)).reduce(_ && _) && inSeq === outSeq + below.U && inCol > outCol
  val rowReady: Bool = if (below == 0) complete(0)
    else complete(0) && (complete(below) || early || (0 until below).map(k => complete(k) && lastAt(k)).reduce(_ || _))
  val v: UInt = metaRow(outSlot)
  val width: UInt = metaW(outSlot)
  val isLast: Bool = metaLast(outSlot)
  /** Window rows v + k, k = -above .. below, at column outCol; with whether that row exists in the frame. */
  def window: Seq[(UInt, Bool)] = (-above to below).map(k => windowTap(k))
  private def windowTap(k: Int): (UInt, Bool) = {
    val word = column(slotAt(k))
    val exists =
      if (k < 0) v >= (-k).U
      else if (k == 0) true.B
      else (0 until k).map(j => !lastAt(j)).reduce(_ && _) && (complete(k) || inSeq === outSeq + k.U && inCol > outCol)
    (word, exists)
  }
  /** Row v at column outCol. */
  def centre: UInt = column(outSlot)
  /** Call when output pixel (v, outCol) is taken. */
  def advanceOut(): Unit = {
    outColNext := outCol + 1.U
    when(outCol === width - 1.U) {
      outColNext := 0.U
      outSeq := outSeq + 1.U
      for (k <- -above to below) rel(k) := wrapInc(rel(k))
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
  in.ready := pending < 5.U
  val centre: PostBeat = ent(4)
  val u: UInt = Mux(centre.sof, 0.U, colReg)
  private val rowEnds = (0 until 3).map(j => pending > j.U && ent(4 + j).eol).reduce(_ || _)
  /** The centre pixel can be computed. */
  val ready: Bool = pending =/= 0.U && (pending >= 4.U || rowEnds)
  def tap(k: Int): UInt = ent(4 + k).data.asUInt
  /** Set when the centre is taken. */
  val take: Bool = WireDefault(false.B)
  when(take) {
    for (i <- 0 until N - 1) ent(i) := ent(i + 1)
    colReg := Mux(centre.eol, 0.U, u + 1.U)
  }
  when(in.fire) { ent(Mux(take, pending +& 3.U, pending +& 4.U)) := in.bits }
  pending := pending + in.fire.asUInt - take.asUInt
}

object PostFilters {
  /** libelas gap fill of a run between valid a and b (sixteenths). */
  def gapValue(a: SInt, b: SInt): SInt = {
    val diff = (a - b).abs
    Mux(diff < 48.S, ((a +& b) >> 1).asSInt, Mux(a < b, a, b))
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
  * Buffers: 2 slots x maxWidth x (dispBits + 1) + 2 x maxWidth x (colBits + dispBits + 1) run table, all block RAM
  * (SyncReadMem) read one cycle ahead. The run table is read at the column after the last valid pixel the output
  * has passed; no write can meet that read: the output reads a complete row, the input writes the next one.
  */
class PostRowGaps(p: ElasParams) extends Module {
  private val vW = p.dispBits + 1
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PostBeat(vW)))
    val out = Decoupled(new PostBeat(16))
  })
  private val gap = math.min(p.ipolGapWidth, p.maxWidth)
  val ring = new RowRing(p, vW, 0, 0, io.in, io.in.bits.data.asUInt)
  private val B = ring.B
  val runEnd = Seq.fill(B)(SyncReadMem(p.maxWidth, UInt((p.colBits + vW).W)))
  val firstPos = Reg(Vec(B, UInt(p.colBits.W))); val firstVal = Reg(Vec(B, SInt(vW.W)))
  val lastPos = Reg(Vec(B, UInt(p.colBits.W))); val lastVal = Reg(Vec(B, SInt(vW.W)))
  val anyValid = Reg(Vec(B, Bool()))
  // input side: the last valid pixel of the row so far
  val inAny = Reg(Bool()); val inPrev = Reg(UInt(p.colBits.W))
  val x = io.in.bits.data
  val startRow = ring.col === 0.U
  val prevAny = !startRow && inAny
  when(io.in.fire && x >= 0.S) {
    when(prevAny && ring.col > inPrev + 1.U) {
      for ((m, s) <- runEnd.zipWithIndex) when(ring.inSlot === s.U) { m.write(inPrev + 1.U, Cat(ring.col, x.asUInt)) }
    }
    when(!prevAny) { firstPos(ring.inSlot) := ring.col; firstVal(ring.inSlot) := x }
    lastPos(ring.inSlot) := ring.col; lastVal(ring.inSlot) := x
    inAny := true.B; inPrev := ring.col
  }
  when(io.in.fire && x < 0.S && startRow) { inAny := false.B }
  when(io.in.fire && io.in.bits.eol) { anyValid(ring.inSlot) := prevAny || x >= 0.S }

  // output side
  val o = new PostFilters.OutReg(16, io.out)
  val u = ring.outCol
  val s = ring.outSlot
  val c = ring.centre.asSInt
  val outAny = Reg(Bool()); val outPrevPos = Reg(UInt(p.colBits.W)); val outPrevVal = Reg(SInt(vW.W))
  val outPrevPosNext = WireDefault(outPrevPos)
  outPrevPos := outPrevPosNext
  val pAny = u =/= 0.U && outAny
  val entry = VecInit(runEnd.map(_.read(outPrevPosNext + 1.U)))(s)
  val endCol = entry(p.colBits + vW - 1, vW)
  val endVal = entry(vW - 1, 0).asSInt
  def x16(d: SInt): SInt = (d << 4).asSInt
  val fill = Wire(SInt(16.W))
  fill := -1.S
  when(!anyValid(s)) { fill := -1.S }
    .elsewhen(!pAny) {
      if (p.addCorners) when(firstPos(s) - u <= gap.U) { fill := x16(firstVal(s)) }
    }
    .elsewhen(u > lastPos(s)) {
      if (p.addCorners) when(u - lastPos(s) <= gap.U) { fill := x16(lastVal(s)) }
    }
    .otherwise {
      when(endCol - outPrevPos - 1.U <= gap.U) { fill := PostFilters.gapValue(x16(outPrevVal), x16(endVal)) }
    }
  val value = Mux(c >= 0.S, x16(c), fill)
  val go = ring.rowReady && o.canLoad
  when(go) {
    o.load(value, ring.v === 0.U && u === 0.U, u === ring.width - 1.U, u === ring.width - 1.U && ring.isLast, ring.isLast, ring.width)
    when(c >= 0.S) { outAny := true.B; outPrevPosNext := u; outPrevVal := c }.elsewhen(u === 0.U) { outAny := false.B }
    ring.advanceOut()
  }
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
  val ring = new RowRing(p, wordBits, 0, G, io.in, 0.U)
  // per column, input side: the last valid pixel above (row, value) in this frame
  val lastMem = SyncReadMem(p.maxWidth, UInt((1 + p.rowBits + 16).W))
  val x = io.in.bits.data
  val r = ring.row
  val u = ring.col
  val lw = lastMem.read(Mux(io.in.fire, Mux(io.in.bits.eol, 0.U, u + 1.U), ring.inCol))
  val lAny = r =/= 0.U && lw(p.rowBits + 16)
  val lRow = lw(p.rowBits + 15, 16)
  val lVal = lw(15, 0).asSInt
  val markRow = WireDefault(0.U(p.rowBits.W))
  val markEnd = WireDefault(0.U(rW.W))
  val markFill = WireDefault(0.S(16.W))
  val mark = WireDefault(false.B)
  when(x >= 0.S) {
    when(lAny) {
      when(r - lRow - 1.U >= 1.U && r - lRow - 1.U <= G.U) {
        mark := true.B; markRow := lRow + 1.U; markEnd := r; markFill := PostFilters.gapValue(lVal, x)
      }
    }.otherwise {
      if (p.addCorners) when(r >= 1.U && r <= G.U) { mark := true.B; markRow := 0.U; markEnd := r; markFill := x }
    }
  }.elsewhen(io.in.bits.lastRow && lAny) {
    if (p.addCorners) when(r - lRow <= G.U) { mark := true.B; markRow := lRow + 1.U; markEnd := r +& 1.U; markFill := lVal }
  }
  val markHere = mark && markRow === r
  ring.writeWord := word(markHere, markEnd, Mux(markHere, markFill, x))
  ring.extraWrite := io.in.fire && mark && !markHere
  ring.extraSlot := ring.wrapSub(ring.inSlot, r - markRow)
  ring.extraCol := u
  ring.extraWord := word(true.B, markEnd, markFill)
  when(io.in.fire) {
    lastMem.write(u, Mux(x >= 0.S, Cat(true.B, r, x.asUInt), Cat(lAny, lRow, lVal.asUInt)))
  }

  // output side: the fill running down each column
  val activeMem = SyncReadMem(p.maxWidth, UInt((1 + rW + 16).W))
  val o = new PostFilters.OutReg(16, io.out)
  val ou = ring.outCol
  val w = ring.centre
  val wValue = w(15, 0).asSInt
  val wFill = wValue
  val wEnd = w(15 + rW, 16)
  val wMark = w(wordBits - 1)
  val a = activeMem.read(ring.outColNext)
  val aOn = ring.v =/= 0.U && a(rW + 16) && ring.v < a(rW + 15, 16)
  val value = Mux(wMark, wFill, Mux(aOn, a(15, 0).asSInt, wValue))
  val go = ring.rowReady && o.canLoad
  when(go) {
    o.load(value, ring.v === 0.U && ou === 0.U, ou === ring.width - 1.U, ou === ring.width - 1.U && ring.isLast, ring.isLast, ring.width)
    activeMem.write(ou, Mux(wMark, Cat(true.B, wEnd, wFill.asUInt), Mux(ring.v === 0.U, 0.U, a)))
    ring.advanceOut()
  }
}

/** Post step 3: adaptive mean, one direction (docs/ALGORITHM.md post 3). Horizontal: taps p-4..p+3 of the row for
  * 4 <= p <= W-4, from a [[RowWindow]] over the stream; vertical: rows v-4..v+3 for 4 <= v <= H-4 (window rows
  * read from the ring at the same column).
  * Buffers: horizontal 9 pixel registers; vertical 9 slots x maxWidth x 16 (block RAM).
  */
class PostMean(p: ElasParams, vertical: Boolean) extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PostBeat(16)))
    val out = Decoupled(new PostBeat(16))
  })
  val o = new PostFilters.OutReg(16, io.out)
  // taps, in range, whether the centre can be taken, output framing (sof, eol, eof, lastRow, width), take
  val (taps, inRange, ready, frame, take) =
    if (vertical) {
      val ring = new RowRing(p, 16, 4, 3, io.in, io.in.bits.data.asUInt)
      val win = ring.window
      val u = ring.outCol
      val last = u === ring.width - 1.U
      (win.map(_._1.asSInt), win.map(_._2).reduce(_ && _), ring.rowReady,
        (ring.v === 0.U && u === 0.U, last, last && ring.isLast, ring.isLast, ring.width), () => ring.advanceOut())
    } else {
      val w = new RowWindow(p, 16, io.in)
      val c = w.centre
      ((-4 to 3).map(k => w.tap(k).asSInt), w.u >= 4.U && w.u +& 4.U <= c.cols, w.ready,
        (c.sof, c.eol, c.eof, c.lastRow, c.cols), () => w.take := true.B)
    }
  val c = taps(4)
  val weights = taps.map { xi =>
    val diff = (xi - c).abs
    Mux(xi < 0.S, 0.U, Mux(diff < 32.S, 4.U, Mux(diff < 128.S, 2.U, 0.U)))
  }
  val num = taps.zip(weights).map { case (xi, wi) => Mux(wi === 0.U, 0.U, xi.asUInt(15, 0) * wi) }.reduce(_ +& _)
  val den = weights.reduce(_ +& _)
  require(16 * p.dispMax * 32 < (1 << 20), s"dispMax = ${p.dispMax}: the adaptive mean's dividend must stay below 2^21")
  // roundDiv(num, den) = floor((2 num + den) / (2 den)) without a divider: 2 den is one of 8, 12, .., 64 and the
  // dividend is below 2^21, so n / d = (n * ceil(2^27 / d)) >> 27 exactly (the error n (m d - 2^27) stays below 2^27).
  private val recip = VecInit((0 to 32).map(d => if (d >= 4) ((BigInt(1) << 27) + 2 * d - 1) / (2 * d) else BigInt(0)).map(_.U(25.W)))
  val mean = ((((num << 1) +& den)(20, 0) * recip(den)) >> 27)(15, 0)
  val value = Mux(inRange && c >= 0.S, mean(15, 0).asSInt, c)
  val go = ready && o.canLoad
  when(go) {
    o.load(value, frame._1, frame._2, frame._3, frame._4, frame._5)
    take()
  }
}

/** Post step 4: 7-tap median, one direction (docs/ALGORITHM.md post 4), 4th smallest with invalid taps as -1.
  * Horizontal for 3 <= u <= W-4 where the pixel is valid (a [[RowWindow]] over the stream); vertical for
  * 3 <= v <= H-4 where the median's input was valid (carried as bit 16 of the horizontal result). Buffers:
  * horizontal 9 pixel registers, vertical 8 slots x maxWidth (block RAM).
  */
class PostMedian(p: ElasParams, vertical: Boolean) extends Module {
  private val inBits = if (vertical) 17 else 16
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PostBeat(inBits)))
    val out = Decoupled(new PostBeat(if (vertical) 16 else 17))
  })
  val o = new PostFilters.OutReg(if (vertical) 16 else 17, io.out)
  val (taps, inRange, centreValid, centre, ready, frame, take) =
    if (vertical) {
      val ring = new RowRing(p, inBits, 3, 3, io.in, io.in.bits.data.asUInt)
      val win = ring.window
      val t = win.map(_._1(15, 0).asSInt)
      val u = ring.outCol
      val last = u === ring.width - 1.U
      (t, win.map(_._2).reduce(_ && _), win(3)._1(16), t(3), ring.rowReady,
        (ring.v === 0.U && u === 0.U, last, last && ring.isLast, ring.isLast, ring.width), () => ring.advanceOut())
    } else {
      val w = new RowWindow(p, inBits, io.in)
      val c = w.centre
      val t = (-3 to 3).map(k => w.tap(k).asSInt)
      (t, w.u >= 3.U && w.u +& 4.U <= c.cols, t(3) >= 0.S, t(3), w.ready,
        (c.sof, c.eol, c.eof, c.lastRow, c.cols), () => w.take := true.B)
    }
  // rank selection: element i is the 4th smallest if exactly 3 elements sort before it (ties by index)
  val before = taps.indices.map(i => taps.indices.filter(_ != i).map(j =>
    (if (j < i) taps(j) <= taps(i) else taps(j) < taps(i)).asUInt).reduce(_ +& _))
  val med = Mux1H(before.map(_ === 3.U), taps)
  val value = Mux(inRange && centreValid, med, centre)
  val go = ready && o.canLoad
  when(go) {
    val data = if (vertical) value else Cat(centreValid, value.asUInt(15, 0)).asSInt
    o.load(data, frame._1, frame._2, frame._3, frame._4, frame._5)
    take()
  }
}
