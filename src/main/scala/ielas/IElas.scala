package ielas

import chisel3._
import chisel3.util._

/** The accelerator (docs/interfaces.md §4): left/right pixels in, disparity*16 out, both AXI4-Stream video style.
  *
  * {{{
  *  in -> FrameGuard -> fork -+-> Descriptor -> SupportMatcher -> SupportFilter -> fork -+-> LatticeFill -> lattice queue -> Planes --+
  *                            |                                                          +-> GridVector -> grid queue ---------------+
  *                            +-> pixel band (bandRows x maxWidth) -> Descriptor ----------------------------------------> DenseMatcher
  *                                                                                   DenseMatcher -> LrCheck -> PostProcess -> OutputGate -> out
  * }}}
  * The early path (support .. grid) runs a band of rows ahead of the late path (dense .. post). Only raw pixel pairs
  * are delayed (16 bits per pixel); the late path recomputes the descriptors. The band must cover the early path's
  * look-ahead, or the input would wait for the late path while the late path waits for the early one; the queues
  * behind the early path hold what it produces ahead of the late path ([[IElas.bandRows]] etc.).
  *
  * Frame sizes: [[FrameGuard]] makes every frame exactly frameWidth x frameHeight (padding or dropping as needed) and
  * records each frame's size in a [[FrameSizeTable]]; every stage reads the size of the next frame it will start, so
  * frames of different sizes may follow one another back to back while earlier frames are still in flight.
  * Malformed frames raise the sticky `error` (cleared by reset or `clearError`); [[OutputGate]] ends an aborted
  * frame's output after the current output line, without end of frame.
  */
class IElas(p: ElasParams) extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PixelPair))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val error = Output(Bool())
    val clearError = Input(Bool())
    val out = Decoupled(new Framed(SInt(16.W)))
    /** Pulses for a register file (IElasAxi): the cause of each error ([[FrameGuard.Cause]] bits), and a frame found
      * malformed (its output will be cut).
      */
    val errorCauses = Output(UInt(FrameGuard.Cause.count.W))
    val frameAborted = Output(Bool())
  })
  val pipeline = new Pipeline(p, Stage.Post, io.in, io.frameWidth, io.frameHeight, io.clearError)
  io.error := pipeline.error
  io.errorCauses := pipeline.guard.io.errorCauses
  io.frameAborted := pipeline.aborted.fire && pipeline.aborted.bits

  val gate = Module(new OutputGate)
  gate.io.in <> RegisterSlice(pipeline.post)
  gate.io.aborted <> RegisterSlice(Queue(pipeline.aborted, IElas.framesInFlight(p)))
  io.out <> gate.io.out
}

/** The stages in pipeline order (docs/interfaces.md §3 names); a [[Pipeline]] is built up to one of them. */
sealed abstract class Stage(val name: String, val index: Int)
object Stage {
  case object Descriptor extends Stage("descriptor", 0)
  case object Support extends Stage("support", 1)
  case object Filter extends Stage("filter", 2)
  case object Interp extends Stage("interp", 3)
  case object Grid extends Stage("grid", 4)
  case object Planes extends Stage("planes", 5)
  case object Dense extends Stage("dense", 6)
  case object LrCheck extends Stage("lrcheck", 7)
  case object Post extends Stage("post", 8)
  val all: Seq[Stage] = Seq(Descriptor, Support, Filter, Interp, Grid, Planes, Dense, LrCheck, Post)
  def byName(name: String): Stage = all.find(_.name == name).getOrElse(
    throw new IllegalArgumentException(s"stage '$name' is unknown (legal: ${all.map(_.name).mkString(", ")}, top)"))
}

/** Builds the accelerator's stages, inside the calling module, from the pixel input up to `last` and whatever it
  * depends on: `grid` needs no `interp`, `planes` no `grid`, `dense` and later need everything. The [[IElas]] top
  * builds all of it; `make simulate` and the stage chains build a prefix and read that stage's stream. Streams of
  * stages not built stay `null`.
  */
class Pipeline(p: ElasParams, last: Stage, in: DecoupledIO[PixelPair], frameWidth: UInt, frameHeight: UInt,
    clearError: Bool) {
  private def needs(s: Stage): Boolean = last == s || (s match {
    case Stage.Interp => last.index >= Stage.Planes.index
    case Stage.Grid => last.index >= Stage.Dense.index
    case _ => last.index > s.index
  })
  private val latticeType = new Framed(SInt(p.signedDispBits.W))

  val guard = Module(new FrameGuard(p))
  if (p.cyclesPerPixel == 1) guard.io.in <> in
  else { // at most one pixel every cyclesPerPixel clocks: the lane counts are sized for that rate
    val wait = RegInit(0.U(log2Ceil(p.cyclesPerPixel).W))
    guard.io.in.valid := in.valid && wait === 0.U
    guard.io.in.bits := in.bits
    in.ready := guard.io.in.ready && wait === 0.U
    when(in.fire) { wait := (p.cyclesPerPixel - 1).U }.elsewhen(wait =/= 0.U) { wait := wait - 1.U }
  }
  guard.io.frameWidth := frameWidth
  guard.io.frameHeight := frameHeight
  guard.io.clearError := clearError
  val error: Bool = guard.io.error
  val aborted: DecoupledIO[Bool] = guard.io.aborted

  // Frame sizes: recorded at the guard's start of frame, read by each stage at its own (see FrameSizeTable).
  private val consumers = scala.collection.mutable.ArrayBuffer.empty[(Bool, Bool, UInt, UInt)]
  private def sized(sof: Bool, fire: Bool, width: UInt, height: UInt): Unit = consumers += ((sof, fire, width, height))
  private val tableFull = Wire(Bool())

  private val guardOut = Wire(Decoupled(new PixelPair))
  private val holdSof = guard.io.out.bits.sof && tableFull
  guardOut.valid := guard.io.out.valid && !holdSof
  guardOut.bits := guard.io.out.bits
  guard.io.out.ready := guardOut.ready && !holdSof

  private val latePath = last.index >= Stage.Dense.index
  private val pixelFork = Module(new StreamFork(new PixelPair, if (latePath) 2 else 1))
  pixelFork.io.in <> RegisterSlice(guardOut) // every stage starts a frame after its size is recorded

  // ---- early path ----
  val earlyDesc = Module(new Descriptor(p))
  earlyDesc.io.in <> pixelFork.io.out(0)
  sized(earlyDesc.io.in.bits.sof, earlyDesc.io.in.fire, earlyDesc.io.frameWidth, earlyDesc.io.frameHeight)
  val descriptor: DecoupledIO[Framed[DescriptorPair]] = earlyDesc.io.out

  val support: DecoupledIO[Framed[SInt]] = if (!needs(Stage.Support)) null else {
    val m = Module(new SupportMatcher(p))
    m.io.in <> RegisterSlice(earlyDesc.io.out)
    sized(m.io.in.bits.sof, m.io.in.fire, m.io.frameWidth, m.io.frameHeight)
    m.io.out
  }
  val filter: DecoupledIO[Framed[SInt]] = if (!needs(Stage.Filter)) null else {
    val m = Module(new SupportFilter(p))
    // a slice: the filter's ready (from its row count and the beat's start of frame) and the matcher's output move
    // were one path across both stages (the whole top's worst at tiny-w3-c8, 79.8 MHz)
    m.io.in <> RegisterSlice(support)
    m.io.out
  }
  private val filterFork: Seq[DecoupledIO[Framed[SInt]]] = if (!needs(Stage.Interp) && !needs(Stage.Grid)) null else {
    val m = Module(new StreamFork(latticeType, Seq(needs(Stage.Interp), needs(Stage.Grid)).count(identity)))
    m.io.in <> filter
    m.io.out.toSeq
  }
  val interp: DecoupledIO[Framed[SInt]] = if (!needs(Stage.Interp)) null else {
    val m = Module(LatticeFill(p))
    m.io.in <> filterFork.head
    sized(m.io.in.bits.sof, m.io.in.fire, m.io.frameWidth, m.io.frameHeight)
    m.io.out
  }
  val grid: DecoupledIO[Framed[GridCellPair]] = if (!needs(Stage.Grid)) null else {
    val m = Module(new GridVector(p))
    m.io.in <> RegisterSlice(filterFork.last)
    sized(m.io.in.bits.sof, m.io.in.fire, m.io.frameWidth, m.io.frameHeight)
    m.io.out
  }
  val planes: DecoupledIO[Framed[PlaneCell]] = if (!needs(Stage.Planes)) null else {
    val m = Module(new Planes(p))
    m.io.in <> RegisterSlice(if (latePath) BlockQueue(RegisterSlice(interp), IElas.latticeQueueEntries(p))
      else interp)
    sized(m.io.in.bits.sof, m.io.in.fire, m.io.frameWidth, m.io.frameHeight)
    m.io.out
  }

  // ---- late path ----
  val dense: DecoupledIO[Framed[DisparityPair]] = if (!latePath) null else {
    val lateDesc = Module(new Descriptor(p))
    lateDesc.io.in <> RegisterSlice(BlockQueue(pixelFork.io.out(1), IElas.bandEntries(p)))
    sized(lateDesc.io.in.bits.sof, lateDesc.io.in.fire, lateDesc.io.frameWidth, lateDesc.io.frameHeight)
    val m = Module(new DenseMatcher(p))
    m.io.desc <> RegisterSlice(lateDesc.io.out)
    m.io.planes <> planes
    m.io.grid <> RegisterSlice(BlockQueue(RegisterSlice(grid), IElas.gridQueueEntries(p)))
    sized(m.io.desc.bits.sof, m.io.desc.fire, m.io.frameWidth, m.io.frameHeight)
    m.io.out
  }
  val lrcheck: DecoupledIO[Framed[DisparityPair]] = if (!needs(Stage.LrCheck)) null else {
    val m = Module(new LrCheck(p))
    m.io.in <> RegisterSlice(dense) // (the dense output queue's count reached LrCheck's memory addresses: 7 LUT levels)
    m.io.out
  }
  val post: DecoupledIO[Framed[SInt]] = if (!needs(Stage.Post)) null else {
    val m = Module(new PostProcess(p))
    val in = RegisterSlice(lrcheck) // (the speckle stage's take reached LrCheck's move register: 7 LUT levels)
    m.io.in.valid := in.valid
    m.io.in.bits.data := in.bits.data.left // only the left view is post-processed and put out
    m.io.in.bits.sof := in.bits.sof
    m.io.in.bits.eol := in.bits.eol
    m.io.in.bits.eof := in.bits.eof
    in.ready := m.io.in.ready
    sized(m.io.in.bits.sof, m.io.in.fire, m.io.frameWidth, m.io.frameHeight)
    m.io.out
  }

  // The last consumer is the slowest: the table is full when it has not started `depth` recorded frames.
  private val sizes = Module(new FrameSizeTable(p, consumers.length, IElas.framesInFlight(p)))
  tableFull := sizes.io.full
  sizes.io.record.valid := guardOut.fire && guardOut.bits.sof
  sizes.io.record.bits.columns := guard.io.outWidth
  sizes.io.record.bits.rows := guard.io.outHeight
  for (((sof, fire, width, height), k) <- consumers.zipWithIndex) {
    width := sizes.io.size(k).columns
    height := sizes.io.size(k).rows
    sizes.io.started(k) := fire && sof
  }
}

object IElas {
  /** The top's no-stall bound N + latencyRows * W + cycleSlack (docs/interfaces.md §4); the sweep's cycle model reads
    * these (`Main config`). Latency: the band, the late descriptor, the L/R check's row and post's look-ahead, plus
    * a margin of 4 rows: the stages' pipeline registers and the early path's tail at a frame's end (the support
    * filter's node takes one cycle more since its pipelining: about one row at mb-tsukuba, 151 523 cycles against
    * 151 144 with the former margin of 2 rows). The slack: 1000 cycles of pipeline fill and drain, plus a clock per
    * row of margin (the clocks per row the speckle labeller takes beyond W are in its latencyRows).
    */
  def latencyRows(p: ElasParams): Int = bandRows(p) + Descriptor.latencyRows(p) + 1 + PostProcess.latencyRows(p) + 4
  def cycleSlack(p: ElasParams): Int = 1000 + p.maxHeight
  /** Image rows the early path needs beyond the row the late path works on: the grid row's dilation and filter
    * window (docs/ALGORITHM.md look-ahead table), the planes' next lattice row plus the fill's look-ahead, whichever
    * is larger (bandRows adds the time the early path takes to produce them).
    */
  def earlyLookahead(p: ElasParams): Int = {
    val support = 2 * p.windowRadius + 1
    val filter = p.inconWindowSize * p.candidateStep + support
    val grid = 2 * p.gridSize - p.candidateStep + filter
    val fill = p.fillRule match {
      case FillRule.R7 => filter + 2 * p.candidateStep // lattice row 0 looks at rows 1..2
      case FillRule.Paper => filter + p.sDelta
    }
    math.max(grid, p.candidateStep + fill)
  }
  /** The look-ahead, plus one lattice step (the support search of a lattice row), the rows of input time in which
    * the grid stage emits a grid row (the late path loads a whole grid row before its first pixel: without them the
    * input waits about a row every gridSize rows, 3 % at kitti) and two rows for the stages' internal pipelining.
    */
  def bandRows(p: ElasParams): Int = earlyLookahead(p) + p.candidateStep + gridEmitRows(p) + 2
  def gridEmitRows(p: ElasParams): Int = {
    val rowClocks = p.cyclesPerPixel * p.maxWidth
    (GridVector.rowCycles(p, p.maxWidth) + rowClocks - 1) / rowClocks
  }
  def bandEntries(p: ElasParams): Int = bandRows(p) * p.maxWidth
  /** Lattice rows the fill can run ahead of the planes (one row per step image rows of the band), plus two. */
  def latticeQueueEntries(p: ElasParams): Int = (bandRows(p) / p.candidateStep + 3) * p.latticeColsMax
  def gridQueueEntries(p: ElasParams): Int = (bandRows(p) / p.gridSize + 3) * p.gridColsMax
  /** Frames between the guard and post: a band of the smallest frame (16 rows) each, plus the pipeline. */
  def framesInFlight(p: ElasParams): Int = 1 << log2Ceil(bandRows(p) / FrameSize.minHeight + 4)

  def memorySummary(p: ElasParams): Seq[MemoryUse] = {
    val pixelBits = 2 * 8 + 2
    val latticeBits = p.signedDispBits + 3
    val gridBits = 2 * p.storedDisparities * p.signedDispBits + 3
    Descriptor.memorySummary(p).map(_.copy(module = "Descriptor (early)")) ++
      SupportMatcher.memorySummary(p) ++ SupportFilter.memorySummary(p) ++ LatticeFill.memorySummary(p) ++
      GridVector.memorySummary(p) ++
      Seq(MemoryUse("IElas", "lattice queue", latticeQueueEntries(p), latticeBits, "filled lattice rows the early path runs ahead"),
        MemoryUse("IElas", "grid queue", gridQueueEntries(p), gridBits, "grid cells the early path runs ahead"),
        MemoryUse("IElas", "pixel band", bandEntries(p), pixelBits, s"${bandRows(p)} rows of pixel pairs + framing")) ++
      Planes.memorySummary(p) ++ Descriptor.memorySummary(p).map(_.copy(module = "Descriptor (late)")) ++
      DenseMatcher.memorySummary(p) ++ LrCheck.memorySummary(p) ++ PostProcess.memorySummary(p)
  }
}

/** A frame's size as sampled at its start of frame. */
class FrameDims(p: ElasParams) extends Bundle {
  val columns = UInt(p.colBits.W)
  val rows = UInt(p.rowBits.W)
}

/** Sizes of the frames in flight, written at the guard's start of frame and read by each consumer stage at its own
  * start of frame (consumer k reads entry started(k) counts). The last consumer is the slowest, so the table is
  * full when `depth` frames have been recorded that it has not started.
  */
class FrameSizeTable(p: ElasParams, consumers: Int, depth: Int) extends Module {
  require(isPow2(depth), s"FrameSizeTable: depth = $depth must be a power of 2")
  val io = IO(new Bundle {
    val record = Flipped(Valid(new FrameDims(p)))
    val full = Output(Bool())
    val size = Output(Vec(consumers, new FrameDims(p)))
    val started = Input(Vec(consumers, Bool()))
  })
  private val ptrBits = log2Ceil(depth) + 1
  val table = Reg(Vec(depth, new FrameDims(p)))
  val written = RegInit(0.U(ptrBits.W))
  val read = RegInit(VecInit(Seq.fill(consumers)(0.U(ptrBits.W))))
  when(io.record.valid) {
    table(written(ptrBits - 2, 0)) := io.record.bits
    written := written + 1.U
  }
  for (k <- 0 until consumers) {
    // Registered, so no consumer's logic follows the table's multiplexer or the guard's record strobe: a clock old,
    // with the record of that clock forwarded. A consumer samples its size at its start of frame, which comes at
    // least a clock (the top's register slice) after the guard recorded it, and read(k) then moves on to the next
    // frame, which that consumer starts a whole frame later.
    io.size(k) := RegNext(Mux(io.record.valid && read(k) === written, io.record.bits, table(read(k)(ptrBits - 2, 0))))
    when(io.started(k)) { read(k) := read(k) + 1.U }
  }
  // full as a register, from the write counter's next value and the last consumer's read counter (the guard's
  // handshake waits on a flip-flop; a start of frame frees its entry a clock later, so the post-processing
  // handshake stays off this path)
  val full = RegInit(false.B)
  full := (written + io.record.valid.asUInt) - read(consumers - 1) === depth.U
  io.full := full
}

/** Ends an aborted frame's output after the output line in progress (docs/interfaces.md §4): the rest of that frame's
  * output is dropped and its end of frame never appears. `aborted` carries one verdict per frame, known once the
  * guard has seen the whole frame; a frame whose verdict is not yet known keeps flowing.
  */
class OutputGate extends Module {
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(SInt(16.W))))
    val aborted = Flipped(Decoupled(Bool()))
    val out = Decoupled(new Framed(SInt(16.W)))
  })
  val cutting = RegInit(false.B) // the current frame was aborted and its current line has ended
  val abortNow = io.aborted.valid && io.aborted.bits
  val drop = cutting || (abortNow && io.in.bits.sof) // an aborted frame not yet started sends nothing
  io.out.valid := io.in.valid && !drop
  io.out.bits := io.in.bits
  io.out.bits.eof := io.in.bits.eof && !abortNow
  io.in.ready := drop || io.out.ready
  io.aborted.ready := io.in.fire && io.in.bits.eof
  when(io.in.fire) {
    when(io.in.bits.eof) { cutting := false.B }
      .elsewhen(abortNow && (io.in.bits.eol || io.in.bits.sof)) { cutting := true.B }
  }
}

/** The pixel input through the hardware up to one stage, whose stream leaves flattened (`asUInt` of the stage's
  * beat: the first field of a bundle in the most significant bits, element 0 of a Vec in the least): what
  * `make simulate STAGE=` and the chained stage tests read. `make simulate STAGE=top` uses [[IElas]] itself.
  */
class StageTap(p: ElasParams, val stage: Stage) extends Module {
  private def dataOf(s: Stage): Data = s match {
    case Stage.Descriptor => new DescriptorPair(p.descriptorBytes)
    case Stage.Grid => new GridCellPair(p)
    case Stage.Planes => new PlaneCell(p)
    case Stage.Dense | Stage.LrCheck => new DisparityPair(p)
    case Stage.Post => SInt(16.W)
    case _ => SInt(p.signedDispBits.W)
  }
  val dataWidth: Int = dataOf(stage).getWidth
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new PixelPair))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val error = Output(Bool())
    val clearError = Input(Bool())
    val out = Decoupled(new Framed(UInt(dataWidth.W)))
  })
  val pipeline = new Pipeline(p, stage, io.in, io.frameWidth, io.frameHeight, io.clearError)
  io.error := pipeline.error
  pipeline.aborted.ready := true.B // no output gate here: a tap shows what the stage put out
  private val stream: DecoupledIO[Framed[Data]] = (stage match {
    case Stage.Descriptor => pipeline.descriptor
    case Stage.Support => pipeline.support
    case Stage.Filter => pipeline.filter
    case Stage.Interp => pipeline.interp
    case Stage.Grid => pipeline.grid
    case Stage.Planes => pipeline.planes
    case Stage.Dense => pipeline.dense
    case Stage.LrCheck => pipeline.lrcheck
    case Stage.Post => pipeline.post
  }).asInstanceOf[DecoupledIO[Framed[Data]]]
  io.out.valid := stream.valid
  io.out.bits.data := stream.bits.data.asUInt
  io.out.bits.sof := stream.bits.sof
  io.out.bits.eol := stream.bits.eol
  io.out.bits.eof := stream.bits.eof
  stream.ready := io.out.ready
}
