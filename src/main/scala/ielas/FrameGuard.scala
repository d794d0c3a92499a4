package ielas

import chisel3._
import chisel3.util._

/** The top's input framing check (docs/interfaces.md §4, malformed frames): turns the raw pixel input into a clean
  * stream in which every frame is exactly W x H (W x H = frameWidth x frameHeight sampled at its start of frame),
  * with sof on its first pixel and eol on the last pixel of each line, so no later stage ever sees a malformed
  * frame.
  *
  * Rules (each malformed case raises the sticky `error`; a frame that is put out but malformed is marked aborted):
  *  - frame size at SOF outside 32x16..maxWidth x maxHeight ([[FrameSize.isLegal]]): the whole frame is dropped up
  *    to the next SOF (no output frame, no `aborted` beat);
  *  - a line too short (eol before column W - 1): the line is padded to W with zero pixels (the input waits);
  *  - a line too long (no eol on column W - 1): column W - 1 goes out with eol, the extra pixels are dropped up to
  *    and including the input's eol;
  *  - SOF in mid-frame (too few lines, or a line cut short): the SOF beat is held, the rest of the current frame is
  *    padded with zero pixels (the input waits), then the held beat starts the new frame with the frame size sampled
  *    when it arrived;
  *  - lines beyond frameHeight: dropped up to the next SOF. The frame was already put out in full, so they raise
  *    `error` but cannot mark it aborted;
  *  - pixels before the first SOF after reset are dropped silently (a source may start mid-frame).
  * `error` is cleared by reset or a one-cycle `clearError` pulse; a new error in the same cycle wins.
  *
  * `aborted`: exactly one beat per frame put out, as early as it is known: `true` at the frame's first malformed
  * line (so the output side can end that frame's output after its current line), else `false` with the frame's
  * last pixel. The beats wait in a [[FrameGuard.abortedDepth]]-entry register queue; the guard stalls while it is full, so the
  * consumer must take them. `outWidth`/`outHeight` give the size of the frame being put out (the sampled ports), stable
  * for the whole frame.
  *
  * Good frames pass with no added bubbles: 1 pixel per clock, frames of any legal sizes back to back, through one
  * output register (N pixels leave in N + [[FrameGuard.cycleSlack]] cycles with no stalls). No memory: registers only
  * (the held SOF beat, the sampled size, the position, the output register).
  */
class FrameGuard(p: ElasParams) extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PixelPair))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val clearError = Input(Bool())
    val error = Output(Bool())
    val out = Decoupled(new PixelPair)
    val aborted = Decoupled(Bool())
    /** The size of the frame being put out (sampled at its SOF). */
    val outWidth = Output(UInt(p.colBits.W))
    val outHeight = Output(UInt(p.rowBits.W))
    /** One-cycle pulses, one bit per cause of `error` ([[FrameGuard.Cause]]), for a register file's sticky bits. */
    val errorCauses = Output(UInt(FrameGuard.Cause.count.W))
  })

  // ---- state ----
  val active = RegInit(false.B)     // inside a frame being put out: (x, y) is its next output pixel
  val afterFrame = RegInit(false.B) // a frame ended and no SOF came yet: stray pixels are lines beyond frameHeight
  val x = RegInit(0.U(p.colBits.W))
  val y = RegInit(0.U(p.rowBits.W))
  val width = RegInit(FrameSize.minWidth.U(p.colBits.W))
  val height = RegInit(FrameSize.minHeight.U(p.rowBits.W))
  // width - 2 and height - 2, set with them; x === width - 1 and y === height - 1 are registers formed a cycle ahead
  // from them (x + 1 and y + 1 next are compared now), so the line and frame end tests behind the source select are
  // flip-flops, not carry chains (the whole top's path from the held SOF beat to the aborted queue ran through both)
  val lastXm1 = RegInit((FrameSize.minWidth - 2).U(p.colBits.W))
  val lastYm1 = RegInit((FrameSize.minHeight - 2).U(p.rowBits.W))
  val xIsLast = RegInit(false.B)
  val yIsLast = RegInit(false.B)
  val padLine = RegInit(false.B)  // zero pixels to the end of the line
  val padFrame = RegInit(false.B) // zero pixels to the end of the frame (a SOF beat is held)
  val dropLine = RegInit(false.B) // dropping a long line's extra pixels up to its eol
  val flagged = RegInit(false.B)  // this frame's aborted beat has gone out
  val error = RegInit(false.B)

  // the SOF beat that arrived in mid-frame, and the frame size sampled with it
  val heldValid = RegInit(false.B)
  val held = Reg(new PixelPair)
  val heldWidth = Reg(UInt(p.colBits.W))
  val heldHeight = Reg(UInt(p.rowBits.W))
  val heldLegal = Reg(Bool()) // its size is legal: the start branch then selects a flip-flop, not a compare of a mux

  val output = new OutputRegister(io.out)
  // The aborted beats wait in two registers (a Queue would be a LUT-RAM): head goes out, tail waits behind it.
  val headValid = RegInit(false.B)
  val headBit = Reg(Bool())
  val tailValid = RegInit(false.B)
  val tailBit = Reg(Bool())
  val abortedEnqReady = !tailValid
  val abortedEnq = WireDefault(false.B)
  val abortedEnqBit = WireDefault(false.B)
  io.aborted.valid := headValid
  io.aborted.bits := headBit

  // ---- one step per cycle: emit a padding pixel, or take one beat (input or held SOF) ----
  val canStep = output.free && abortedEnqReady
  val padding = active && (padLine || padFrame)
  io.in.ready := canStep && !padding && !heldValid
  val srcValid = heldValid || io.in.valid
  val src = Mux(heldValid, held, io.in.bits)
  val srcWidth = Mux(heldValid, heldWidth, io.frameWidth)
  val srcHeight = Mux(heldValid, heldHeight, io.frameHeight)
  val srcLegal = Mux(heldValid, heldLegal, FrameSize.isLegal(p, io.frameWidth, io.frameHeight))

  val setError = WireDefault(false.B)
  val malformed = WireDefault(false.B) // this step finds the current frame malformed
  val frameEnd = WireDefault(false.B)  // this step puts out the frame's last pixel
  val starting = WireDefault(false.B)  // this step starts a frame (its aborted beat is still to come)
  val cause = WireDefault(VecInit(Seq.fill(FrameGuard.Cause.count)(false.B)))

  /** Puts out a pixel: the first of a frame, or pixel (x, y) of the current one; returns whether it is the line's last
    * (never for the first pixel: W >= 32, so no size multiplexer reaches the end tests).
    */
  def emit(left: UInt, right: UInt, first: Boolean): Bool = {
    val lastCol = if (first) false.B else xIsLast
    output.valid := true.B
    output.bits.left := left
    output.bits.right := right
    output.bits.sof := (if (first) true.B else x === 0.U && y === 0.U)
    output.bits.eol := lastCol
    x := (if (first) 1.U else Mux(lastCol, 0.U, x + 1.U))
    y := (if (first) 0.U else Mux(lastCol, y + 1.U, y))
    // next x is 1 after a frame's first pixel, 0 after a line's last (never the last: W >= 32, H >= 16)
    xIsLast := (if (first) false.B else x === lastXm1)
    if (first) yIsLast := false.B else when(lastCol) { yIsLast := y === lastYm1 }
    when(lastCol && yIsLast) {
      frameEnd := true.B
      active := false.B
      afterFrame := true.B
      padLine := false.B
      padFrame := false.B
    }
    lastCol
  }

  when(canStep) {
    when(padding) {
      val lastCol = emit(0.U, 0.U, first = false)
      when(lastCol) { padLine := false.B }
    }.elsewhen(srcValid) {
      heldValid := false.B
      when(src.sof && active) { // mid-frame SOF: hold it, pad out the current frame first
        heldValid := true.B
        held := src
        heldWidth := srcWidth
        heldHeight := srcHeight
        heldLegal := srcLegal
        padFrame := true.B
        dropLine := false.B
        malformed := true.B
        cause(FrameGuard.Cause.earlySof) := true.B
      }.elsewhen(src.sof) { // start of frame
        dropLine := false.B
        when(srcLegal) {
          active := true.B
          afterFrame := false.B
          starting := true.B
          width := srcWidth
          height := srcHeight
          lastXm1 := srcWidth - 2.U
          lastYm1 := srcHeight - 2.U
          emit(src.left, src.right, first = true)
          when(src.eol) { padLine := true.B; malformed := true.B; cause(FrameGuard.Cause.shortLine) := true.B }
        }.otherwise {
          active := false.B
          afterFrame := false.B // the rest of this frame is dropped silently
          setError := true.B
          cause(FrameGuard.Cause.size) := true.B
        }
      }.elsewhen(dropLine) {
        when(src.eol) { dropLine := false.B }
      }.elsewhen(active) {
        val lastCol = emit(src.left, src.right, first = false)
        when(src.eol && !lastCol) { padLine := true.B; malformed := true.B; cause(FrameGuard.Cause.shortLine) := true.B }
        when(!src.eol && lastCol) { dropLine := true.B; malformed := true.B; cause(FrameGuard.Cause.longLine) := true.B }
      }.otherwise { // outside any frame
        when(afterFrame) { setError := true.B; cause(FrameGuard.Cause.extraLines) := true.B }
      }
    }
  }

  // The frame's one aborted beat: at its first malformed line, else with its last pixel.
  val flaggedNow = flagged && !starting
  abortedEnq := canStep && (malformed || frameEnd) && !flaggedNow
  abortedEnqBit := malformed
  // The bits load whenever their slot is free or moves, from the tail or the new beat (a slot left empty holds a
  // value never read): their enables then leave out the step's decision, the whole top's worst path at tiny-w3-c8
  when(!headValid || io.aborted.fire) { headBit := Mux(headValid && tailValid, tailBit, abortedEnqBit) }
  when(!tailValid || io.aborted.fire) { tailBit := abortedEnqBit }
  when(io.aborted.fire) {
    headValid := tailValid
    tailValid := false.B
  }
  when(abortedEnq) {
    when(!headValid || (io.aborted.fire && !tailValid)) { headValid := true.B }.otherwise { tailValid := true.B }
  }
  flagged := flaggedNow || (canStep && (malformed || frameEnd))
  when(malformed) { setError := true.B }

  when(io.clearError) { error := false.B }
  when(setError) { error := true.B }

  assert(!active || (xIsLast === (x === width - 1.U) && yIsLast === (y === height - 1.U)), "FrameGuard: the end registers")
  io.error := error
  io.outWidth := width
  io.outHeight := height
  io.errorCauses := cause.asUInt
}

object FrameGuard {
  /** The bits of `errorCauses`: size at SOF illegal (frame dropped), a line too short, a line too long, SOF in
    * mid-frame, pixels after the frame's last line.
    */
  object Cause {
    val size = 0
    val shortLine = 1
    val longLine = 2
    val earlySof = 3
    val extraLines = 4
    val count = 5
  }

  /** Aborted beats the guard can be ahead of their consumer. */
  val abortedDepth: Int = 2

  /** Cycles beyond N for N good pixels with no stalls: the output register. */
  val cycleSlack: Int = 2

  /** Registers only. */
  def memorySummary(p: ElasParams): Seq[MemoryUse] = Seq.empty
}
