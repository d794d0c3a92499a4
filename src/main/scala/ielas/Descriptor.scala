package ielas

import chisel3._
import chisel3.util._

/** One on-chip memory of a module, for the memory summary of `make verilog`. */
case class MemoryUse(module: String, name: String, rows: Int, bitsPerRow: Int, note: String) {
  def bits: Long = rows.toLong * bitsPerRow
  override def toString: String = f"$module%-12s $name%-12s $rows%6d rows x $bitsPerRow%4d bits = $bits%9d bits  ($note)"
}

/** Sobel gradients and the 16-byte descriptor (docs/ALGORITHM.md, descriptor steps 1-2) of both views, streaming.
  *
  * Every accepted pixel is one "step" of a raster-order pipeline. A step at input index k emits the descriptor of
  * output index k - latencySteps, latencySteps = m*W + m + 1 (m = descriptorMargin): by then every pixel that
  * descriptor reads (m rows below, m + 1 columns to the right counting the gradient register) has arrived.
  * After the last input pixel the stage runs latencySteps virtual steps by itself; the descriptors they emit all
  * lie in the zero border, so the garbage those steps shift in is never visible.
  *
  * Data path per step: line buffer (2m pixel rows, one read and one write per column, read-modify-write as a
  * shift) -> 3-column pixel window -> gradients of its centre column -> gradient window (2r+1 columns) -> bytes.
  * Nothing needs clearing between frames: a window position reaching into the previous frame or the previous line
  * is always a border pixel, whose output is forced to zero.
  */
class Descriptor(p: ElasParams) extends Module {
  private val r = p.windowRadius
  private val m = p.descriptorMargin
  private val bufferedRows = Descriptor.bufferedRows(p)
  private val stepBits = log2Ceil(Descriptor.latencySteps(p, p.maxWidth) + 1)

  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PixelPair))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val out = Decoupled(new Framed(new DescriptorPair(p.descriptorBytes)))
  })

  // ---- frame state (sampled at start of frame) ----
  val width = RegInit(0.U(p.colBits.W))
  val height = RegInit(0.U(p.rowBits.W))
  val latency = RegInit(0.U(stepBits.W)) //    latencySteps of the current frame
  val busy = RegInit(false.B) //              real input pixels of a frame are still expected
  val inCol = RegInit(0.U(p.colBits.W)) //    column of the next step (real or virtual)
  val inRow = RegInit(0.U(p.rowBits.W)) //    row of the next real pixel
  val warmup = RegInit(0.U(stepBits.W)) //    steps left before the first emission of the frame
  val flushLeft = RegInit(0.U(stepBits.W)) // virtual steps left after the last input pixel
  val flushing = RegInit(false.B) //          flushLeft =/= 0, kept as a flag: it gates the input handshake

  // ---- pipeline registers ----
  val s1Valid = RegInit(false.B)
  val s1Col = Reg(UInt(p.colBits.W))
  val s1Left = Reg(UInt(8.W))
  val s1Right = Reg(UInt(8.W))
  val s1Emit = Reg(Bool())
  val outValid = RegInit(false.B)
  // The windows are the output register, and s1Advance enables about a thousand of their flip-flops. Were it to
  // wait for io.out.ready, the consumer's ready would reach all of them in one clock (the whole top's critical path
  // at 82 MHz). So s1 advances on local registers only: an output not taken when the windows move on is saved in a
  // skid register, presented first, and s1 waits while it is full.
  val skidValid = RegInit(false.B)
  val skidBits = Reg(chiselTypeOf(io.out.bits))

  val s1Advance = s1Valid && !skidValid
  val s1Free = !s1Valid || s1Advance

  io.in.ready := s1Free && !flushing
  val startOfFrame = io.in.fire && !busy && io.in.bits.sof
  val realStep = io.in.fire && (busy || io.in.bits.sof) // an idle stage drops pixels until a start of frame
  val virtualStep = s1Free && flushing
  val step = realStep || virtualStep

  val stepCol = Mux(startOfFrame, 0.U, inCol)
  val stepRow = Mux(startOfFrame, 0.U, inRow)
  val stepLatency = Mux(startOfFrame, Descriptor.latencyOf(p, io.frameWidth, stepBits), latency)
  val stepWarmup = Mux(startOfFrame, stepLatency, warmup)
  // compared on the registers (and on the frame width for the start beat), so the handshake only selects
  val endOfLine = Mux(startOfFrame, io.frameWidth === 1.U, inCol === width - 1.U)
  val lastRow = Mux(startOfFrame, io.frameHeight === 1.U, inRow === height - 1.U)
  val lastPixel = realStep && endOfLine && lastRow

  when(startOfFrame) {
    width := io.frameWidth
    height := io.frameHeight
    latency := stepLatency
    busy := true.B
  }
  when(step) {
    inCol := Mux(endOfLine, 0.U, stepCol + 1.U)
    warmup := Mux(stepWarmup === 0.U, 0.U, stepWarmup - 1.U)
  }
  when(realStep) { inRow := Mux(endOfLine, stepRow + 1.U, stepRow) }
  when(virtualStep) {
    flushLeft := flushLeft - 1.U
    flushing := flushLeft =/= 1.U
  }
  when(lastPixel) {
    busy := false.B
    flushLeft := stepLatency
    flushing := true.B // latencySteps >= m + 1 > 0
  }

  // ---- line buffer: word at column x = pixel rows y-1 (slot 0) .. y-2m (slot 2m-1) of both views ----
  // A read-first `Mem` read into a register that holds the word while s1 stalls (Yosys' block-RAM read register
  // with its enable): nothing but that register sits between the block RAM and the Sobel sums. A step never reads
  // the column s1 writes in its cycle (it reads the next one), so no transparency is needed. The word is stored as
  // bit slices one block deep (`SlicedMem`): at kitti 1242 x 96 bits would otherwise be blocks stacked in depth, and
  // their multiplexer would sit between the read register and the Sobel sums.
  val lines = new SlicedMem(p.maxWidth, bufferedRows * 16, "lines")
  val pastRows = RegEnable(lines.read(stepCol), step).asTypeOf(Vec(bufferedRows, UInt(16.W)))
  // a step reads column x + 1 while s1 writes column x (frames are at least 32 wide)
  CollisionFree.check("Descriptor: lines", lines.mems, Seq(CollisionFree.Read(stepCol, RegNext(step, false.B))),
    Seq(CollisionFree.Write(s1Advance, s1Col)))

  when(s1Advance) { s1Valid := false.B }
  when(step) {
    s1Valid := true.B
    s1Col := stepCol
    s1Left := io.in.bits.left
    s1Right := io.in.bits.right
    s1Emit := stepWarmup === 0.U
  }
  val newPixel = Cat(s1Left, s1Right)
  when(s1Advance) {
    lines.write(s1Col, VecInit(newPixel +: pastRows.take(bufferedRows - 1)).asUInt)
  }

  /** Pixel column of one view, oldest row first: index 0 = row y-2m, index 2m = row y. */
  def column(view: Int): Seq[UInt] = {
    def pick(w: UInt) = if (view == 0) w(15, 8) else w(7, 0)
    (pastRows.reverse :+ newPixel).map(pick)
  }

  val duRows = Seq(m - r, m - 1, m, m + 1, m + r).distinct // pixel-window rows whose du the layout reads
  val dvRows = Seq(m - 1, m, m + 1)

  /** Gradient window of one view: du/dv per needed row, columns 0 (x - r) .. 2r (x + r).
    * The vertical halves of the Sobel (column sum S, column difference T) are computed once per pixel column as
    * it arrives and shifted along with it; the gradient then only combines three registered column values, which
    * keeps the line buffer -> gradient register path short (and shares each column's S / T between positions).
    */
  def gradientWindow(view: Int): (Map[Int, Seq[UInt]], Map[Int, Seq[UInt]]) = {
    val col = column(view)
    def around(q: Int) = Seq(col(q - 1), col(q), col(q + 1))
    // columns x-1, x, x+1 of the gradient's centre, per pixel-window row
    val smoothIn = duRows.map(q => q -> Sobel.smooth(around(q))).toMap
    val diffIn = dvRows.map(q => q -> Sobel.diff(around(q))).toMap
    val smooths = smoothIn.map { case (q, s) => q -> Seq.fill(3)(Reg(chiselTypeOf(s))) }
    val diffs = diffIn.map { case (q, t) => q -> Seq.fill(3)(Reg(chiselTypeOf(t))) }
    val du = duRows.map(q => q -> Seq.fill(2 * r + 1)(Reg(UInt(8.W)))).toMap
    val dv = dvRows.map(q => q -> Seq.fill(2 * r + 1)(Reg(UInt(8.W)))).toMap
    def shiftIn[T <: Data](regs: Seq[T], in: T): Unit = {
      regs.zip(regs.tail).foreach { case (older, newer) => older := newer }
      regs.last := in
    }
    when(s1Advance) {
      for ((q, s) <- smooths) shiftIn(s, smoothIn(q))
      for ((q, t) <- diffs) shiftIn(t, diffIn(q))
      for ((q, regs) <- du) shiftIn(regs, Sobel.duOf(smooths(q)(0), smooths(q)(2)))
      for ((q, regs) <- dv) shiftIn(regs, Sobel.dvOf(diffs(q)))
    }
    (du, dv)
  }

  def descriptorBytes(view: Int): UInt = {
    val (du, dv) = gradientWindow(view)
    val bytes = Descriptor.layout(r).map { case (isDu, dx, dy) =>
      (if (isDu) du else dv)(m + dy)(r + dx)
    }
    Cat(bytes.reverse) // byte 0 in the least significant bits
  }
  val leftBytes = descriptorBytes(0)
  val rightBytes = descriptorBytes(1)

  // ---- output: position counters, border policy, framing ----
  val outCol = RegInit(0.U(p.colBits.W))
  val outRow = RegInit(0.U(p.rowBits.W))
  val outInterior = Reg(Bool())
  val outSof = Reg(Bool())
  val outEol = Reg(Bool())
  val outEof = Reg(Bool())

  val liveOut = Wire(chiselTypeOf(io.out.bits))
  when(skidValid && io.out.ready) { skidValid := false.B }
  when(!skidValid && io.out.ready) { outValid := false.B } // the live output, if any, is taken
  when(s1Advance) {
    skidBits := liveOut
    skidValid := outValid && !io.out.ready // s1Advance implies an empty skid: the live output is presented
    outValid := false.B
  }
  when(startOfFrame) {
    outCol := 0.U
    outRow := 0.U
  }
  when(s1Advance && s1Emit) {
    val eol = outCol === width - 1.U
    val eof = eol && outRow === height - 1.U
    outValid := true.B
    outInterior := outCol >= m.U && outCol +& m.U < width && outRow >= m.U && outRow +& m.U < height
    outSof := outCol === 0.U && outRow === 0.U
    outEol := eol
    outEof := eof
    outCol := Mux(eol, 0.U, outCol + 1.U)
    outRow := Mux(eof, 0.U, Mux(eol, outRow + 1.U, outRow))
  }

  liveOut.data.left := Mux(outInterior, leftBytes, 0.U)
  liveOut.data.right := Mux(outInterior, rightBytes, 0.U)
  liveOut.sof := outSof
  liveOut.eol := outEol
  liveOut.eof := outEof
  io.out.valid := skidValid || outValid
  io.out.bits := Mux(skidValid, skidBits, liveOut)
}

object Descriptor {
  /** Pixel rows held in the line buffer: the window needs 2m + 1 rows, the newest comes from the input. */
  def bufferedRows(p: ElasParams): Int = 2 * p.descriptorMargin

  /** Steps between an input pixel and the descriptor it completes, for frame width w. */
  def latencySteps(p: ElasParams, w: Int): Int = p.descriptorMargin * w + p.descriptorMargin + 1

  /** Rows of latency: the throughput bound is N + latencyRows * W + cycleSlack cycles for N input pixels. */
  def latencyRows(p: ElasParams): Int = p.descriptorMargin

  /** Cycles beyond latencyRows * W: m + 1 latency columns, the s1 and output registers, one cycle of margin. */
  def cycleSlack(p: ElasParams): Int = p.descriptorMargin + 4

  /** m*w + m + 1 as shifted adds (m is a small constant): Yosys would otherwise spend a DSP on it. */
  private[ielas] def latencyOf(p: ElasParams, w: UInt, bits: Int): UInt = {
    val m = p.descriptorMargin
    val times = (0 until log2Ceil(m + 1)).filter(i => ((m >> i) & 1) == 1).map(i => (w << i).pad(bits))
    (times.reduce(_ +& _) +& (m + 1).U)(bits - 1, 0)
  }

  /** The ELAS byte layout with offsets of magnitude 2 replaced by r: (is du, dx, dy) per byte (docs/ALGORITHM.md). */
  def layout(r: Int): Seq[(Boolean, Int, Int)] = Seq(
    (true, 0, -r), (true, -r, -1), (true, 0, -1), (true, r, -1),
    (true, -1, 0), (true, 0, 0), (true, 0, 0), (true, 1, 0),
    (true, -r, 1), (true, 0, 1), (true, r, 1), (true, 0, r),
    (false, 0, -1), (false, -1, 0), (false, 1, 0), (false, 0, 1)
  )

  def memorySummary(p: ElasParams): Seq[MemoryUse] = Seq(
    MemoryUse("Descriptor", "lines", p.maxWidth, bufferedRows(p) * 16,
      s"${bufferedRows(p)} pixel rows x {left, right} 8 bit, 1R1W, in bit slices one block deep")
  )
}
