package ielas

import chisel3._
import chisel3.util._

/** Stage `planes`: the regular triangulation of the filled lattice and the Q16 plane coefficients of both triangles
  * of every lattice cell in both views (docs/ALGORITHM.md "planes", golden/src/planes.cpp).
  *
  * Input: the filled lattice of stage `interp` (lattice raster order, every node 0..dispMax, sof / eol / eof); the
  * frame size ports are sampled with the sof node and give the node positions X_i = min(i*step, W-1),
  * Y_j = min(j*step, H-1). Output: one [[PlaneCell]] per lattice cell, raster order over (Lh-1) x (Lw-1), eol on the
  * last cell of a cell row (the cell closed by the input's eol node), eof on the last cell (closed by the input's
  * eof node).
  *
  * Cell (cr, cc) is complete when node (cr+1, cc+1) arrives: TL and BL are kept in registers from the previous node,
  * TR comes from the row memory, BR is the arriving node, which then overwrites TR's slot. So the one memory is a
  * single lattice row:
  *   row memory bits = latticeColsMax x dispBits   (kitti: 250 x 8 = 2,000 bits).
  *
  * Each complete cell goes to one of `engines` [[PlaneEngine]]s, round robin, and leaves in the same order. An
  * engine runs 8 radix-4 [[RoundDivider]]s side by side (left a, b and right a, b of both triangles; the right
  * divisors n and h*n vary per triangle, the left ones are w, h in 1..step), so a cell occupies an engine for
  * E = I + 5 cycles (job, operands, divider load, dividends, I two-bit steps, hand over), I = [[Planes.iterations]]
  * (12 at `small`, 14 at `kitti`: E = 17, 19). With P engines the stage accepts a cell-closing node every
  * ceil(E / P) cycles; P is the lowest count that keeps that within step^2, the pixel clocks per lattice cell at 1
  * input pixel per clock (one cell row per `step` image rows): P = 1 at step 5, 4 at step 2. Nodes that close no
  * cell (lattice row 0, column 0) are accepted at once. A lattice row that arrives as a burst is therefore taken
  * at ceil(E / P) cycles per node: the upstream stage sees back-pressure, never a loss. An idle stage drops nodes
  * until a start of frame. Latency: the cell closed by a node leaves E + 1 cycles after that node is accepted.
  */
class Planes(p: ElasParams, enginesOverride: Int = 0) extends Module {
  private val step = p.candidateStep
  private val nEngines = if (enginesOverride > 0) enginesOverride else Planes.engines(p)
  private val colIdxW = log2Ceil(p.latticeColsMax + 1)
  private val linW = log2Ceil(math.max(p.maxWidth, p.maxHeight) + step + 1) // i*step before the clamp

  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(SInt(p.signedDispBits.W))))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val out = Decoupled(new Framed(new PlaneCell(p)))
  })

  // ---- input side: lattice position of the next node ----
  val inFrame = RegInit(false.B)
  val width = RegInit(0.U(p.colBits.W))
  val height = RegInit(0.U(p.rowBits.W))
  val col = RegInit(0.U(colIdxW.W))
  val xLin = RegInit(0.U(linW.W)) // col * step
  val yLin = RegInit(0.U(linW.W)) // row * step
  val prevX = Reg(UInt(p.colBits.W)) // X of the previous node in this row
  val prevY = Reg(UInt(p.rowBits.W)) // Y of the previous lattice row
  val prevTop = Reg(UInt(p.dispBits.W)) // TL of the next cell: node (row-1, col-1)
  val prevBot = Reg(UInt(p.dispBits.W)) // BL of the next cell: node (row, col-1)

  val engines = Seq.fill(nEngines)(Module(new PlaneEngine(p)))
  def pick[T <: Data](xs: Seq[T], ptr: UInt): T = if (xs.size == 1) xs.head else VecInit(xs)(ptr)
  val ptrW = math.max(log2Ceil(nEngines), 1)
  def next(ptr: UInt): UInt = if (nEngines == 1) 0.U else Mux(ptr === (nEngines - 1).U, 0.U, ptr + 1.U)
  val dispatchPtr = RegInit(0.U(ptrW.W))
  val collectPtr = RegInit(0.U(ptrW.W))

  // A node closes a cell unless it lies in lattice row 0 or column 0 (decided on registers: ready never waits on
  // valid or bits).
  val closesCell = yLin =/= 0.U && col =/= 0.U
  io.in.ready := !closesCell || pick(engines.map(_.io.idle), dispatchPtr)

  val sof = io.in.bits.sof
  val take = io.in.fire && (inFrame || sof)
  val colNow = Mux(sof, 0.U, col)
  val xNow = Mux(sof, 0.U, xLin)
  val yNow = Mux(sof, 0.U, yLin)
  val w = Mux(sof, io.frameWidth, width)
  val h = Mux(sof, io.frameHeight, height)
  val x = Mux(xNow < w, xNow, w - 1.U)(p.colBits - 1, 0) // X_col = min(col*step, W-1)
  val y = Mux(yNow < h, yNow, h - 1.U)(p.rowBits - 1, 0)
  val value = io.in.bits.data.asUInt(p.dispBits - 1, 0) // 0..dispMax

  // Node (row-1, col): read one cycle ahead at the address of the next node, never at the one being written.
  val row = SyncReadMem(p.latticeColsMax, UInt(p.dispBits.W))
  val readAddr = Mux(take, Mux(io.in.bits.eol, 0.U, colNow + 1.U), col)
  val above = row.read(readAddr(log2Ceil(p.latticeColsMax) - 1, 0))

  val dispatch = take && yNow =/= 0.U && colNow =/= 0.U
  for ((e, k) <- engines.zipWithIndex) {
    e.io.start := dispatch && dispatchPtr === k.U
    e.io.job.corners := VecInit(prevTop, above, prevBot, value)
    e.io.job.x0 := prevX
    e.io.job.y1 := y
    e.io.job.w := RoundDivider.low(x - prevX, e.io.job.w.getWidth) // 1..step
    e.io.job.h := RoundDivider.low(y - prevY, e.io.job.h.getWidth)
    e.io.job.sof := yNow === step.U && colNow === 1.U
    e.io.job.eol := io.in.bits.eol
    e.io.job.eof := io.in.bits.eof
  }
  when(dispatch) { dispatchPtr := next(dispatchPtr) }

  when(take) {
    row.write(colNow(log2Ceil(p.latticeColsMax) - 1, 0), value)
    inFrame := !io.in.bits.eof
    when(sof) { width := io.frameWidth; height := io.frameHeight }
    prevTop := above
    prevBot := value
    prevX := x
    col := colNow + 1.U
    xLin := xNow + step.U
    yLin := yNow
    when(io.in.bits.eol) {
      col := 0.U
      xLin := 0.U
      yLin := yNow + step.U
      prevY := y
    }
    when(io.in.bits.eof) { yLin := 0.U }
  }

  // ---- output: cells in dispatch order ----
  val output = new OutputRegister(io.out)
  val collect = pick(engines.map(_.io.done), collectPtr) && output.free
  for ((e, k) <- engines.zipWithIndex) e.io.take := collect && collectPtr === k.U
  when(collect) {
    output.valid := true.B
    output.bits := pick(engines.map(_.io.result), collectPtr)
    collectPtr := next(collectPtr)
  }
}

/** One lattice cell handed to a [[PlaneEngine]]: corners TL, TR, BL, BR, the cell's left column x0, bottom row y1,
  * width w and height h (1..step), and the output framing of the cell.
  */
class PlaneJob(p: ElasParams) extends Bundle {
  val corners = Vec(4, UInt(p.dispBits.W))
  val x0 = UInt(p.colBits.W)
  val y1 = UInt(p.rowBits.W)
  val w = UInt(log2Ceil(p.candidateStep + 1).W)
  val h = UInt(log2Ceil(p.candidateStep + 1).W)
  val sof = Bool()
  val eol = Bool()
  val eof = Bool()
}

/** The planes of one cell: both triangles in both views with 8 [[RoundDivider]]s in parallel.
  * start -> job registered -> operands -> dividers loaded -> dividends -> I steps -> done until taken: I + 5 cycles
  * from one start to the next.
  * Triangle 0 = (TL, TR, BL): dA = TR - TL, dB = BL - TL; triangle 1 = (TR, BR, BL): dA = BR - BL, dB = BR - TR;
  * n = w - dA. Left a = roundDiv(dA 2^16, w), b = roundDiv(dB 2^16, h); right a = roundDiv(dA 2^16, n),
  * b = roundDiv(dB w 2^16, h n) (0 when n = 0); c = D_BL 2^16; valid = 10|dA| < 7w && n != 0 && 10|dA| < 7|n|.
  */
class PlaneEngine(p: ElasParams) extends Module {
  private val step = p.candidateStep
  private val iters = Planes.iterations(p)
  private val one = BigInt(1) << 16

  val io = IO(new Bundle {
    val start = Input(Bool())
    val job = Input(new PlaneJob(p))
    val idle = Output(Bool())
    val done = Output(Bool())
    val take = Input(Bool())
    val result = Output(new Framed(new PlaneCell(p)))
  })

  val sIdle :: sPrep :: sLoad :: sStart :: sRun :: sDone :: Nil = Enum(6)
  val state = RegInit(sIdle)
  val job = Reg(new PlaneJob(p))
  val count = Reg(UInt(log2Ceil(iters + 1).W))
  io.idle := state === sIdle
  io.done := state === sDone

  // Divider shapes from the value bounds (|dA|, |dB| <= dispMax, w, h in 1..step, |n| <= step + dispMax).
  private val dMax = BigInt(p.dispMax)
  private val sMax = BigInt(step)
  private val leftDiv = () => Module(new RoundDivider(dMax * one, sMax, iters))
  private val rightA = () => Module(new RoundDivider(dMax * one, sMax + dMax, iters))
  private val rightB = () => Module(new RoundDivider(dMax * sMax * one, sMax * (sMax + dMax), iters))
  val la = Seq.fill(2)(leftDiv())
  val lb = Seq.fill(2)(leftDiv())
  val ra = Seq.fill(2)(rightA())
  val rb = Seq.fill(2)(rightB())

  val Seq(tl, tr, bl, br) = job.corners.map(_.zext)
  val dA = Seq(tr -& tl, br -& bl)
  val dB = Seq(bl -& tl, br -& tr)
  val wS = job.w.zext
  val hS = job.h.zext
  val n = dA.map(wS -& _)
  val nZero = n.map(_ === 0.S)
  // Products with w, h in 1..step and the constants 10 and 7 as shift-adds: too small for a DSP block.
  def times(a: SInt, b: UInt): SInt = b.asBools.zipWithIndex.map { case (bit, k) => Mux(bit, a << k, 0.S) }.reduce(_ +& _)
  def times10(a: UInt): UInt = (a << 3) +& (a << 1)
  def times7(a: UInt): UInt = (a << 3) -& a
  // the validity test in two cycles: |dA| and |n| registered in sPrep, the comparisons in sLoad (valid is first
  // needed at sDone; differences, magnitudes and comparisons in one cycle were 7 to 8 LUT levels)
  val absDA = Reg(Vec(2, chiselTypeOf(RoundDivider.absU(dA(0)))))
  val absN = Reg(Vec(2, chiselTypeOf(RoundDivider.absU(n(0)))))
  val nZeroReg = Reg(Vec(2, Bool()))
  val valid = (0 until 2).map { t =>
    val absA10 = times10(absDA(t))
    absA10 < times7(job.w) && !nZeroReg(t) && absA10 < times7(absN(t))
  }
  val validReg = Reg(Vec(2, Bool()))

  // Pipeline of one cell: sPrep registers the dividers' operands (differences, n, products), sLoad the dividers'
  // sign-normalised operands, sStart their dividends; short paths between registers (the whole chain in one cycle
  // was 10 LUT levels).
  val prep = state === sPrep
  for (t <- 0 until 2) {
    // the value bounds are the dividers' port widths; fitS drops the bits the width arithmetic adds
    def feed(d: RoundDivider, num: SInt, den: SInt): Unit = {
      val numReg = RegEnable(RoundDivider.fitS(num, d.io.n.getWidth), prep)
      val denReg = RegEnable(RoundDivider.fitS(den, d.io.d.getWidth), prep)
      d.io.n := numReg
      d.io.d := denReg
      d.io.load := state === sLoad
      d.io.start := state === sStart
      d.io.step := state === sRun
    }
    feed(la(t), dA(t) << 16, wS)
    feed(lb(t), dB(t) << 16, hS)
    feed(ra(t), dA(t) << 16, Mux(nZero(t), 1.S, n(t))) // n = 0: the result is replaced by 0
    feed(rb(t), times(dB(t), job.w) << 16, Mux(nZero(t), 1.S, times(n(t), job.h)))
  }

  switch(state) {
    is(sIdle) { when(io.start) { job := io.job; state := sPrep } }
    is(sPrep) {
      nZeroReg := VecInit(nZero)
      for (t <- 0 until 2) {
        absDA(t) := RoundDivider.absU(dA(t))
        absN(t) := RoundDivider.absU(n(t))
      }
      state := sLoad
    }
    is(sLoad) { validReg := VecInit(valid); state := sStart }
    is(sStart) { count := (iters - 1).U; state := sRun }
    is(sRun) {
      count := count - 1.U
      when(count === 0.U) { state := sDone }
    }
    is(sDone) { when(io.take) { state := sIdle } }
  }

  val c = (job.corners(2) << 16).zext.pad(32)
  for (t <- 0 until 2) {
    val l = io.result.data.left(t)
    l.a := la(t).io.q; l.b := lb(t).io.q; l.c := c
    l.anchorU := job.x0.zext; l.anchorV := job.y1; l.valid := validReg(t)
    val r = io.result.data.right(t)
    r.a := Mux(nZeroReg(t), 0.S, ra(t).io.q); r.b := Mux(nZeroReg(t), 0.S, rb(t).io.q); r.c := c
    r.anchorU := job.x0.zext - job.corners(2).zext; r.anchorV := job.y1; r.valid := validReg(t)
  }
  io.result.data.corners := job.corners
  io.result.sof := job.sof
  io.result.eol := job.eol
  io.result.eof := job.eof
}

/** Sequential radix-4 divider: q = roundDiv(n, d) = floor((2n + d) / (2d)) exactly (d != 0; d < 0 negates both),
  * two quotient bits per step: the unsigned restoring division of |2n + d| by 2|d| in `iters` steps after a load,
  * then the floor for a negative dividend from the remainder. Shaped by the magnitude bounds maxN >= |n| and
  * maxD >= |d|; q is valid after `iters` steps and holds until the next load. q is 32 bits: every plane
  * coefficient fits int32 (docs/ALGORITHM.md).
  */
class RoundDivider(maxN: BigInt, maxD: BigInt, iters: Int) extends Module {
  private val qW = 2 * iters
  require(2 * maxN + maxD < (BigInt(1) << (qW + 1)), s"RoundDivider: $iters steps are too few for |n| <= $maxN, |d| <= $maxD")
  require((2 * maxN + maxD) / 2 + 1 < (BigInt(1) << 31), s"RoundDivider: quotients of |n| <= $maxN exceed int32")
  private val numW = maxN.bitLength + 1
  private val denW = maxD.bitLength + 2 // holds 2|d|
  val io = IO(new Bundle {
    val load = Input(Bool()) //  n, d are taken
    val start = Input(Bool()) // the next cycle: the dividend is formed
    val step = Input(Bool()) //  then `iters` steps
    val n = Input(SInt(numW.W))
    val d = Input(SInt((maxD.bitLength + 1).W))
    val q = Output(SInt(32.W))
  })

  val nn = RegEnable(Mux(io.d < 0.S, 0.S -& io.n, io.n), io.load) // d < 0: negate both
  val dd = RegEnable(RoundDivider.absU(io.d), io.load)
  val m = (nn << 1) +& dd.zext
  val mag = RoundDivider.absU(m)

  val den = Reg(UInt(denW.W)) //        2|d|
  val den3 = Reg(UInt((denW + 2).W)) // 6|d|
  val rem = Reg(UInt(denW.W)) //        partial remainder, < den
  val quo = Reg(UInt(qW.W)) //          dividend bits still to shift in (high end), quotient digits (low end)
  val neg = Reg(Bool())
  when(io.start) {
    den := RoundDivider.low(dd << 1, denW)
    den3 := RoundDivider.low((dd << 2) +& (dd << 1), denW + 2)
    rem := RoundDivider.low(mag >> qW, denW)
    quo := RoundDivider.low(mag, qW)
    neg := m < 0.S
  }.elsewhen(io.step) {
    // the three trial differences side by side, each one carry chain whose borrow is the comparison: the step is
    // chains, then a select (comparing first and subtracting the chosen multiple after was two chains in series)
    val r4 = Cat(rem, quo(qW - 1, qW - 2))
    val Seq(diff1, diff2, diff3) = Seq(den.pad(denW + 2), den << 1, den3).map(r4 -& _)
    val Seq(ge1, ge2, ge3) = Seq(diff1, diff2, diff3).map(d => !d(denW + 2)) // no borrow: r4 >= multiple
    val digit = Mux(ge3, 3.U, Mux(ge2, 2.U, Mux(ge1, 1.U, 0.U)))
    val next = Mux(ge3, diff3, Mux(ge2, diff2, Mux(ge1, diff1, r4.pad(denW + 3))))
    rem := RoundDivider.low(next, denW)
    quo := Cat(quo(qW - 3, 0), digit)
  }
  // floor for a negative dividend: -(|M| div D) - (remainder != 0) = ~quo + (remainder == 0), one carry chain
  val negQ = (Cat(1.U(1.W), ~quo) + (rem === 0.U).asUInt).asSInt
  io.q := RoundDivider.fitS(Mux(neg, negQ, Cat(0.U(1.W), quo).asSInt), 32)
}

object RoundDivider {
  /** |x| as an unsigned value one bit wider than x (no overflow at the most negative value). */
  def absU(x: SInt): UInt = Mux(x < 0.S, (0.S -& x).asUInt, x.asUInt.pad(x.getWidth + 1))
  /** The low `w` bits of x, zero-extended when x is narrower. */
  def low(x: UInt, w: Int): UInt = if (x.getWidth >= w) x(w - 1, 0) else x.pad(w)
  /** x as a `w`-bit signed value: sign-extended when narrower, the low bits when wider (the value must fit). */
  def fitS(x: SInt, w: Int): SInt = if (x.getWidth > w) x(w - 1, 0).asSInt else x.pad(w)
}

object Planes {
  /** Radix-4 steps of the widest division (right b: |dB w 2^16| <= dispMax step 2^16 over |h n| >= 1). */
  def iterations(p: ElasParams): Int = {
    val bound = 2 * BigInt(p.dispMax) * p.candidateStep * (BigInt(1) << 16) + p.candidateStep * (p.candidateStep + p.dispMax)
    Iterator.from(1).find(i => bound < (BigInt(1) << (2 * i + 1))).get
  }
  /** Cycles a cell occupies an engine: the job, the operands, the dividers' load, the dividends, I steps, hand over. */
  def engineCycles(p: ElasParams): Int = iterations(p) + 5
  /** Engines: the lowest count that accepts a cell every step^2 cycles (the pixel clocks per lattice cell). */
  def engines(p: ElasParams): Int = {
    val budget = p.candidateStep * p.candidateStep
    (engineCycles(p) + budget - 1) / budget
  }
  /** Cycles between two accepted cell-closing nodes with no stalls. */
  def cyclesPerCell(p: ElasParams, engines: Int): Int = (engineCycles(p) + engines - 1) / engines
  def cyclesPerCell(p: ElasParams): Int = cyclesPerCell(p, engines(p))

  def memorySummary(p: ElasParams): Seq[MemoryUse] = Seq(
    MemoryUse("Planes", "row", p.latticeColsMax, p.dispBits,
      s"one lattice row of ${p.dispBits}-bit disparities, SyncReadMem 1R1W (${engines(p)} engine(s), ${cyclesPerCell(p)} cycles per cell)"))
}
