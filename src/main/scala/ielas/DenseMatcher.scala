package ielas

import chisel3._
import chisel3.util._

/** Stage `dense`: the per-pixel MAP search of both views (docs/ALGORITHM.md "Rasteriser" and "dense"), streaming at
  * one pixel per clock.
  *
  * Inputs: the descriptor stream (both views per pixel, raster order), the `planes` stream (one [[PlaneCell]] per
  * lattice cell, cell rows in order) and the `grid` stream (one [[GridCellPair]] per grid cell, grid rows in order).
  * The three streams are independent: plane cells and grid cells are taken into a free row bank whenever one is
  * free, whatever their timing relative to the descriptors; the pixel pipeline waits (stage A holds the pixel and the
  * stream waits) only when the cell row or grid row a pixel needs has not arrived yet. Output: dense_L and dense_R per pixel in
  * raster order (-1 invalid) with sof / eol / eof. frameWidth / frameHeight are sampled at the descriptor sof.
  *
  * '''Candidate lanes.''' A pixel has 2R+1 plane-range candidates and storedDisparities grid candidates per view,
  * not dispMax+1, so each view has denseLanesUsed = ceil(candidates / cyclesPerPixel) lanes (candidate groups of
  * one cycle each when cyclesPerPixel > 1), and each lane has its own replica of a descriptor ring (one read port
  * per lane, a block RAM of ringDepth x 128 bits): the left view's lane k reads descR(P - d_k) from a ring of the
  * right descriptors that have passed stage B, the right view's lane reads descL(P + d_k) from a ring written with
  * the stream (position n), and one more ring holds both views' references. Both views are evaluated at the same
  * pixel P = n - dispMax so that the right view's targets (columns u + d) have arrived. One [[DescriptorSad]] per
  * lane; the first minimum over the lanes in candidate order (grid lanes, then the plane range) is the algorithm's
  * selection. The target rings are read every clock at stage C's addresses (the back half never stalls); the
  * reference ring's read follows the pixel generator ([[DenseMatcher.stageAddress]]), so a stall repeats that read
  * instead of holding 128-bit data. docs/architecture.md ("Fitting the device") gives the alternatives
  * measured.
  * Entries that fall into another row (or the flush after a frame) are never selected: a candidate is skipped
  * unless m <= t <= W-1-m, which keeps t in P's row. After the last beat of a frame the stage inserts dispMax flush
  * steps (input not ready) to bring the frame's last dispMax pixels through.
  *
  * '''Rasteriser.''' For image row v and lattice cell cc the three cut points of the left edge, the diagonal and
  * the right edge with row v, scaled by h (e, g, f of the algorithm), are exact integers. A pixel u can only be
  * covered by cells cu - 1 .. cu + ceil(dispMax/step) (cu = its own cell; right-view vertices move left by at most
  * dispMax), so a register window of K = 2 + ceil(dispMax/step) cells, shifted by one cell every `step` pixels,
  * holds all candidates; the owner is the highest-indexed covering triangle, and an uncovered pixel takes the
  * carried owner of the nearest covered pixel to its left (a row whose pixel 0 is uncovered has no covered pixel at
  * all and takes the cell row's last triangle). A primer computes the first K-1 cells of the next row into shadow
  * registers while the current row runs (one cell per clock, in register steps: corner read and subtractions,
  * products, sums and order, the shadow write), so row starts cost no cycles; the cell a shift brings in is read at
  * the pixel before the shift and its span formed two clocks ahead (products, then sums and order; one clock at
  * candidateStep 3, none at 2), so the window shift only copies registers.
  *   raster registers = 2 (window + shadow) x K x (1 + 4 spanBits)   (right view only)   (K = 9 at small, 53 at kitti)
  *
  * '''Row banks''' (memories, combinational read ports; written by the loaders, tagged with frame parity and row):
  *   corner banks = 2 x (latticeColsMax - 1) x 4 dispBits          (one cell row in use, the next loading)
  *   plane banks  = 2 views x 2 x (latticeColsMax - 1) x 2 (3 x 32 + colBits + rowBits + 3)
  *                  (anchors and coefficients in separate memories, read at stages A3 and B)
  *   grid banks  = 2 x gridColsMax x 2 storedDisparities x (dispBits + 1) (one grid row in use, the next loading)
  * The second grid row is there so that a grid row change costs no cycle (the next row loads while the current
  * one is read); with one bank the pixel stream would wait gridColsMax cycles every gridSize rows.
  * Nothing grows with the image height.
  *
  * '''Framing.''' The descriptor stream is trusted to be well formed (the top checks the pixel framing): a frame is
  * frameWidth x frameHeight beats from sof to eof, and the planes and grid streams carry the matching cell and grid
  * rows. Frames may follow each other back to back in all three streams; row banks are tagged with a frame parity
  * so the next frame's rows can load while the current frame ends.
  *
  * Pipeline: A (window shift, cover tests, grid read; holds its pixel) -> A1..A3 (owner) -> B -> B1 (texture SAD in
  * quarters, plane offsets) -> B2 (plane products) -> B3 (plane value d_p) -> B4 (range lo..hi, the grid lanes' flags),
  * never stalling -> a front queue of [[DenseMatcher.frontQueueDepth]] pixels (credit counted from A) -> C
  * (candidates, ring reads; holds its pixel one cycle per candidate group); then, never stalling, D (ring read) -> D2 (the ring data: a block RAM
  * takes it as its read register) -> D3 (byte differences) -> E (four quarter-descriptor SADs per lane) -> F (cost with
  * the prior) -> the first-minimum tree ([[DenseMatcher.treeRegisters]] register levels) -> an output queue with a slot
  * for every pixel in flight behind C (credit counted). Only A and C hold pixels, each on one-LUT handshakes; each
  * register step is a few LUTs deep (docs/timing.md).
  */
class DenseMatcher(p: ElasParams) extends Module {
  private val D = p.dispMax
  private val S = p.storedDisparities
  private val R = p.planeRadius
  private val m = p.descriptorMargin
  private val step = p.candidateStep
  private val G = p.gridSize
  private val K = DenseMatcher.rasterCells(p)
  private val cellsMax = p.latticeColsMax - 1
  private val colW = p.colBits
  private val rowW = p.rowBits
  private val cellW = log2Ceil(cellsMax + K + 1) + 1
  private val cellRowW = log2Ceil(p.latticeRowsMax + 1)
  private val gridColW = log2Ceil(p.gridColsMax + 1)
  private val gridRowW = log2Ceil(p.gridRowsMax + 1)
  private val inW = log2Ceil(step + 1)
  private val gInW = log2Ceil(G + 1)
  private val spanW = DenseMatcher.spanBits(p)
  private val dispW = p.signedDispBits // signed disparity, -1 invalid
  private val offW = log2Ceil(3 * R + 1) + 2 // lo - d_p + i for i <= 2R, signed
  private val descBits = 8 * p.descriptorBytes
  private val lanes = p.denseLanesUsed //      SAD lanes per view
  private val groups = p.denseGroups //        cycles per pixel of candidate evaluation (lanes x groups >= candidates)
  private val ringDepth = DenseMatcher.ringDepth(p)
  private val ringW = log2Ceil(ringDepth)
  private val copyLanes = 4 //          lanes sharing one copy of a target ring's write address and data
  private val ringCopies = (lanes + copyLanes - 1) / copyLanes
  private val sadParts = 4 //          each lane's SAD in four registered parts (stages D3, E)
  private val costW = 14 //             SAD16 <= 4080 plus a prior >= -4096 fits 14 signed bits
  require(p.priorTable.take(R + 1).forall(v => v >= -(1 << 12) && v < (1 << 12)),
    s"priorTable entries 0..planeRadius must lie in -4096..4095 (got ${p.priorTable.take(R + 1)})")
  // The golden model's dense stage accepts at most 127 grid slots and plane range candidates; beyond that the
  // hardware could not be verified.
  require(S < 128, s"storedDisparities = $S is out of range for the dense stage (legal: 1..${math.min(127, D + 1)})")
  require(2 * R + 1 < 128,
    s"planeRadius = $R (from sigma x sradius) is out of range for the dense stage (legal: 2..63)")

  val io = IO(new Bundle {
    val desc = Flipped(Decoupled(new Framed(new DescriptorPair(p.descriptorBytes))))
    val planes = Flipped(Decoupled(new Framed(new PlaneCell(p))))
    val grid = Flipped(Decoupled(new Framed(new GridCellPair(p))))
    val frameWidth = Input(UInt(colW.W))
    val frameHeight = Input(UInt(rowW.W))
    val out = Decoupled(new Framed(new DisparityPair(p)))
  })

  // ---------------------------------------------------------------- frame parameters (sampled at the desc sof)
  // the size W x H minus 1 and 2: the row- and frame-end compares start at flip-flops (a subtractor in front of the
  // pixel generator's row-end compare was the whole top's critical path)
  val widthM1 = RegInit((p.maxWidth - 1).U(colW.W))
  val heightM1 = RegInit((p.maxHeight - 1).U(rowW.W))
  val widthM2 = RegInit((p.maxWidth - 2).U(colW.W))
  val heightM2 = RegInit((p.maxHeight - 2).U(rowW.W))
  val lastCell = RegInit(0.U(cellW.W)) //    Lw - 2 = (W - 2) / step
  val lastCellRow = RegInit(0.U(cellRowW.W)) // Lh - 2 = (H - 2) / step
  val inFp = RegInit(false.B) // frame parity of the descriptor stream (toggles at each sof)

  // ---------------------------------------------------------------- row banks and their loaders
  class Tag extends Bundle {
    val fp = Bool()
    val row = UInt(math.max(cellRowW, gridRowW).W)
  }
  // Plane banks are split by reader: the corners feed the rasteriser (primer and window shift), each view's planes
  // feed that view's plane read, so every memory has at most two combinational read ports.
  val cornerBanks = Seq.fill(2)(Mem(cellsMax, Vec(4, UInt(p.dispBits.W))))
  // A plane's anchor and its coefficients are kept apart: the anchor is read a stage ahead (A3), so the offsets
  // u - anchorU, v - anchorV subtract registers; read with the coefficients at B, the read ran into those
  // subtracts (the dense matcher's worst path at small-c4).
  class Anchor extends Bundle {
    val u = SInt((p.colBits + 1).W)
    val v = UInt(p.rowBits.W)
  }
  class Coeffs extends Bundle {
    val a = SInt(32.W)
    val b = SInt(32.W)
    val c = SInt(32.W)
    val valid = Bool()
  }
  def anchorOf(pl: PlaneCoeffs): Anchor = { val r = Wire(new Anchor); r.u := pl.anchorU; r.v := pl.anchorV; r }
  def coeffsOf(pl: PlaneCoeffs): Coeffs = {
    val r = Wire(new Coeffs); r.a := pl.a; r.b := pl.b; r.c := pl.c; r.valid := pl.valid; r
  }
  val anchorBanks = Seq.fill(2, 2)(Mem(cellsMax, Vec(2, new Anchor))) // (view)(bank)
  val coeffBanks = Seq.fill(2, 2)(Mem(cellsMax, Vec(2, new Coeffs)))
  val planeFull = RegInit(VecInit(Seq.fill(2)(false.B)))
  val planeTag = Reg(Vec(2, new Tag))
  val gridBanks = Seq.fill(2)(Mem(p.gridColsMax, new GridCellPair(p)))
  val gridFull = RegInit(VecInit(Seq.fill(2)(false.B)))
  val gridTag = Reg(Vec(2, new Tag))

  /** Fills the two banks alternately, one row per bank; a row's tag is (frame parity, row in frame). A bank's `full`
    * flag is set by its row's last beat and cleared by `release` (its readers are done with it). With
    * `registeredWrite` the bank write lands a clock after the beat is taken (its enable then starts at a flip-flop,
    * not at the handshake): only for banks whose readers see a row a clock after its `full` is set.
    *
    * The input's ready is a register holding !full(fill), formed from next cycle's flags, and the loader's own take
    * is formed from the flags, not from `in.fire`. The two sides of the handshake then share no gate: with one
    * shared `fire`, the whole top's worst path at tiny-w3-c8 ran from `full` through the plane stage's output logic
    * and back (8.3 ns of routing).
    */
  def loader[T <: Data](in: DecoupledIO[Framed[T]], full: Vec[Bool], tag: Vec[Tag], depth: Int, release: Vec[Bool],
      registeredWrite: Boolean = false)(write: (Int, UInt, T) => Unit): Unit = {
    val fill = RegInit(0.U(1.W))
    val col = RegInit(0.U(log2Ceil(depth + 1).W))
    val row = RegInit(0.U(tag(0).row.getWidth.W))
    val fp = RegInit(false.B)
    val ready = RegInit(true.B)
    in.ready := ready
    val take = in.valid && !full(fill)
    assert(ready === !full(fill), "DenseMatcher: a loader's ready register")
    val beatCol = Mux(in.bits.sof, 0.U, col)
    val addr = beatCol(math.max(log2Ceil(depth), 1) - 1, 0)
    // the bank write: the beat now, or with `registeredWrite` the same beat a clock later
    val (wValid, wBank, wAddr, wData) =
      if (registeredWrite) (RegNext(take, false.B), RegNext(fill), RegNext(addr), RegNext(in.bits.data))
      else (take, fill, addr, in.bits.data)
    for (i <- 0 until 2) when(wValid && wBank === i.U) { write(i, wAddr, wData) }
    val rowDone = take && in.bits.eol
    when(take) {
      val beatFp = Mux(in.bits.sof, !fp, fp)
      val beatRow = Mux(in.bits.sof, 0.U, row)
      fp := beatFp
      col := Mux(in.bits.sof, 1.U, col + 1.U) // not beatCol + 1: beatCol is the bank write address, a wide net
      row := beatRow
      when(in.bits.eol) {
        tag(fill).fp := beatFp
        tag(fill).row := beatRow
        col := 0.U
        row := beatRow + 1.U
      }
    }
    // a bank is never released while it fills (its readers wait for `full`), so set and release never meet
    for (i <- 0 until 2) assert(!release(i) || full(i), "DenseMatcher: a loader's bank released while it fills")
    val fullNext = VecInit((0 until 2).map(i => !release(i) && (full(i) || rowDone && fill === i.U)))
    val fillNext = Mux(rowDone, ~fill, fill)
    full := fullNext
    fill := fillNext
    ready := !fullNext(fillNext)
  }
  val planeRelease = WireDefault(VecInit(Seq.fill(2)(false.B)))
  val gridRelease = WireDefault(VecInit(Seq.fill(2)(false.B)))
  loader(io.planes, planeFull, planeTag, cellsMax, planeRelease) { (i, addr, cell) =>
    cornerBanks(i).write(addr, cell.corners)
    for ((planes, view) <- Seq(cell.left, cell.right).zipWithIndex) {
      anchorBanks(view)(i).write(addr, VecInit(planes.map(anchorOf)))
      coeffBanks(view)(i).write(addr, VecInit(planes.map(coeffsOf)))
    }
  }
  // The grid banks' write a clock late: stage A reads a row only through aGridHit, a register formed from the banks'
  // `full` flags, so its first read of a row is a clock after `full` is set, when the last write has landed.
  loader(io.grid, gridFull, gridTag, p.gridColsMax, gridRelease, registeredWrite = true) { (i, addr, cell) =>
    gridBanks(i).write(addr, cell)
  }

  def bankOf(full: Vec[Bool], tag: Vec[Tag], fp: Bool, row: UInt): (Bool, UInt) = {
    val hit = (0 until 2).map(i => full(i) && tag(i).fp === fp && tag(i).row === row)
    (hit.reduce(_ || _), Mux(hit(1), 1.U, 0.U))
  }
  def readBank[T <: Data](banks: Seq[MemBase[T]], sel: UInt, addr: UInt, depth: Int): T = {
    val a = addr(math.max(log2Ceil(depth), 1) - 1, 0)
    Mux(sel === 1.U, banks(1).read(a), banks(0).read(a))
  }

  // ---------------------------------------------------------------- rasteriser cell spans
  /** e*h, g*h, f*h of one cell for view 0 (left, s = 0) and 1 (right, s = corner disparities). */
  /** The right view's covered interval lo..hi of the scaled column u*h per triangle t: t = 0 between e and g,
    * t = 1 between g and f (ordered when the cell enters the window, so a pixel's cover test is two compares).
    * The left view needs no window: its mesh is not shifted, so a pixel's own cell always owns it.
    */
  class Span extends Bundle {
    val valid = Bool()
    val lo = Vec(2, SInt(spanW.W))
    val hi = Vec(2, SInt(spanW.W))
  }
  /** A cell's corner offsets x - s (x0, x1 its left and right column, s its corner disparities): the first register
    * step of a span, whose memory read and subtractions stay off the products (see [[spanOf]]).
    */
  class Cuts extends Bundle {
    val valid = Bool()
    val tl = SInt((colW + 4).W)
    val tr = SInt((colW + 4).W)
    val bl = SInt((colW + 4).W)
    val br = SInt((colW + 4).W)
  }
  /** Cell cc's place in the row: whether it exists (cc <= lastCell) and its left and right column x0, x1. */
  class CellAt extends Bundle {
    val cc = UInt(cellW.W)
    val exists = Bool()
    val x0 = UInt((colW + 2).W)
    val x1 = UInt((colW + 2).W)
  }
  /** x0 = cc x step (mod 2^(colW + 2)) comes in from a counter kept beside cc: a constant multiply maps to a DSP,
    * whose delay would sit between the cell counter and the offsets. */
  def cellAt(cc: UInt, x0: UInt): CellAt = {
    val c = Wire(new CellAt)
    c.cc := cc
    c.exists := cc <= lastCell
    c.x0 := x0
    val x1raw = c.x0 +& step.U
    c.x1 := Mux(x1raw > widthM1, widthM1, x1raw)
    c
  }
  def cellCuts(at: CellAt, corners: Vec[UInt]): Cuts = {
    val c = Wire(new Cuts)
    c.valid := at.exists
    c.tl := at.x0.zext - corners(0).zext
    c.tr := at.x1.zext - corners(1).zext
    c.bl := at.x0.zext - corners(2).zext
    c.br := at.x1.zext - corners(3).zext
    c
  }
  /** The second step: the cuts' products with the row offsets (up, down), a multiplier each on the ECP5. */
  class Products extends Bundle {
    val valid = Bool()
    val tlUp = SInt(spanW.W)
    val trUp = SInt(spanW.W)
    val blDown = SInt(spanW.W)
    val brDown = SInt(spanW.W)
  }
  def productsOf(c: Cuts, up: UInt, down: UInt): Products = {
    val r = Wire(new Products)
    r.valid := c.valid
    r.tlUp := c.tl * up.zext
    r.trUp := c.tr * up.zext
    r.blDown := c.bl * down.zext
    r.brDown := c.br * down.zext
    r
  }
  /** The third step: e, g, f and each triangle's ordered interval (sums, then compares). */
  def spanOfProducts(q: Products): Span = {
    val s = Wire(new Span)
    s.valid := q.valid
    val e = q.tlUp + q.blDown
    val g = q.trUp + q.blDown
    val f = q.trUp + q.brDown
    for ((t, (x, y)) <- Seq(0 -> (e, g), 1 -> (g, f))) {
      s.lo(t) := Mux(x < y, x, y)
      s.hi(t) := Mux(x < y, y, x)
    }
    s
  }
  def spanOf(c: Cuts, up: UInt, down: UInt): Span = spanOfProducts(productsOf(c, up, down))
  def noSpan: Span = { val s = Wire(new Span); s := 0.U.asTypeOf(new Span); s }

  // ---------------------------------------------------------------- pixel positions
  class Pos extends Bundle {
    val u = UInt(colW.W)
    val v = UInt(rowW.W)
    val cu = UInt(cellW.W) //    cell column of u (capped at lastCell)
    val uIn = UInt(inW.W) //     u - cu*step
    val cr = UInt(cellRowW.W) // cell row of v (capped at lastCellRow)
    val vIn = UInt(inW.W) //     v - cr*step
    val gx = UInt(gridColW.W)
    val uG = UInt(gInW.W)
    val gy = UInt(gridRowW.W)
    val vG = UInt(gInW.W)
    val fp = Bool()
    val h = UInt(inW.W) //          cell height of the row: y1 - y0 of cell row cr
    val up = UInt(inW.W) //         h - vIn (y1 - v), registered so the window's products start at a register
    val uh = UInt((colW + inW).W) // u * h, kept by adding h (the rasteriser's scaled column)
    val shiftX0 = UInt((colW + 2).W) // (cu + K - 1) * step (mod 2^(colW + 2)): the column of the cell a shift brings in
  }
  private val shiftX0First = (((K - 1) * step) % (1 << (colW + 2))).U((colW + 2).W) // shiftX0 at u = 0
  def nextCellRow(q: Pos): Bool = q.vIn === (step - 1).U && q.cr < lastCellRow
  def nextCellCol(q: Pos): Bool = q.uIn === (step - 1).U && q.cu < lastCell
  /** The pixel after q. Its row end `end` (q.u = W - 1), `below` (q.cr < lastCellRow) and the heights of cell rows
    * q.cr and q.cr + 1 come in as registers (see `genRowEnd`, `genBelow`), so no compare sits on the generator's
    * per-pixel path.
    */
  def advance(q: Pos, end: Bool, below: Bool, hCur: UInt, hNext: UInt): Pos = {
    val n = Wire(new Pos)
    val nextCr = q.vIn === (step - 1).U && below
    n := q
    when(end) {
      n.u := 0.U; n.cu := 0.U; n.uIn := 0.U; n.gx := 0.U; n.uG := 0.U
      n.shiftX0 := shiftX0First
      n.v := q.v + 1.U
      n.uh := 0.U
      n.h := Mux(nextCr, hNext, hCur)
      when(nextCr) { n.cr := q.cr + 1.U; n.vIn := 0.U }.otherwise { n.vIn := q.vIn + 1.U }
      when(q.vG === (G - 1).U) { n.gy := q.gy + 1.U; n.vG := 0.U }.otherwise { n.vG := q.vG + 1.U }
    }.otherwise {
      n.u := q.u + 1.U
      n.uh := q.uh + q.h
      when(nextCellCol(q)) { n.cu := q.cu + 1.U; n.uIn := 0.U; n.shiftX0 := q.shiftX0 + step.U }
        .otherwise { n.uIn := q.uIn + 1.U }
      when(q.uG === (G - 1).U) { n.gx := q.gx + 1.U; n.uG := 0.U }.otherwise { n.uG := q.uG + 1.U }
    }
    // h - vIn: a new cell row starts at vIn = 0; otherwise h stays (one height per cell row) and vIn counts up
    n.up := Mux(end, Mux(nextCr, n.h, q.up - 1.U), q.up)
    n
  }
  // The last cell row's height min(step, H - 1 - y0) (every other cell row is step high), for the pixel generator.
  // (the products by step are registers of their own: a constant multiply is a DSP, kept off the compares)
  val lastCellRowY0 = RegNext(lastCellRow * step.U)
  val lastRowH = RegNext(Mux(heightM1 - lastCellRowY0 < step.U, heightM1 - lastCellRowY0, step.U))
  /** Row geometry of a cell row starting at image row y0 (= cr x step mod 2^(rowW + 2), from a counter), at image
    * row offset vIn: (h, up = y1 - v, down = v - y0). */
  def rowGeometry(y0: UInt, vIn: UInt): (UInt, UInt, UInt) = {
    val y1raw = y0 +& step.U
    val y1 = Mux(y1raw > heightM1, heightM1, y1raw)
    val h = (y1 - y0)(inW - 1, 0)
    (h, (h - vIn)(inW - 1, 0), vIn)
  }

  // ---------------------------------------------------------------- pipeline control
  // Only stages A and C ever hold a pixel. A holds a row's first pixel until its primer and grid row are there, and
  // any pixel until it has a front credit: a free slot of the front queue (between B4 and C) for every pixel in
  // flight behind A, so A1..B4 never stall and their wide registers load every clock with no enable. C holds a pixel
  // for its candidate groups and issues a group only while it holds an output credit, a free slot of the output queue
  // for every pixel in flight behind C, so the back half (ring data, SADs, tree) needs no enable either. One stall
  // signal across A..C, fanned out to every step's registers, was the critical path (docs/architecture.md).
  private val outDepth = DenseMatcher.backStages(p) + 2 // a credit comes back two cycles after the pixel's enqueue
  val outQueue = Module(new Queue(new Framed(new DisparityPair(p)), outDepth) {
    override def desiredName = "DenseOutputQueue" // one per design: the same module name in every top's Verilog
  })
  io.out <> outQueue.io.deq
  val outCredits = new Credits(outDepth, "credits", "creditOk")
  val creditOk = outCredits.ok
  private val frontDepth = DenseMatcher.frontQueueDepth
  val frontCredits = new Credits(frontDepth, "frontCredits", "frontCreditOk")
  val frontCreditOk = frontCredits.ok

  val aValid = RegInit(false.B)
  val aFirst = RegInit(false.B) // a.u = 0, registered with a (it selects the raster window: keep it off the compare)
  val aShift = Reg(new CellAt) // the cell a window shift at a brings in, cu + K - 1 (see `shiftCuts`)
  val a = Reg(new Pos)
  val shadow = Reg(Vec(K, new Span))
  val shadowFull = RegInit(false.B)
  val (gridHit, gridSel) = bankOf(gridFull, gridTag, a.fp, a.gy)
  val (planeHit, planeSel) = bankOf(planeFull, planeTag, a.fp, a.cr)
  // a's grid row is loaded, registered: formed from the pixel entering A, then from a itself while it waits. A row
  // that completes in that clock shows a clock late (a wait of one cycle); a bank is released only by its row's last
  // pixel leaving A, and the pixel entering then needs another row or frame, so the register is never true too long.
  val aGridHit = RegNext(gridHit, false.B)
  val aGridSel = RegNext(gridSel) // a's grid bank, registered the same way (the bank read's select is a flip-flop)
  // only a row's first pixel waits (for its primer and grid row): aReady = !aFirst || (shadowFull && aGridHit), kept
  // as a register formed from those three's next values (below), so the handshake starts at flip-flops
  val aReady = RegInit(false.B)
  val aRowEnd = RegInit(false.B) // a.u = W - 1, registered with a
  // a's cell width w1 = x1 - x0 (step, or the last cell's): registered with a, and formed again from a while it
  // waits (a frame's first pixel may enter A before lastCell settles), so the left owner's product w1 * up starts
  // and ends at flip-flops (the compare and select in front of the multiplier were the whole top's critical path)
  val aCellWidth = Reg(UInt(inW.W))
  val lastCellX0 = RegNext(lastCell * step.U)
  val lastCellWidth = RegNext(Mux(widthM1 - lastCellX0 < step.U, widthM1 - lastCellX0, step.U))
  def cellWidth(cu: UInt): UInt = Mux(cu === lastCell, lastCellWidth, step.U)(inW - 1, 0)
  aCellWidth := cellWidth(a.cu) // (a pixel entering A overrides this below)
  // whether a's successor enters the next cell (the window shifts), registered the same way: the shift enable reaches
  // every bit of the window, so it starts at a flip-flop rather than after the compare with lastCell
  val aNextCell = Reg(Bool())
  aNextCell := nextCellCol(a)
  // The handshakes read flags kept as registers (the credits =/= 0, the last candidate group, flushing, the primer
  // lag done, the front queue not empty) rather than counter compares: each is one LUT deep.
  val aFire = aValid && aReady && frontCreditOk // stage A's pixel moves into A1 on this clock
  val aTakes = !aValid || aFire //                 stage A takes the next pixel: the stream moves
  val cValid = RegInit(false.B)
  val group = RegInit(0.U(math.max(1, log2Ceil(groups)).W)) // candidate group stage C issues this cycle
  val cLast = if (groups == 1) true.B else RegInit(false.B) // group === groups - 1
  val frontNonEmpty = RegInit(false.B) // the front queue holds a pixel
  val cLoad = creditOk && (!cValid || cLast) && frontNonEmpty // stage C takes the front queue's next pixel

  val flush = RegInit(0.U(log2Ceil(D + 1).W)) // flush steps still to insert after a frame's last beat
  val flushing = RegInit(false.B) //               flush =/= 0
  // After a frame's flush the stream waits until the frame's last pixel has left stage C: between the rings' writes
  // and reads a frame's pixels lie at consecutive stream positions, but the next frame's first dispMax positions
  // carry no pixel, so two frames in flight at once would span more than ringDepth positions.
  val draining = RegInit(false.B)
  val inputOpen = RegInit(true.B) // !flushing && !draining
  io.desc.ready := aTakes && inputOpen
  val slot = aTakes && (flushing || (io.desc.valid && inputOpen))
  val slotSof = !flushing && io.desc.bits.sof
  // flushing's copy for the 2 x descBits data multiplexers, held inverted so Yosys keeps it apart: one net into those
  // and the handshake was the whole top's critical path (4.1 ns of routing to its first LUT on the ECP5)
  val descLive = RegInit(true.B)
  assert(descLive === !flushing, "DenseMatcher: descLive differs from !flushing")
  val slotL = Mux(descLive, io.desc.bits.data.left, 0.U)
  val slotR = Mux(descLive, io.desc.bits.data.right, 0.U)

  // descriptor rings, all written at the stream position's address `wp` (see "Candidate lanes"); the target rings a
  // clock after the slot (their reads come D positions and more later), from registers near their block RAMs
  val wp = RegInit(0.U(ringW.W))
  when(slot) { wp := wp + 1.U }
  val refRing = SyncReadMem(ringDepth, Vec(2, UInt(descBits.W))) // (descL, descR) of every stream position
  val ringL = Seq.fill(lanes)(SyncReadMem(ringDepth, UInt(descBits.W))) // descL: the right view's targets
  val ringR = Seq.fill(lanes)(SyncReadMem(ringDepth, UInt(descBits.W))) // descR(P) written from stage B
  // A target ring's write reaches a block RAM of every lane, so each group of `copyLanes` lanes takes its write address
  // and data from its own registers (one data register to every lane was one net of 16 ns on the ECP5 at small, one
  // address register 9.6 ns at small-c4). Copy g loads with the write's source, and also when `copyPhase` = g: those
  // loads are never written (a write follows only a load with the source set), but they give each copy its own
  // enable, so synthesis cannot merge the copies back into one register.
  class RingWrite extends Bundle {
    val addr = UInt(ringW.W)
    val data = UInt(descBits.W)
  }
  val copyPhase = RegInit(0.U(log2Ceil(ringCopies + 1).W))
  copyPhase := copyPhase + 1.U
  def ringWriteCopies(load: Bool, addr: UInt, data: UInt): (Bool, Seq[RingWrite]) = {
    val copies = (0 until ringCopies).map { g =>
      val r = Reg(new RingWrite)
      when(load || copyPhase === g.U) { r.addr := addr; r.data := data }
      r
    }
    (RegNext(load, false.B), (0 until lanes).map(k => copies(k / copyLanes)))
  }
  val (ringLWrite, ringLCopies) = ringWriteCopies(slot, wp, slotL)
  when(slot) { refRing.write(wp, VecInit(slotL, slotR)) }
  when(ringLWrite) { for ((ring, w) <- ringL.zip(ringLCopies)) ring.write(w.addr, w.data) }

  // pixel generator: pixel P = n - dispMax enters stage A with stream position n
  val gen = Reg(new Pos)
  val genFirst = RegInit(false.B) // gen.u = 0
  val genRowEnd = RegInit(false.B) // gen.u = W - 1: the pixel after gen.u = W - 2 (W >= 32, so never the first)
  // gen's frame end: gen.v changes only at a row end, and the next row end is W >= 32 pixels later
  val genLastRow = RegNext(gen.v === heightM1)
  val (genGridHit, genGridSel) = bankOf(gridFull, gridTag, gen.fp, gen.gy)
  val loadA = WireDefault(false.B) // gen enters stage A this cycle
  val genActive = RegInit(false.B)
  // gen's cell-row facts, a register behind gen: its cell row changes only at a row end, and the next row end that
  // reads them is a row (>= 2 pixels) later; lastCellRow and lastRowH settle within 5 cycles of sof, long before
  // gen's first row end (the primer lag is D steps).
  val genBelow = RegNext(gen.cr < lastCellRow)
  val genHCur = RegNext(Mux(gen.cr === lastCellRow, lastRowH, step.U))
  val genHNext = RegNext(Mux(gen.cr +& 1.U === lastCellRow, lastRowH, step.U))
  val lag = RegInit(0.U(log2Ceil(D + 1).W))
  val lagDone = RegInit(false.B) // lag === D: pixels enter stage A
  val sofPending = RegInit(false.B) // a frame the primer has not started yet
  val aAddr = Reg(UInt(ringW.W)) //     ring address of a's pixel (its stream position)
  // a's reference descriptors, read from the ring as the pixel enters stage A
  val aRefAddr = DenseMatcher.stageAddress(wp - D.U, slot && !slotSof && lagDone && genActive)
  val aRef = refRing.read(aRefAddr)

  // (nothing enters A while draining, so the pipeline, once empty, stays empty until the register below clears it)
  val drained = RegNext(draining && !aValid && frontCredits.full && !cValid, false.B)
  when(drained) { draining := false.B; inputOpen := true.B }
  assert(inputOpen === (!flushing && !draining), "DenseMatcher: inputOpen differs from !flushing && !draining")
  when(io.desc.fire && io.desc.bits.eof) { flush := D.U; flushing := true.B; descLive := false.B; inputOpen := false.B }
  when(slot) {
    when(flushing) {
      flush := flush - 1.U
      when(flush === 1.U) { flushing := false.B; descLive := true.B; draining := true.B }
    }
    when(slotSof) {
      lag := 1.U
      lagDone := (D == 1).B
      widthM1 := io.frameWidth - 1.U
      heightM1 := io.frameHeight - 1.U
      widthM2 := io.frameWidth - 2.U
      heightM2 := io.frameHeight - 2.U
      inFp := !inFp
      sofPending := true.B
      genActive := true.B
      gen := 0.U.asTypeOf(new Pos)
      genFirst := true.B
      genRowEnd := false.B
      gen.shiftX0 := shiftX0First
      gen.fp := !inFp
      val firstRowH = Mux(io.frameHeight - 1.U < step.U, io.frameHeight - 1.U, step.U) // cell row 0: min(step, H - 1)
      gen.h := firstRowH
      gen.up := firstRowH
    }.elsewhen(!lagDone) {
      lag := lag + 1.U
      lagDone := lag === (D - 1).U
    }.elsewhen(genActive) {
      a := gen
      loadA := true.B
      aFirst := genFirst
      aRowEnd := genRowEnd
      aCellWidth := cellWidth(gen.cu)
      aNextCell := nextCellCol(gen)
      aGridHit := genGridHit
      aGridSel := genGridSel
      aShift := cellAt(gen.cu + (K - 1).U, gen.shiftX0)
      aAddr := wp - D.U
      gen := advance(gen, genRowEnd, genBelow, genHCur, genHNext)
      genFirst := genRowEnd
      genRowEnd := !genRowEnd && gen.u === widthM2
      when(genRowEnd && genLastRow) { genActive := false.B }
    }
  }
  assert(!genActive || genRowEnd === (gen.u === widthM1), "DenseMatcher: the generator's row-end register is wrong")
  assert(!genActive || !genRowEnd || genLastRow === (gen.v === heightM1),
    "DenseMatcher: the generator's last-row register is wrong")
  // (slot implies aTakes) a pixel enters A in a slot past the primer lag; otherwise A empties when its pixel leaves
  aValid := Mux(aTakes, slot && !slotSof && lagDone && genActive, aValid)
  // refRing: read D positions behind the write (the ring is deeper than D + 10), or at the held address while nothing
  // is written (stalled); during the flush and the primer lag the held address meets the wrapping writes, unused
  CollisionFree.check("DenseMatcher: refRing", Seq(refRing), Seq(CollisionFree.Read(aRefAddr, aFire)),
    Seq(CollisionFree.Write(slot, wp)))
  // The last cell column and row follow from the size minus 2 registered at sof, two register steps later (the
  // product by the reciprocal waits one step more): the divisions stay off the handshake paths, and each multiplier
  // starts and ends at flip-flops. The primer starts once they are there (`sizeReady`, three cycles after sof).
  val sizeStep1 = RegNext(slot && slotSof, false.B)
  val sizeStep2 = RegNext(sizeStep1, false.B)
  when(sizeStep2) {
    lastCell := DenseMatcher.divConst(widthM2, step, colW)
    lastCellRow := DenseMatcher.divConst(heightM2, step, rowW)
  }
  val sizeReady = RegInit(false.B)
  when(slot && slotSof) { sizeReady := false.B }.elsewhen(sizeStep2) { sizeReady := true.B }

  // ---------------------------------------------------------------- primer: the next row's first K-1 cells
  val pRow = Reg(new Pos) // only v, cr, vIn, fp are used
  val pJ = RegInit(0.U(cellW.W))
  val pX0 = RegInit(0.U((colW + 2).W)) // pJ * step
  val pY0 = RegInit(0.U((rowW + 2).W)) // pRow.cr * step
  val pWaitFrame = RegInit(true.B)
  val pActive = RegInit(false.B)
  val pIssued = RegInit(false.B) // all K-1 cells of the next row issued; cleared with the last write
  when(pWaitFrame && sofPending && sizeReady && !shadowFull && !pIssued) {
    pWaitFrame := false.B
    pActive := true.B
    sofPending := false.B
    pRow := 0.U.asTypeOf(new Pos)
    pRow.fp := inFp
    pY0 := 0.U
    pJ := 0.U
    pX0 := 0.U
  }
  val (pHit, pSel) = bankOf(planeFull, planeTag, pRow.fp, pRow.cr)
  val pCorners = readBank(cornerBanks, pSel, pJ, cellsMax)
  val (pH, pUp, pDown) = rowGeometry(pY0, pRow.vIn)
  // four register steps per cell: the issue reads the corners into p1 (cuts), p2 takes the products (a multiplier
  // each on the ECP5), p3 the span (sums and order compares), and the next cycle writes it into the shadow
  val p1Valid = RegInit(false.B)
  val p1J = Reg(UInt(cellW.W))
  val p1Cuts = Reg(new Cuts)
  val p1Up = Reg(UInt(inW.W))
  val p1Down = Reg(UInt(inW.W))
  p1Valid := false.B
  when(pActive && !shadowFull && !pIssued && pHit) {
    p1Valid := true.B
    p1J := pJ
    p1Cuts := cellCuts(cellAt(pJ, pX0), pCorners)
    p1Up := pUp
    p1Down := pDown
    pJ := pJ + 1.U
    pX0 := pX0 + step.U
    when(pJ === (K - 2).U) {
      pIssued := true.B
      pJ := 0.U
      pX0 := 0.U
      when(pRow.v === heightM1) {
        pActive := false.B
        pWaitFrame := true.B
      }.otherwise {
        pRow.v := pRow.v + 1.U
        when(pRow.vIn === (step - 1).U && pRow.cr < lastCellRow) {
          pRow.cr := pRow.cr + 1.U; pRow.vIn := 0.U; pY0 := pY0 + step.U
        }
          .otherwise { pRow.vIn := pRow.vIn + 1.U }
      }
    }
  }
  val p2Valid = RegNext(p1Valid, false.B)
  val p2J = RegNext(p1J)
  val p2Products = RegNext(productsOf(p1Cuts, p1Up, p1Down))
  val p3Valid = RegNext(p2Valid, false.B)
  val p3J = RegNext(p2J)
  val p3Span = RegNext(spanOfProducts(p2Products))
  when(p3Valid) {
    shadow(0) := noSpan
    for (j <- 1 until K) when(p3J === (j - 1).U) { shadow(j) := p3Span }
    when(p3J === (K - 2).U) { pIssued := false.B }
  }
  // the shadow is full from the primer's last write until the row's first pixel leaves A (the primer writes only
  // while it is empty, so the two never meet)
  val shadowFullNext = Mux(aFire && aFirst, false.B, Mux(p3Valid && p3J === (K - 2).U, true.B, shadowFull))
  shadowFull := shadowFullNext
  val aReadyNext = !Mux(loadA, genFirst, aFirst) || (shadowFullNext && Mux(loadA, genGridHit, gridHit))
  aReady := aReadyNext

  // ---------------------------------------------------------------- stage A
  // Stage A decides what needs the window and the frame registers (the cover tests, the left owner's two products,
  // the pixel's flags); A1..A3 find the owner (the highest cover per block of 8, then over the blocks, then the
  // carried owner), B reads the planes.
  val window = Reg(Vec(K, new Span))
  val aH = a.h
  val aUp = a.up
  val aDown = a.vIn
  val win = Mux(aFirst, shadow, window)
  val uh = a.uh.zext

  // next window: shift by one cell when the next pixel enters the next cell. The entering cell's cuts are read at
  // the pixel before (every pixel that fires registers those of its own cu + K - 1): a shift happens at a cell's
  // last pixel (uIn = step - 1 >= 1), so the pixel before it is in the same cell and row.
  // (aShift, the entering cell cu + K - 1 and its columns, is registered with a: the corner read's address and the
  // offsets' columns come from registers)
  val shiftCuts = Reg(new Cuts)
  when(aFire) { shiftCuts := cellCuts(aShift, readBank(cornerBanks, planeSel, aShift.cc, cellsMax)) }
  // The span is formed every clock from shiftCuts and the row offsets of the pixel in stage A, in register steps of
  // its own: with candidateStep >= 4 two (the products, then sums and order), with 3 one, with 2 none. At the shift
  // of pixel s (uIn = step - 1, so u >= step - 1) a span n steps deep was formed from the shiftCuts and stage A of n
  // clocks before. shiftCuts then holds the cuts loaded by one of s - n - 1 .. s - 1 (at most n + 1 pixels leave A in
  // n + 1 clocks; it is loaded by every pixel that leaves) and A holds one of s - n .. s; with n <= step - 2 all of
  // them lie in s's cell and row.
  val shiftSpan =
    if (step >= 4) RegNext(spanOfProducts(RegNext(productsOf(shiftCuts, aUp, aDown))))
    else if (step == 3) RegNext(spanOf(shiftCuts, aUp, aDown))
    else spanOf(shiftCuts, aUp, aDown)
  when(aFire && !aRowEnd) {
    when(aNextCell) {
      for (j <- 0 until K - 1) window(j) := win(j + 1)
      window(K - 1) := shiftSpan
    }.otherwise { window := win }
  }
  assert(!aFire || aNextCell === nextCellCol(a), "DenseMatcher: the window shift register differs from the cell test")

  /** What travels unchanged with a pixel from stage A to stage C. */
  class Carry extends Bundle {
    val addr = UInt(ringW.W)
    val refs = Vec(2, UInt(descBits.W))
    val reach = Vec(2, SInt((colW + 1).W)) // highest disparity whose target column is legal (< 0: none)
    val grid = Vec(2, Vec(S, SInt(dispW.W)))
    val sof = Bool()
    val eol = Bool()
    val eof = Bool()
  }
  /** What travels with a pixel from stage A to stage B besides its Carry. */
  class Pixel extends Bundle {
    val u = UInt(colW.W)
    val v = UInt(rowW.W)
    val inside = Bool() //      inside the margins
    val planeSel = UInt(1.W) // its plane row bank
    val release = Bool() //     the cell row's last pixel: its plane bank is free once the planes are read
    val first = Bool() //       u = 0
    val fallback = UInt((cellW + 1).W) // right-view owner of a row without covered pixels: the row's last triangle
    val carry = new Carry
  }
  val gridCell = readBank(gridBanks, aGridSel, a.gx, p.gridColsMax) // (aGridSel is right once aReady: see aGridHit)
  val aPixel = Wire(new Pixel)
  aPixel.u := a.u
  aPixel.v := a.v
  aPixel.inside := a.u >= m.U && a.u +& m.U <= widthM1 && a.v >= m.U && a.v +& m.U <= heightM1
  aPixel.planeSel := planeSel
  aPixel.release := aRowEnd && (a.v === heightM1 || nextCellRow(a))
  aPixel.first := aFirst
  aPixel.fallback := Cat(lastCell, 1.U(1.W))
  aPixel.carry.addr := aAddr
  aPixel.carry.refs := aRef
  aPixel.carry.reach(0) := a.u.zext - m.S //                 left: target u - d needs u - d >= m
  aPixel.carry.reach(1) := widthM1.zext - m.S - a.u.zext // right: target u + d needs u + d <= W - 1 - m
  aPixel.carry.grid(0) := gridCell.left
  aPixel.carry.grid(1) := gridCell.right
  aPixel.carry.sof := a.u === 0.U && a.v === 0.U
  aPixel.carry.eol := aRowEnd
  aPixel.carry.eof := aRowEnd && a.v === heightM1
  // release the grid row bank after its last pixel (its read is in stage A)
  when(aFire && aRowEnd) {
    when(aPixel.carry.eof || a.vG === (G - 1).U) { gridRelease(aGridSel) := true.B }
  }

  /** A register step of stages A1..B4, which never stall: it takes the step before it, valid bit and data, every
    * clock (no enable; an empty step's data is never read). */
  def upStage[T <: Data](gen: T, prevValid: Bool)(fill: T => Unit): (Bool, T) = {
    val r = Reg(gen)
    fill(r)
    (RegNext(prevValid, false.B), r)
  }

  // Left view: cell cu spans x0..x1 (x1 = min(x0 + step, W - 1)), its triangles cover e = x0 h .. g and g .. f = x1 h
  // with g = x1 (h - vIn) + x0 vIn, and no higher-indexed cell reaches u (its e is above u h; h >= 1 in every row), so
  // the owner is (cu, t = 1) when u h >= g, else (cu, 0): the highest-indexed covering triangle of the general rule.
  // With u = x0 + uIn and w1 = x1 - x0, u h >= g is uIn h >= w1 (h - vIn): two products of step-sized numbers.
  class StageA1 extends Bundle {
    val px = new Pixel
    val cu = UInt(cellW.W)
    val uInH = UInt((2 * inW).W)
    val w1Up = UInt((2 * inW).W)
    val covers = UInt((2 * K).W) // right view: triangle j*2 + t of the window covers the pixel (drawing order)
    val base2 = UInt((cellW + 1).W) // 2 x (cell of window entry 0)
  }
  val (a1Valid, a1) = upStage(new StageA1, aFire) { r =>
    r.px := aPixel
    r.cu := a.cu
    r.uInH := a.uIn * aH
    r.w1Up := aCellWidth * aUp
    r.covers := VecInit((0 until K).flatMap { j =>
      val s = win(j)
      (0 until 2).map(t => s.valid && s.lo(t) <= uh && uh <= s.hi(t))
    }).asUInt
    r.base2 := ((a.cu - 1.U) << 1)(cellW, 0)
  }
  /** The highest set entry of `xs` (a power of two of (any, index) pairs with equal index widths) as a balanced
    * tree of 2:1 muxes: log2 levels instead of the linear chain a priority mux becomes.
    */
  def highest(xs: Seq[(Bool, UInt)]): (Bool, UInt) =
    if (xs.length == 1) xs.head
    else {
      val (lo, hi) = xs.splitAt(xs.length / 2)
      val (anyLo, idxLo) = highest(lo)
      val (anyHi, idxHi) = highest(hi)
      (anyLo || anyHi, Mux(anyHi, Cat(1.U(1.W), idxHi), Cat(0.U(1.W), idxLo)))
    }
  private val coverBlocks = 1 << log2Ceil((2 * K + 7) / 8) // blocks of 8 cover bits, padded to a power of two
  class StageA2 extends Bundle {
    val px = new Pixel
    val leftOwner = UInt((cellW + 1).W)
    val base2 = UInt((cellW + 1).W)
    val blockAny = Vec(coverBlocks, Bool()) //   a block of 8 cover bits has a covering triangle
    val blockTop = Vec(coverBlocks, UInt(3.W)) // its highest one
  }
  val (a2Valid, a2) = upStage(new StageA2, a1Valid) { r =>
    r.px := a1.px
    r.leftOwner := Cat(a1.cu, a1.uInH >= a1.w1Up)(cellW, 0)
    r.base2 := a1.base2
    for (k <- 0 until coverBlocks) {
      val bits = (0 until 8).map(i => if (8 * k + i < 2 * K) a1.covers(8 * k + i) else false.B)
      val (any, top) = highest(bits.grouped(2).map(pair => (pair(0) || pair(1), pair(1).asUInt)).toSeq)
      r.blockAny(k) := any
      r.blockTop(k) := top
    }
  }
  class StageA3 extends Bundle {
    val px = new Pixel
    val leftOwner = UInt((cellW + 1).W)
    val covered = Bool()
    val coveredOwner = UInt((cellW + 1).W) // base2 + j * 2 + t of the highest covering triangle in the window
  }
  val (a3Valid, a3) = upStage(new StageA3, a2Valid) { r =>
    r.px := a2.px
    r.leftOwner := a2.leftOwner
    val (any, top) = highest(a2.blockAny.zip(a2.blockTop))
    r.covered := any
    r.coveredOwner := (a2.base2 + top)(cellW, 0) // added here: the owner feeds the plane banks' read address next
  }
  // Right view: the highest-indexed covering triangle in the window, else the owner of the last covered pixel.
  val carry = Reg(UInt((cellW + 1).W))
  val rightOwner = Mux(a3.covered, a3.coveredOwner, Mux(a3.px.first, a3.px.fallback, carry))
  when(a3Valid) { carry := rightOwner }

  /** Triangle `owner` (cell * 2 + t) of the plane row bank `sel` in one view's banks. */
  def ownerRead[T <: Data](banks: Seq[MemBase[Vec[T]]], sel: UInt, owner: UInt): T = {
    val both = readBank(banks, sel, owner >> 1, cellsMax)
    Mux(owner(0), both(1), both(0))
  }
  class StageB extends Bundle {
    val px = new Pixel
    val owner = Vec(2, UInt((cellW + 1).W))
    val anchor = Vec(2, new Anchor)
  }
  val (bValid, b) = upStage(new StageB, a3Valid) { r =>
    r.px := a3.px
    for ((owner, view) <- Seq(a3.leftOwner, rightOwner).zipWithIndex) {
      r.owner(view) := owner
      r.anchor(view) := ownerRead(anchorBanks(view), a3.px.planeSel, owner)
    }
  }
  // the left view's targets: descR of the pixels that have passed stage B (written a clock later, like ringL)
  val (ringRWrite, ringRCopies) = ringWriteCopies(bValid, b.px.carry.addr, b.px.carry.refs(1))
  when(ringRWrite) { for ((ring, w) <- ringR.zip(ringRCopies)) ring.write(w.addr, w.data) }
  // the plane row bank is free once the cell row's last pixel has read it (stage B)
  when(bValid && b.px.release) { planeRelease(b.px.planeSel) := true.B }
  val ownerCoeffs = (0 until 2).map(view => ownerRead(coeffBanks(view), b.px.planeSel, b.owner(view)))

  // ---------------------------------------------------------------- stages B1..B3: texture, plane value and range
  // d_p = (c + a (u - anchorU) + b (v - anchorV) + 2^15) >> 16 in three register steps (offsets, products, sum), the
  // texture SAD beside them; the same exact integer arithmetic as one expression, only registered.
  // each SAD in four quarter-descriptor parts (a 16- or 8-byte adder tree maps to 7 LUT levels), added a stage later
  val partBytes = p.descriptorBytes / sadParts
  require(partBytes * sadParts == p.descriptorBytes)
  def quarter(x: UInt, part: Int): UInt = x(8 * partBytes * (part + 1) - 1, 8 * partBytes * part)
  def partSads(x: UInt, y: UInt): Seq[UInt] = (0 until sadParts).map { part =>
    val u = Module(new DescriptorSad(partBytes))
    u.io.x := quarter(x, part)
    u.io.y := quarter(y, part)
    u.io.sad
  }
  val flat = VecInit(Seq.fill(p.descriptorBytes)(128.U(8.W))).asUInt
  private val termW = 32 + math.max(colW, rowW) + 2
  class StageB1 extends Bundle {
    val carry = new Carry
    val inside = Bool()
    val texture = Vec(2, Vec(sadParts, UInt(DescriptorSad.bits(p.descriptorBytes).W))) // quarter SADs vs flat
    val du = Vec(2, SInt((colW + 2).W))
    val dv = Vec(2, SInt((rowW + 2).W))
    val plane = Vec(2, new Coeffs)
  }
  val (b1Valid, b1) = upStage(new StageB1, bValid) { r =>
    r.carry := b.px.carry
    r.inside := b.px.inside
    for (view <- 0 until 2) {
      r.texture(view) := VecInit(partSads(b.px.carry.refs(view), flat))
      r.du(view) := b.px.u.zext - b.anchor(view).u
      r.dv(view) := b.px.v.zext - b.anchor(view).v.zext
      r.plane(view) := ownerCoeffs(view)
    }
  }
  private val listBlock = 6 // grid entries per block of the list-end search (one LUT6 per block OR)
  private val listBlocks = (S + listBlock - 1) / listBlock
  class StageB2 extends Bundle {
    val carry = new Carry
    val live = Vec(2, Bool()) // inside the margins and textured
    val terms = Vec(2, Vec(3, SInt(termW.W))) // a du, b dv, c
    val priorOn = Vec(2, Bool())
    val negBlock = Vec(2, Vec(listBlocks, Bool())) // some grid entry of block i (entries 6i .. 6i + 5) is -1
  }
  val (b2Valid, b2) = upStage(new StageB2, b1Valid) { r =>
    r.carry := b1.carry
    for (view <- 0 until 2; i <- 0 until listBlocks) {
      r.negBlock(view)(i) := b1.carry.grid(view).slice(listBlock * i, listBlock * (i + 1)).map(_ < 0.S).reduce(_ || _)
    }
    for (view <- 0 until 2) {
      val pl = b1.plane(view)
      r.live(view) := b1.inside && b1.texture(view).reduceTree(_ +& _) >= p.matchTexture.U
      r.terms(view)(0) := pl.a * b1.du(view)
      r.terms(view)(1) := pl.b * b1.dv(view)
      r.terms(view)(2) := pl.c
      r.priorOn(view) := pl.valid
    }
  }
  class StageB3 extends Bundle {
    val carry = new Carry
    val live = Vec(2, Bool())
    val dp = Vec(2, SInt(termW.W)) // the plane's disparity (rounded)
    val priorOn = Vec(2, Bool())
    val listLive = Vec(2, Vec(S, Bool())) // grid entry k comes before the list's first -1
  }
  val (b3Valid, b3) = upStage(new StageB3, b2Valid) { r =>
    r.carry := b2.carry
    r.live := b2.live
    r.priorOn := b2.priorOn
    for (view <- 0 until 2) {
      // entry k is live when no block before its own and no entry of its own block up to k is -1: two LUT levels
      // over registered block ORs (a scan, or even one OR per entry, maps to a chain of LUTs 5-8 deep at S = 40)
      for (k <- 0 until S) {
        val i = k / listBlock
        val before = b2.negBlock(view).take(i)
        val own = b2.carry.grid(view).slice(listBlock * i, k + 1).map(_ < 0.S)
        r.listLive(view)(k) := !(before ++ own).reduce(_ || _)
      }
    }
    for (view <- 0 until 2) {
      val t = b2.terms(view)
      r.dp(view) := (t(2) +& t(0) +& t(1) +& (1 << 15).S) >> 16
    }
  }

  // ---------------------------------------------------------------- stage B4: the plane range
  class StageC extends Bundle {
    val addr = UInt(ringW.W)
    val refs = Vec(2, UInt(descBits.W))
    val live = Vec(2, Bool())
    val reach = Vec(2, SInt((colW + 1).W))
    val grid = Vec(2, Vec(S, SInt(dispW.W)))
    val gridOk = Vec(2, Vec(S, Bool())) // grid entry k is a candidate: before the list's first -1, within reach,
    //                                     and outside the plane range (which evaluates it)
    val lo = Vec(2, UInt(p.signedDispBits.W))
    val hi = Vec(2, UInt(p.signedDispBits.W))
    val empty = Vec(2, Bool())
    val off = Vec(2, SInt(offW.W)) // lo - d_p (in -R..R when the range is not empty)
    val priorOn = Vec(2, Bool())
    val sof = Bool()
    val eol = Bool()
    val eof = Bool()
  }
  // Stage B4 holds B3's pixel as stage C takes it, so the front queue is written from registers (the grid lanes'
  // compares in front of the queue's LUT-RAM were the whole top's critical path at c = 8).
  val (b4Valid, entry) = upStage(new StageC, b3Valid) { entry =>
    entry.addr := b3.carry.addr
    entry.refs := b3.carry.refs
    entry.live := b3.live
    entry.reach := b3.carry.reach
    entry.grid := b3.carry.grid
    for (view <- 0 until 2) {
      // A grid entry du (in 0..D) lies in the plane range [max(d_p - R, 0), min(d_p + R, D)] exactly when
      // |du - d_p| <= R; tested here from B3's registers, so stage C's lanes select a flip-flop (the range's bounds
      // reached every grid lane's compare in C: the whole top's critical path at c = 8). d_p is within R of 0..D
      // only if it lies in -R..D + R, where its low bits are its value.
      val dp = b3.dp(view)
      val dpNear = dp >= (-R).S && dp <= (D + R).S
      val dpLow = dp(log2Ceil(D + R + 1), 0).asSInt
      for (k <- 0 until S) {
        val du = b3.carry.grid(view)(k).asUInt(p.dispBits - 1, 0)
        val e = du.zext -& dpLow
        val inPlaneRange = dpNear && e >= (-R).S && e <= R.S
        entry.gridOk(view)(k) := b3.listLive(view)(k) && du.zext <= b3.carry.reach(view) && !inPlaneRange
      }
    }
    entry.sof := b3.carry.sof
    entry.eol := b3.carry.eol
    entry.eof := b3.carry.eof
    for (view <- 0 until 2) {
      val dp = b3.dp(view)
      val loRaw = dp - R.S
      val hiRaw = dp + R.S
      val lo = Mux(loRaw < 0.S, 0.S, loRaw)
      val hi = Mux(hiRaw > D.S, D.S, hiRaw)
      entry.empty(view) := lo > hi
      entry.lo(view) := lo.asUInt
      entry.hi(view) := hi.asUInt
      entry.off(view) := (lo - dp).asSInt
      entry.priorOn(view) := b3.priorOn(view)
    }
  }

  // The front queue: a pixel that has left stage A waits here for stage C. It never overflows: a pixel leaves A only
  // with a front credit, and the credits count its slots. A memory with a combinational read port (LUT-RAM): C's
  // registers take the entry at the read pointer directly.
  val front = Mem(frontDepth, new StageC)
  val frontWp = RegInit(0.U(log2Ceil(frontDepth).W))
  val frontRp = RegInit(0.U(log2Ceil(frontDepth).W))
  val frontCount = RegInit(0.U(log2Ceil(frontDepth + 1).W))
  when(b4Valid) { front.write(frontWp, entry); frontWp := frontWp + 1.U }
  require((new StageC).getWidth == DenseMatcher.frontEntryBits(p), "DenseMatcher: frontEntryBits is out of date")
  val c = Reg(new StageC)
  when(cLoad) { c := front.read(frontRp); frontRp := frontRp + 1.U }
  frontCount := frontCount + b4Valid.asUInt - cLoad.asUInt
  frontNonEmpty := Mux(b4Valid, true.B, Mux(cLoad, frontCount =/= 1.U, frontNonEmpty))
  assert(frontNonEmpty === (frontCount =/= 0.U), "DenseMatcher: frontNonEmpty differs from the front queue's count")
  assert(!b4Valid || cLoad || frontCount =/= frontDepth.U, "DenseMatcher: the front queue overflows")
  cValid := Mux(creditOk && (!cValid || cLast), frontNonEmpty, cValid)
  // a front credit is taken as a pixel leaves A and comes back as C takes it from the queue
  frontCredits.update(taken = aFire, back = cLoad)

  // ---------------------------------------------------------------- stage C: candidates and their ring reads
  /** Which prior a candidate's cost takes: the table's index travels with the candidate instead of the 14-bit value,
    * and E -> F looks it up beside the SAD's adder tree. */
  class PriorRef extends Bundle {
    val on = Bool() //                          a plane range candidate of a pixel with a plane
    val index = UInt(log2Ceil(R + 1).W) //      |d - d_p|
  }
  /** One candidate lane: grid lanes first (k = 0 until S), then the plane range (lo + i, i = 0..2R). */
  class Cand extends Bundle {
    val valid = Bool()
    val d = UInt(p.dispBits.W)
    val prior = new PriorRef
  }
  class StageD extends Bundle {
    val refs = Vec(2, UInt(descBits.W))
    val live = Vec(2, Bool())
    val cand = Vec(2, Vec(lanes, new Cand))
    val first = Bool() // the pixel's first / last candidate group
    val last = Bool()
    val sof = Bool()
    val eol = Bool()
    val eof = Bool()
  }
  val prior = VecInit(p.priorTable.take(R + 1).map(_.S(costW.W)))
  val candC = (0 until 2).map { view =>
    val lo = c.lo(view)
    val hi = c.hi(view)
    def legal(d: UInt): Bool = d.zext <= c.reach(view)
    val gridCands = (0 until S).map { k =>
      val d = c.grid(view)(k)
      val du = d.asUInt(p.dispBits - 1, 0)
      val x = Wire(new Cand)
      x.valid := c.gridOk(view)(k)
      x.d := du
      x.prior.on := false.B
      x.prior.index := 0.U
      x
    }
    val rangeCands = (0 to 2 * R).map { i =>
      val d = lo +& i.U
      val du = d(p.dispBits - 1, 0)
      val delta = c.off(view) + i.S
      val absDelta = Mux(delta < 0.S, (-delta).asUInt, delta.asUInt)
      val x = Wire(new Cand)
      x.valid := !c.empty(view) && d <= hi && legal(du)
      x.d := du
      x.prior.on := c.priorOn(view)
      x.prior.index := absDelta(log2Ceil(R + 1) - 1, 0)
      x
    }
    val all = gridCands ++ rangeCands
    // lane k evaluates candidate g * lanes + k in group g (candidates beyond the list are never valid)
    (0 until lanes).map { k =>
      val inGroup = (0 until groups).map { g =>
        all.lift(g * lanes + k).getOrElse { val x = Wire(new Cand); x := 0.U.asTypeOf(new Cand); x }
      }
      // a binary multiplexer tree on the group number (a one-hot AND-OR maps to about three times the LUTs)
      if (groups == 1) inGroup.head else VecInit(inGroup.padTo(1 << group.getWidth, inGroup.last))(group)
    }
  }
  // lane k of the left view reads descR(P - d_k), of the right view descL(P + d_k); the reads leave with the pixel
  val targetAddrs = (0 until 2).map { view =>
    (0 until lanes).map { k => if (view == 0) c.addr - candC(view)(k).d else c.addr + candC(view)(k).d }
  }
  val targets = (0 until 2).map { view =>
    // every clock: D keeps the word only when C issues
    (0 until lanes).map(k => (if (view == 0) ringR(k) else ringL(k)).read(targetAddrs(view)(k)))
  }
  val issue = creditOk && cValid // C issues a candidate group into the back half this clock
  val dValid = RegNext(issue, false.B)
  val dReg = Reg(new StageD)
  // No used read meets a write: a right-view target lies between the pixel's position (c.addr) and D positions on,
  // all written (a clock after their slot, before the pixel entered A); the writes since are at most
  // frontQueueDepth + 3 positions beyond, and the ring is deeper than D + frontQueueDepth + 3 (ringDepth). ringR is
  // written a clock after stage B, at most frontQueueDepth + 1 positions after C's pixel and before that pixel reaches
  // C; its valid targets lie at most D behind C's. Reads with a stale address or for an invalid candidate meet writes,
  // unused.
  for (k <- 0 until lanes) {
    CollisionFree.check(s"DenseMatcher: ringL($k)", Seq(ringL(k)),
      Seq(CollisionFree.Read(targetAddrs(1)(k), dValid && dReg.cand(1)(k).valid)),
      Seq(CollisionFree.Write(ringLWrite, ringLCopies(k).addr)))
    CollisionFree.check(s"DenseMatcher: ringR($k)", Seq(ringR(k)),
      Seq(CollisionFree.Read(targetAddrs(0)(k), dValid && dReg.cand(0)(k).valid)),
      Seq(CollisionFree.Write(ringRWrite, ringRCopies(k).addr)))
  }
  when(issue) { group := Mux(cLast, 0.U, group + 1.U) }
  val cLastNext = if (groups > 1) Mux(issue, !cLast && group === (groups - 2).U, cLast) else true.B
  if (groups > 1) cLast := cLastNext
  val creditTaken = issue && cLast
  val creditBack = outQueue.io.deq.fire
  outCredits.update(taken = creditTaken, back = creditBack)
  dReg.refs := c.refs
  dReg.live := c.live
  for (view <- 0 until 2; k <- 0 until lanes) dReg.cand(view)(k) := candC(view)(k)
  dReg.first := group === 0.U
  dReg.last := cLast
  dReg.sof := c.sof
  dReg.eol := c.eol
  dReg.eof := c.eof

  // ---------------------------------------------------------------- stage D: one SAD per candidate lane
  // Stages D..F and the minimum tree move every clock (valid bits mark the issued groups); each register level keeps its logic within a few LUTs:
  // D -> E the SAD (target ring read, 16 byte differences, adder tree), E -> F cost = SAD + prior, then the first
  // minimum over the lanes, two pairwise levels per register, and the running minimum over the groups at the end.
  class Scored extends Bundle {
    val valid = Bool()
    val cost = SInt(costW.W)
    val d = UInt(p.dispBits.W)
  }
  class Tail extends Bundle { // what travels with a pixel's candidate group besides its candidates
    val live = Vec(2, Bool())
    val first = Bool()
    val last = Bool()
    val sof = Bool()
    val eol = Bool()
    val eof = Bool()
  }
  class Sad extends Bundle {
    val valid = Bool()
    val parts = Vec(sadParts, UInt(DescriptorSad.bits(p.descriptorBytes).W)) // SADs of the descriptor's quarters
    val d = UInt(p.dispBits.W)
    val prior = new PriorRef
  }
  def tailOf(x: StageD): Tail = {
    val t = Wire(new Tail)
    t.live := x.live; t.first := x.first; t.last := x.last; t.sof := x.sof; t.eol := x.eol; t.eof := x.eof
    t
  }
  val eValid = RegInit(false.B)
  val eTail = Reg(new Tail)
  val eSad = Reg(Vec(2, Vec(lanes, new Sad)))
  // D -> D2 -> D3 -> E: the ring data (D2), the byte differences (D3), the quarter SADs (E). A LUT-RAM ring reads
  // combinationally from its address register; Yosys takes a block-RAM ring's data register (D2) into the block as
  // its read register. The byte subtracts fit after that read, so the adder tree starts from D3's registers: 9 bits a
  // byte, fewer flip-flops than the two descriptors whose difference they hold.
  val d2Valid = RegNext(dValid, false.B)
  val d2 = Reg(new StageD)
  val d2Targets = Reg(Vec(2, Vec(lanes, UInt(descBits.W))))
  d2 := dReg
  for (view <- 0 until 2; k <- 0 until lanes) d2Targets(view)(k) := targets(view)(k)
  // the references once per pair of lanes: one register set beside two lanes' subtracts instead of one net to every
  // lane (loaded only for a valid candidate of the pair, whose SAD alone is used: the enables differ, so synthesis
  // keeps the copies apart). One set per lane would hold 64 flip-flops a lane more.
  val d2Refs = Reg(Vec(2, Vec((lanes + 1) / 2, UInt(descBits.W))))
  for (view <- 0 until 2; j <- 0 until (lanes + 1) / 2) {
    val pair = dReg.cand(view).slice(2 * j, 2 * j + 2)
    when(pair.map(_.valid).reduce(_ || _)) { d2Refs(view)(j) := dReg.refs(view) }
  }
  // each lane's quarter SADs: the byte differences into D3, their magnitudes' sums into E (added with the prior in F)
  val d3Valid = RegNext(d2Valid, false.B)
  val d3 = RegNext(d2)
  val d3Differences = Reg(Vec(2, Vec(lanes, Vec(sadParts, UInt((9 * partBytes).W)))))
  for (view <- 0 until 2; k <- 0 until lanes; part <- 0 until sadParts) {
    val u = Module(new ByteDifferences(partBytes))
    u.io.x := quarter(d2Targets(view)(k), part) // the ring's data as the minuend: the subtrahend's inversion (a LUT
    u.io.y := quarter(d2Refs(view)(k / 2), part) // on the ECP5) then sits on the register side, not after the read
    d3Differences(view)(k)(part) := u.io.diffs
  }
  def quarterSad(diffs: UInt): UInt = {
    val u = Module(new DifferencesSad(partBytes))
    u.io.diffs := diffs
    u.io.sad
  }
  eValid := d3Valid
  eTail := tailOf(d3)
  for (view <- 0 until 2; k <- 0 until lanes) {
    val x = d3.cand(view)(k)
    eSad(view)(k).valid := x.valid
    eSad(view)(k).d := x.d
    eSad(view)(k).prior := x.prior
    for (h <- 0 until sadParts) eSad(view)(k).parts(h) := quarterSad(d3Differences(view)(k)(h))
  }
  val fValid = RegInit(false.B)
  val fTail = Reg(new Tail)
  val fCand = Reg(Vec(2, Vec(lanes, new Scored)))
  fValid := eValid
  fTail := eTail
  for (view <- 0 until 2; k <- 0 until lanes) {
    val x = eSad(view)(k)
    fCand(view)(k).valid := x.valid
    fCand(view)(k).d := x.d
    fCand(view)(k).cost := x.parts.reduceTree(_ +& _)(DescriptorSad.bits(p.descriptorBytes) - 1, 0).zext +
      Mux(x.prior.on, prior(x.prior.index), 0.S)
  }

  // ---------------------------------------------------------------- the first minimum
  /** The first of the minimum costs in evaluation order (strict "<": a later candidate wins only if cheaper). */
  def firstOf(x: Scored, y: Scored): Scored = Mux(y.valid && (!x.valid || y.cost < x.cost), y, x)
  def firstMin(xs: Seq[Scored]): Scored =
    if (xs.length == 1) xs.head
    else {
      val (l, r) = xs.splitAt(xs.length / 2)
      firstOf(firstMin(l), firstMin(r))
    }
  // Registered levels of the tree: contiguous blocks of lanes keep the candidate order, so the first minimum of the
  // blocks' first minima is the first minimum of all. The last level leaves at most 2 values (groups = 1) or one
  // (groups > 1: its compare with the earlier groups' minimum closes the loop through bestSoFar on its own).
  var treeValid: Bool = fValid
  var treeTail: Tail = fTail
  var tree: Seq[Seq[Scored]] = fCand.map(_.toSeq)
  while (tree.head.length > DenseMatcher.treeKeep(p)) {
    val reduced = tree.map(_.grouped(DenseMatcher.treeArity(p)).map(firstMin).toSeq)
    val v = RegInit(false.B)
    val t = Reg(new Tail)
    val r = Reg(Vec(2, Vec(reduced.head.length, new Scored)))
    v := treeValid
    t := treeTail
    for (view <- 0 until 2; k <- reduced.head.indices) r(view)(k) := reduced(view)(k)
    treeValid = v; treeTail = t; tree = r.map(_.toSeq)
  }
  val bestSoFar = Reg(Vec(2, new Scored)) // over the pixel's earlier candidate groups
  val result = (0 until 2).map { view =>
    val groupBest = firstMin(tree(view))
    val best = if (groups == 1) groupBest else Mux(treeTail.first, groupBest, firstOf(bestSoFar(view), groupBest))
    when(treeValid) { bestSoFar(view) := best }
    Mux(treeTail.live(view) && best.valid, best.d.zext, (-1).S(dispW.W))
  }

  // the credits guarantee the queue's room (enq.ready is true whenever a result arrives)
  assert(!outQueue.io.enq.valid || outQueue.io.enq.ready, "dense output queue overflow (credit count)")
  outQueue.io.enq.valid := treeValid && treeTail.last
  outQueue.io.enq.bits.data.left := result(0)
  outQueue.io.enq.bits.data.right := result(1)
  outQueue.io.enq.bits.sof := treeTail.sof
  outQueue.io.enq.bits.eol := treeTail.eol
  outQueue.io.enq.bits.eof := treeTail.eof
}

object DenseMatcher {
  /** Slots of the front queue between stage B4 and stage C, and the front credits: at least the clocks from a pixel
    * leaving stage A to its credit's return (A1..B4, the queue's write, C's load: 10), so the front half runs at one
    * pixel per clock; 16, one LUT-RAM deep. */
  val frontQueueDepth: Int = 16

  /** Ring depth: a power of two of more than dispMax + frontQueueDepth + 3 entries. Between the pixel in stage C and
    * the next pixel to enter stage A there are at most frontQueueDepth + 1 pixels (the front credits, and A), and the
    * stream is dispMax positions ahead of that next pixel: the right view's targets (C's position + 0..dispMax) must
    * not be overwritten, nor the left view's (C's position - dispMax..0) by stage B's writes.
    */
  def ringDepth(p: ElasParams): Int = 1 << log2Ceil(p.dispMax + frontQueueDepth + 4)

  /** Values the first-minimum tree's last register level leaves per view: 2 (one candidate group per pixel: the
    * last compare-select feeds the output queue) or 1 (several groups: the running minimum over the groups then takes
    * one compare per clock).
    */
  def treeKeep(p: ElasParams): Int = if (p.denseGroups == 1) 2 else 1

  /** Lanes a register level of the tree reduces to one: 2, one compare-select per clock. Arity 4 (two compare-selects
    * per level, 7-8 LUT levels on the 7-series with Yosys 0.23) held the dense matcher at `small` to 63 MHz on the
    * ECP5, where its lanes spread over every block RAM of the part; at 25 lanes arity 2 costs 17 more registered
    * (d, cost) pairs per view.
    */
  def treeArity(p: ElasParams): Int = 2

  /** Registered levels of the first-minimum tree: each reduces blocks of treeArity lanes until treeKeep are left. */
  /** Register steps from stage C's issue to the output queue's write: D, D2, D3, E, F and the tree's levels. */
  def backStages(p: ElasParams): Int = 5 + treeRegisters(p)

  def treeRegisters(p: ElasParams): Int = Iterator.iterate(p.denseLanesUsed)(n => (n + treeArity(p) - 1) / treeArity(p))
    .takeWhile(_ > treeKeep(p)).length

  /** The read address of a pipeline stage's memory entry, read one cycle ahead: when `enter`, the entry at `addr`
    * enters the stage; otherwise the stage keeps its entry and the read repeats its address (the memories are written
    * only when the pipeline moves, so the repeated read returns the same data, and no output register is needed).
    */
  def stageAddress(addr: UInt, enter: Bool): UInt = Mux(enter, addr, RegEnable(addr, enter))

  /** floor(n / d) for a constant d and n < 2^bits, as a multiply by a rounded-up reciprocal (exact for
    * s = bits + ceil(log2 d): the error n (M d - 2^s) / (d 2^s) stays below 1/d).
    */
  def divConst(n: UInt, d: Int, bits: Int): UInt = {
    val s = bits + log2Ceil(d)
    val mul = (BigInt(1) << s) / d + 1
    ((n(bits - 1, 0) * mul.U) >> s).asUInt
  }
  /** Raster window cells: cu - 1 .. cu + ceil(dispMax / step). */
  def rasterCells(p: ElasParams): Int = 2 + (p.dispMax + p.candidateStep - 1) / p.candidateStep
  /** Bits of a scaled cut point (|x - s| * h <= max(maxWidth, dispMax) * step), signed. */
  def spanBits(p: ElasParams): Int = log2Ceil(math.max(p.maxWidth, p.dispMax + 1) * p.candidateStep + 1) + 2
  def gridCellBits(p: ElasParams): Int = 2 * p.storedDisparities * p.signedDispBits
  /** Bits of a front queue entry (stage C's registers): ring address, both references, and per view the live flag,
    * reach, grid list and its candidate flags, plane range (lo, hi, empty, offset) and prior flag; sof, eol, eof. */
  def frontEntryBits(p: ElasParams): Int = {
    val offBits = log2Ceil(3 * p.planeRadius + 1) + 2
    log2Ceil(ringDepth(p)) + 2 * 8 * p.descriptorBytes + 3 +
      2 * (1 + p.colBits + 1 + p.storedDisparities * (p.signedDispBits + 1) + 2 * p.signedDispBits + 1 + offBits + 1)
  }
  /** Cycles a frame costs beyond its pixels: the flush, the pipeline registers (A1..B4 and the front queue among
    * them), the drain after the flush (A1..B4, the queue, C's groups and the drain's register), and the first row's
    * planes and primer (K - 1 cells and its register step, after the frame size's two register steps) when they have
    * not arrived during the first dispMax steps.
    */
  def cycleSlack(p: ElasParams): Int =
    p.dispMax + 6 + (p.latticeColsMax - 1) + rasterCells(p) + 6 + 8 + 4 + treeRegisters(p) + 11 + p.denseGroups

  def memorySummary(p: ElasParams): Seq[MemoryUse] = Seq(
    MemoryUse("Dense", "cornerBanks", p.latticeColsMax - 1, 2 * 4 * p.dispBits,
      "2 cell rows of the cells' corner disparities, Mem with 2 combinational read ports (primer, window shift)"),
    MemoryUse("Dense", "anchorBanks", p.latticeColsMax - 1, 2 * 2 * 2 * (p.colBits + 1 + p.rowBits),
      "2 views x 2 cell rows of both triangles' plane anchors, Mem with 1 combinational read port (stage A3)"),
    MemoryUse("Dense", "coeffBanks", p.latticeColsMax - 1, 2 * 2 * 2 * (3 * 32 + 1),
      "2 views x 2 cell rows of both triangles' plane coefficients, Mem with 1 combinational read port (stage B)"),
    MemoryUse("Dense", "gridBanks", p.gridColsMax, 2 * gridCellBits(p),
      "2 grid rows of both views' candidates, Mem with 1 combinational read port"),
    MemoryUse("Dense", "refRing", ringDepth(p), 2 * 8 * p.descriptorBytes,
      "both views' descriptors of the last ringDepth stream positions, SyncReadMem 1R1W (the references)"),
    MemoryUse("Dense", "targetRings", ringDepth(p), 2 * p.denseCandidates * 8 * p.descriptorBytes,
      "descL by stream position and descR by stage-B pixel, one SyncReadMem 1R1W replica per candidate lane and view"),
    MemoryUse("Dense", "frontQueue", frontQueueDepth, frontEntryBits(p),
      "pixels between stage B3 and stage C (addresses, references, candidate lists, plane range), Mem 1R1W with a " +
      "combinational read port (LUT-RAM)"),
    MemoryUse("Dense", "raster", 2 * rasterCells(p), 1 + 4 * spanBits(p),
      "registers: raster window and the next row's shadow")
  )
}
