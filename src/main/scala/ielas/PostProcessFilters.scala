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

/** Row ring shared by the post steps after speckle: B = above + below + 2 row slots of maxWidth words, one memory
  * per slot. The input writes rows in order; output pixel (v, u) is read once rows v .. v + below - 1 have arrived
  * and row v + below up to column u (or the frame's last row is among them); with below = 0, once row v is complete
  * or, for a step that reads only `ahead` columns ahead, once column u + ahead of row v has arrived. The input stalls only when the slot it needs still holds a row the window reads.
  * Build it inside a Module; `word` is what a slot stores per pixel.
  */
class RowRing(p: ElasParams, wordBits: Int, above: Int, below: Int, in: DecoupledIO[PostBeat], inWord: UInt,
    ahead: Int = -1) {
  val B: Int = above + below + 2
  private val W = p.maxWidth
  private val seqW = 16
  private def seqGe(a: UInt, b: UInt): Bool = !(a - b)(seqW - 1)
  def slotOf(seq: UInt): UInt = (seq % B.U)(log2Ceil(B) - 1, 0)

  val mems: Seq[Mem[UInt]] = Seq.fill(B)(Mem(W, UInt(wordBits.W)))
  val metaRow: Vec[UInt] = Reg(Vec(B, UInt(p.rowBits.W)))
  val metaLast: Vec[Bool] = Reg(Vec(B, Bool()))
  val metaW: Vec[UInt] = Reg(Vec(B, UInt(p.colBits.W)))

  // ---- input side ----
  val inSeq: UInt = RegInit(0.U(seqW.W)) // rows completed
  val inCol: UInt = RegInit(0.U(p.colBits.W))
  val inRow: UInt = RegInit(0.U(p.rowBits.W))
  val outSeq: UInt = RegInit(0.U(seqW.W))
  val outCol: UInt = RegInit(0.U(p.colBits.W))
  val inSlot: UInt = slotOf(inSeq)
  // slot of row inSeq last held row inSeq - B; the window of row outSeq reaches back to outSeq - above
  in.ready := seqGe(outSeq - above.U + B.U, inSeq + 1.U)
  val col: UInt = Mux(in.bits.sof, 0.U, inCol)
  val row: UInt = Mux(in.bits.sof && inCol === 0.U, 0.U, inRow)
  /** Marker write into an earlier slot (set by the step; slot must differ from inSlot). */
  val extraWrite: Bool = WireDefault(false.B)
  val extraSlot: UInt = WireDefault(0.U(log2Ceil(B).W))
  val extraCol: UInt = WireDefault(0.U(p.colBits.W))
  val extraWord: UInt = WireDefault(0.U(wordBits.W))
  val writeWord: UInt = WireDefault(inWord)
  for ((m, s) <- mems.zipWithIndex) { // one write port per slot: the current row, or a marker into an earlier row
    val here = in.fire && inSlot === s.U
    when(here || extraWrite && extraSlot === s.U) { m.write(Mux(here, col, extraCol), Mux(here, writeWord, extraWord)) }
  }
  when(in.fire) {
    metaRow(inSlot) := row
    metaLast(inSlot) := in.bits.lastRow
    metaW(inSlot) := in.bits.cols
    inCol := col + 1.U
    when(in.bits.eol) {
      inCol := 0.U
      inSeq := inSeq + 1.U
      inRow := Mux(in.bits.lastRow, 0.U, row + 1.U)
    }
  }

  // ---- output side ----
  val outSlot: UInt = slotOf(outSeq)
  private def complete(k: Int): Bool = seqGe(inSeq, outSeq + (k + 1).U)
  private def lastAt(k: Int): Bool = metaLast(slotOf(outSeq + k.U))
  // Row v + below may still be arriving: column u of row v only needs column u of that row (vertical windows and
  // the column pass's markers, which are written while that column is taken).
  private val early: Bool = if (below == 0) false.B
    else (0 until below).map(k => complete(k) && !lastAt(k)).reduce(_ && _) && inSeq === outSeq + below.U && inCol > outCol
  // With below = 0 and ahead >= 0, pixel u of row v needs only columns up to u + ahead of that row.
  private val earlyRow: Bool = if (ahead < 0) false.B else inSeq === outSeq && inCol > outCol +& ahead.U
  val rowReady: Bool = if (below == 0) complete(0) || earlyRow
    else complete(0) && (complete(below) || early || (0 until below).map(k => complete(k) && lastAt(k)).reduce(_ || _))
  val v: UInt = metaRow(outSlot)
  val width: UInt = metaW(outSlot)
  val isLast: Bool = metaLast(outSlot)
  /** Window rows v + k, k = -above .. below, at column c; with whether that row exists in the frame. */
  def windowAt(c: UInt): Seq[(UInt, Bool)] = {
    val column = VecInit(mems.map(_(c))) // one read per slot memory; the taps select among them
    (-above to below).map(k => windowTap(column, k))
  }
  private def windowTap(column: Vec[UInt], k: Int): (UInt, Bool) = {
    val slot = slotOf(outSeq + k.S(seqW.W).asUInt)
    val word = column(slot)
    val exists =
      if (k < 0) v >= (-k).U
      else if (k == 0) true.B
      else (0 until k).map(j => !lastAt(j)).reduce(_ && _) && (complete(k) || inSeq === outSeq + k.U && inCol > outCol)
    (word, exists)
  }
  /** Row v at column c. */
  def centreAt(c: UInt): UInt = VecInit(mems.map(_(c)))(outSlot)
  /** Call when output pixel (v, outCol) is taken. */
  def advanceOut(): Unit = {
    outCol := outCol + 1.U
    when(outCol === width - 1.U) { outCol := 0.U; outSeq := outSeq + 1.U }
  }
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
  * Buffers: 2 slots x maxWidth x (dispBits + 1) + 2 x maxWidth x (colBits + dispBits) run table.
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
  val runEnd = Seq.fill(B)(Mem(p.maxWidth, UInt((p.colBits + vW).W)))
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
  val c = ring.centreAt(u).asSInt
  val outAny = Reg(Bool()); val outPrevPos = Reg(UInt(p.colBits.W)); val outPrevVal = Reg(SInt(vW.W))
  val pAny = u =/= 0.U && outAny
  val entry = VecInit(runEnd.map(_(outPrevPos + 1.U)))(s)
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
    when(c >= 0.S) { outAny := true.B; outPrevPos := u; outPrevVal := c }.elsewhen(u === 0.U) { outAny := false.B }
    ring.advanceOut()
  }
}

/** Post step 2b: the column gap pass over a G-row window, G = min(ipolGapWidth, ipolColumnWindow)
  * (docs/ALGORITHM.md post 2, columns). When a valid pixel ends a run of 1..G invalid pixels above it (or, with
  * addCorners, the top run of <= G rows, or at the last row the bottom run of <= G rows), a marker (fill value,
  * end row) is written into the run's first pixel, still in the window; the output side carries the fill down the
  * column in a per-column register memory.
  * Buffers: (G + 2) slots x maxWidth x (18 + rowBits); 2 x maxWidth column memories.
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
  val lastMem = Mem(p.maxWidth, UInt((1 + p.rowBits + 16).W))
  val x = io.in.bits.data
  val r = ring.row
  val u = ring.col
  val lw = lastMem(u)
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
  ring.extraSlot := ring.slotOf(ring.inSeq - (r - markRow))
  ring.extraCol := u
  ring.extraWord := word(true.B, markEnd, markFill)
  when(io.in.fire) {
    lastMem.write(u, Mux(x >= 0.S, Cat(true.B, r, x.asUInt), Cat(lAny, lRow, lVal.asUInt)))
  }

  // output side: the fill running down each column
  val activeMem = Mem(p.maxWidth, UInt((1 + rW + 16).W))
  val o = new PostFilters.OutReg(16, io.out)
  val ou = ring.outCol
  val w = ring.centreAt(ou)
  val wValue = w(15, 0).asSInt
  val wFill = wValue
  val wEnd = w(15 + rW, 16)
  val wMark = w(wordBits - 1)
  val a = activeMem(ou)
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
  * 4 <= p <= W-4; vertical: rows v-4..v+3 for 4 <= v <= H-4 (window rows read from the ring at the same column).
  * Buffers: horizontal 2 slots, vertical 9 slots, x maxWidth x 16.
  */
class PostMean(p: ElasParams, vertical: Boolean) extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PostBeat(16)))
    val out = Decoupled(new PostBeat(16))
  })
  val ring = new RowRing(p, 16, if (vertical) 4 else 0, if (vertical) 3 else 0, io.in, io.in.bits.data.asUInt,
    ahead = if (vertical) -1 else 3)
  val o = new PostFilters.OutReg(16, io.out)
  val u = ring.outCol
  val (taps, inRange) =
    if (vertical) {
      val win = ring.windowAt(u)
      (win.map(_._1.asSInt), win.map(_._2).reduce(_ && _))
    } else {
      val t = (-4 to 3).map(k => ring.centreAt(u + k.S(p.colBits.W).asUInt).asSInt)
      (t, u >= 4.U && u +& 4.U <= ring.width)
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
  val go = ring.rowReady && o.canLoad
  when(go) {
    o.load(value, ring.v === 0.U && u === 0.U, u === ring.width - 1.U, u === ring.width - 1.U && ring.isLast, ring.isLast, ring.width)
    ring.advanceOut()
  }
}

/** Post step 4: 7-tap median, one direction (docs/ALGORITHM.md post 4), 4th smallest with invalid taps as -1.
  * Horizontal for 3 <= u <= W-4 where the pixel is valid; vertical for 3 <= v <= H-4 where the median's input was
  * valid (carried as bit 16 of the horizontal result). Buffers: horizontal 2 slots, vertical 8 slots, x maxWidth.
  */
class PostMedian(p: ElasParams, vertical: Boolean) extends Module {
  private val inBits = if (vertical) 17 else 16
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PostBeat(inBits)))
    val out = Decoupled(new PostBeat(if (vertical) 16 else 17))
  })
  val ring = new RowRing(p, inBits, if (vertical) 3 else 0, if (vertical) 3 else 0, io.in, io.in.bits.data.asUInt,
    ahead = if (vertical) -1 else 3)
  val o = new PostFilters.OutReg(if (vertical) 16 else 17, io.out)
  val u = ring.outCol
  val (taps, inRange, centreValid, centre) =
    if (vertical) {
      val win = ring.windowAt(u)
      val t = win.map(_._1(15, 0).asSInt)
      (t, win.map(_._2).reduce(_ && _), win(3)._1(16), t(3))
    } else {
      val t = (-3 to 3).map(k => ring.centreAt(u + k.S(p.colBits.W).asUInt).asSInt)
      (t, u >= 3.U && u +& 4.U <= ring.width, t(3) >= 0.S, t(3))
    }
  // rank selection: element i is the 4th smallest if exactly 3 elements sort before it (ties by index)
  val before = taps.indices.map(i => taps.indices.filter(_ != i).map(j =>
    (if (j < i) taps(j) <= taps(i) else taps(j) < taps(i)).asUInt).reduce(_ +& _))
  val med = Mux1H(before.map(_ === 3.U), taps)
  val value = Mux(inRange && centreValid, med, centre)
  val go = ring.rowReady && o.canLoad
  when(go) {
    val data = if (vertical) value else Cat(centreValid, value.asUInt(15, 0)).asSInt
    o.load(data, ring.v === 0.U && u === 0.U, u === ring.width - 1.U, u === ring.width - 1.U && ring.isLast, ring.isLast, ring.width)
    ring.advanceOut()
  }
}
