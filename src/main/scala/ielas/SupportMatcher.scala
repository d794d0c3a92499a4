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
  * Search (per active node, one sweep per reference view over d = 0..dhi): the target columns t - r of the sweep
  * are c1 = minC1 .. maxC1 (left reference u: c1 = u - r - d; right reference u': c1 = u' - r + d), each with its
  * partner c1 + 2r. The sweep reads the blocks from the one holding maxC1 + 2r down to the one holding minC1; lane
  * k evaluates c1 = jL + k against the partner in the same block or in the block read the cycle before (its first
  * 2r columns are kept). The reference columns u ± r are read from the reference view before the sweep (one or two
  * cycles) and kept in registers. A node costs at most 5 + two sweeps of ceil((dhi + 2r) / L) + 1 blocks
  * (ElasParams.supportNodeCycles), within supportCyclesPerPoint = cyclesPerPixel x step^2 at every configuration.
  * Best/second best are merged over lanes in ascending d with strict "<" on the left operand, which equals the
  * sequential definition (E1 min, d1 its smallest d, E2 the second smallest of the multiset).
  *
  * Back-pressure: the input stalls only when a slot is still being searched (or a new frame arrives while the
  * previous one is still being searched); the output register stalls the walker. Any gaps are fine.
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
  private val colW = math.max(p.colBits, p.dispBits + 1) + 2 // signed column arithmetic (window starts may be < 0)
  private val rowW = p.rowBits + 1
  private val baseW = p.dispBits + 2
  private val firstRow = (margin + step - 1) / step * step // first lattice row that can hold supports

  private def sad(x: UInt, y: UInt): UInt = {
    val unit = Module(new DescriptorSad(p.descriptorBytes))
    unit.io.x := x
    unit.io.y := y
    unit.io.sad
  }

  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(new DescriptorPair(p.descriptorBytes))))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val out = Decoupled(new Framed(SInt((p.dispBits + 1).W)))
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

  // The slot of lattice row v is free once the walker has left lattice row v - slots*step.
  val topSlotFree = walkV +& (slots * step).U > topRow.v
  val startFrame = io.in.valid && io.in.bits.sof && !capBusy && !walkBusy
  io.in.ready := Mux(capBusy, !topRow.hit || topSlotFree, !io.in.bits.sof || !walkBusy)
  val capture = io.in.fire && capBusy

  when(startFrame) {
    width := io.frameWidth
    height := io.frameHeight
    capBusy := true.B
    walkBusy := true.B
    // the start-of-frame beat is pixel (0, 0): no lattice row needs pixel row 0, so only the counters move
    capX := 1.U
    capY := 0.U
    Seq(topRow, centreRow, bottomRow).foreach(_.restart())
  }
  val endOfLine = capX === width - 1.U
  when(capture) {
    capX := Mux(endOfLine, 0.U, capX + 1.U)
    when(endOfLine) {
      capY := capY + 1.U
      when(capY === height - 1.U) { capBusy := false.B }
      Seq(topRow, centreRow, bottomRow).foreach(t => when(t.rowIs) { t.advance() })
    }
  }

  def slotBase(slot: UInt, perSlot: Int): UInt =
    VecInit((0 until slots).map(s => (s * perSlot).U(log2Ceil(slots * perSlot + 1).W)))(slot)

  /** Row memory address: view * slots * words + slot * words + word (word < words always holds). */
  private val viewWords = slots * wordsPerRow
  def rowAddress(view: UInt, slot: UInt, word: UInt): UInt =
    (Mux(view.asBool, viewWords.U, 0.U) +& slotBase(slot, wordsPerRow) +& word)(log2Ceil(2 * viewWords) - 1, 0)
  def texAddress(slot: UInt, col: UInt): UInt =
    (slotBase(slot, p.maxWidth) +& col)(log2Ceil(slots * p.maxWidth) - 1, 0)

  /** Descriptor row memories: (row kind 0 = v - r, 1 = v + r)(bank), the right view's words after the left's: a
    * sweep reads one view at a time, so sharing the read port halves the block RAMs (they are read-width bound).
    */
  val rowMem = Seq.fill(2, banks)(SyncReadMem(2 * viewWords, UInt(descBits.W)))
  val texMem = SyncReadMem(slots * p.maxWidth, UInt(2.W)) // bit 0 left, bit 1 right: texture >= supportTexture

  val capBank = capX(bankBits - 1, 0)
  val capWord = capX >> bankBits
  // The left word is written with the pixel, the right word one cycle later: that bank's next write is `banks`
  // columns away, and a kind's captured rows are step >= 2 pixel rows apart, so the two never meet.
  for ((tracker, kind) <- Seq(topRow, bottomRow).zipWithIndex) {
    val hit = capture && tracker.hit
    val rightPending = RegNext(hit, false.B)
    val rightBank = RegNext(capBank)
    val rightAddr = RegNext(rowAddress(1.U, tracker.slot, capWord))
    val rightData = RegNext(io.in.bits.data.right)
    val leftAddr = rowAddress(0.U, tracker.slot, capWord)
    for (b <- 0 until banks) { // one write port per memory
      val writeLeft = hit && capBank === b.U
      when(writeLeft || rightPending && rightBank === b.U) {
        rowMem(kind)(b).write(Mux(writeLeft, leftAddr, rightAddr), Mux(writeLeft, io.in.bits.data.left, rightData))
      }
    }
  }
  when(capture && centreRow.hit) {
    val tex = Cat(SupportMatcher.texture(io.in.bits.data.right) >= p.supportTexture.U,
      SupportMatcher.texture(io.in.bits.data.left) >= p.supportTexture.U)
    texMem.write(texAddress(centreRow.slot, capX), tex)
  }

  // ---- walker: every lattice node in raster order ----
  val sIdle :: sNode :: sRefHi :: sSweep :: sDecide :: Nil = Enum(5)
  val state = RegInit(sIdle)
  val phaseLeft = RegInit(true.B) // sweeping with the left view as reference
  val uRef = RegInit(0.U(p.colBits.W)) // reference column of the current sweep
  val dLeft = RegInit(0.U(p.dispBits.W))

  val rowActive = walkV >= margin.U && walkV +& margin.U < height
  val nodeActive = rowActive && walkU >= margin.U && walkU +& margin.U < width
  val rowReady = !rowActive || bottomRow.v > walkV // both descriptor rows of this lattice row are in

  // ---- block reads: word j of every bank is the aligned block of columns jL .. jL + L - 1, lane k = bank k ----
  val blockW = log2Ceil(wordsPerRow + 1)
  def blockOf(col: UInt): UInt = (col >> bankBits)(blockW - 1, 0)
  val j = RegInit(0.U(blockW.W)) //   block the sweep reads this cycle (the sweep runs from jHi down to jLo)
  val jLo = RegInit(0.U(blockW.W))
  val sweepStart = RegInit(false.B) // the sweep's first block (its s1 result starts the running best)
  val minC1 = RegInit(0.U(colW.W)) // target columns t - r of the sweep's disparities: minC1 .. minC1 + dhi
  val maxC1 = RegInit(0.U(colW.W))
  val dRight = Wire(UInt(p.dispBits.W)) // the left sweep's decision, which sets the right sweep's reference column
  val uRight = uRef - dRight
  // One read per bank and cycle: the reference view's block of uRef - r in the cycle before a sweep (sNode, or
  // sDecide before the right sweep), its block of uRef + r (sRefHi, skipped when it is the same block), then the
  // target view's blocks j.
  val refLoWord = Mux(state === sNode, blockOf(walkU - r.U), blockOf(uRight - r.U))
  val readView = Mux(state === sNode || state === sRefHi, !phaseLeft && state === sRefHi,
    Mux(state === sSweep, phaseLeft, true.B)) // sDecide: the right view's reference (only used after the left sweep)
  val readWord = Mux(state === sSweep, j, Mux(state === sRefHi, blockOf(uRef + r.U), refLoWord))
  val data = (0 until 2).map(kind => (0 until banks).map(b => rowMem(kind)(b).read(rowAddress(readView, walkSlot, readWord))))
  val texBits = texMem.read(texAddress(walkSlot, uRef))

  // ---- the sweep's reference descriptors (columns uRef - r and uRef + r), kept in registers ----
  def column(data: Seq[UInt], col: UInt): UInt = Mux1H(data.indices.map(b => col(bankBits - 1, 0) === b.U), data)
  val loRead = RegInit(false.B) // the data of this cycle holds column uRef - r (and uRef + r when hiRead)
  val hiRead = RegInit(false.B)
  loRead := false.B
  hiRead := state === sRefHi
  val refLo = Reg(Vec(2, UInt(descBits.W)))
  val refHi = Reg(Vec(2, UInt(descBits.W)))
  when(loRead) { for (kind <- 0 until 2) refLo(kind) := column(data(kind), uRef - r.U) }
  when(hiRead) { for (kind <- 0 until 2) refHi(kind) := column(data(kind), uRef + r.U) }
  /** Starts a sweep with reference column u: its reference reads are under way (one more cycle when u ± r lie in
    * two blocks).
    */
  def startSweep(u: UInt): Unit = {
    val oneBlock = blockOf(u - r.U) === blockOf(u + r.U)
    loRead := true.B
    hiRead := oneBlock
    sweepStart := true.B
    state := Mux(oneBlock, sSweep, sRefHi)
  }
  val tgtView = data

  // ---- s1: costs of the block read last cycle, merged into the running best / second best ----
  val issue = state === sSweep
  val s1Valid = RegNext(issue, false.B)
  val s1Left = RegNext(phaseLeft)
  val s1Block = RegNext(j)
  val s1MinC1 = RegNext(minC1)
  val s1MaxC1 = RegNext(maxC1)
  val s1First = RegNext(sweepStart)
  // columns 0 .. 2r - 1 of the block read the cycle before (block j + 1): the partners of the top 2r lanes
  val prevBlock = tgtView.map(cols => RegNext(VecInit(cols.take(2 * r).toSeq)))

  class Best extends Bundle {
    val e1 = UInt(costBits.W)
    val d1 = UInt(baseW.W)
    val e2 = UInt(costBits.W)
  }
  def best(e1: UInt, d1: UInt, e2: UInt): Best = {
    val b = Wire(new Best); b.e1 := e1; b.d1 := d1; b.e2 := e2; b
  }
  /** `a` covers smaller disparities than `b`: a strict "<" keeps a's d on ties, and a tie makes E2 = E1. */
  def merge(a: Best, b: Best): Best = {
    val bWins = b.e1 < a.e1
    best(Mux(bWins, b.e1, a.e1), Mux(bWins, b.d1, a.d1),
      Mux(bWins, SupportMatcher.min(a.e1, b.e2), SupportMatcher.min(a.e2, b.e1)))
  }
  def tree(xs: Seq[Best]): Best = if (xs.length == 1) xs.head else {
    val (lo, hi) = xs.splitAt(xs.length / 2)
    merge(tree(lo), tree(hi))
  }

  // lane k evaluates target column c1 = jL + k (and its partner c1 + 2r, in this block or the one above):
  // left sweep d = maxC1 - c1 (the reference is u - r), right sweep d = c1 - minC1 (the reference is uRight - r)
  val laneBest = (0 until lanes).map { k =>
    val cost = (0 until 2).map { kind =>
      val cur = tgtView(kind)
      val partner = if (k + 2 * r < banks) cur(k + 2 * r) else prevBlock(kind)(k + 2 * r - banks)
      sad(refLo(kind), cur(k)) +& sad(refHi(kind), partner)
    }.reduce(_ +& _)
    val c1 = Cat(s1Block, k.U(bankBits.W))
    val inSweep = c1 >= s1MinC1 && c1 <= s1MaxC1
    val d = Mux(s1Left, s1MaxC1 - c1, c1 - s1MinC1)(baseW - 1, 0)
    best(Mux(inSweep, cost, costInf), d, costInf)
  }
  // ascending d: lanes in reverse order for the left sweep; each later block holds higher d (left) or lower (right)
  val blockBest = tree(laneBest.indices.map(k => Mux(s1Left, laneBest(lanes - 1 - k), laneBest(k))))
  val running = Reg(new Best)
  val merged = Mux(s1First, blockBest, Mux(s1Left, merge(running, blockBest), merge(blockBest, running)))
  when(s1Valid) { running := merged }
  val final_ = Mux(s1Valid, merged, running)
  dRight := final_.d1(p.dispBits - 1, 0)

  // ---- output register ----
  val outValid = RegInit(false.B)
  val outBits = Reg(new Framed(SInt((p.dispBits + 1).W)))
  val outFree = !outValid || io.out.ready
  when(io.out.fire) { outValid := false.B }
  io.out.valid := outValid
  io.out.bits := outBits

  /** Emits the current node (when the output register is free) and moves to the next one. */
  def emit(value: SInt): Unit = when(outFree) {
    val eol = walkU === width - 1.U
    val eof = eol && walkV === height - 1.U
    outValid := true.B
    outBits.data := value
    outBits.sof := walkU === 0.U && walkV === 0.U
    outBits.eol := eol
    outBits.eof := eof
    state := sNode
    when(eol) {
      walkU := 0.U
      walkV := Mux(walkV +& step.U < height, walkV + step.U, height - 1.U)
      walkSlot := Mux(walkSlot === (slots - 1).U, 0.U, walkSlot + 1.U)
      when(eof) { state := sIdle; walkBusy := false.B }
    }.otherwise {
      walkU := Mux(walkU +& step.U < width, walkU + step.U, width - 1.U)
    }
  }
  val none = (-1).S((p.dispBits + 1).W)
  def dispMin(a: UInt): UInt = Mux(a > p.dispMax.U, p.dispMax.U, a)

  switch(state) {
    is(sIdle) {
      when(startFrame) {
        walkU := 0.U; walkV := 0.U; walkSlot := 0.U
        state := sNode
      }
    }
    is(sNode) {
      val dhiL = dispMin(walkU - margin.U)
      when(!nodeActive || dhiL < p.supportMinRange.U) {
        when(rowReady) { emit(none) }
      }.elsewhen(rowReady) {
        phaseLeft := true.B; uRef := walkU
        startSweep(walkU)
        minC1 := walkU - r.U - dhiL
        maxC1 := walkU - r.U
        j := blockOf(walkU + r.U)
        jLo := blockOf(walkU - r.U - dhiL)
      }
    }
    is(sRefHi) { state := sSweep }
    is(sSweep) {
      sweepStart := false.B
      j := j - 1.U
      when(j === jLo) { state := sDecide }
    }
    is(sDecide) {
      val texOk = Mux(phaseLeft, texBits(0), texBits(1))
      val accept = texOk && (final_.e1 * 100.U) < (final_.e2 * p.supportThresholdPercent.U)
      val d1 = final_.d1(p.dispBits - 1, 0)
      when(phaseLeft) {
        val dhiR = dispMin(width - (1 + margin).U - uRight)
        when(!accept || dhiR < p.supportMinRange.U) {
          emit(none)
        }.otherwise {
          dLeft := d1; uRef := uRight; phaseLeft := false.B
          startSweep(uRight)
          minC1 := uRight - r.U
          maxC1 := uRight - r.U + dhiR
          j := blockOf(uRight + r.U + dhiR)
          jLo := blockOf(uRight - r.U)
        }
      }.otherwise {
        val diff = Mux(dLeft > d1, dLeft - d1, d1 - dLeft)
        emit(Mux(accept && diff <= p.lrThreshold.U, dLeft.zext, none))
      }
    }
  }
}

object SupportMatcher {
  /** Lattice rows whose descriptor rows are buffered at once (see the class doc). */
  def slots(p: ElasParams): Int = (2 to 64).find(k => (k - 1) * p.candidateStep >= 2 * p.windowRadius + 1).get

  /** Column-interleaved banks, one per lane (lane k always reads bank k): ElasParams.supportLanesUsed, a power of
    * two above 2r.
    */
  def banks(p: ElasParams): Int = p.supportLanesUsed

  def wordsPerRow(p: ElasParams): Int = (p.maxWidth + banks(p) - 1) / banks(p)

  /** Bits of a cost: 4 descriptors x 16 bytes x 255, plus room for the "no disparity" value above it. */
  def costBits(p: ElasParams): Int = log2Ceil(4 * p.descriptorBytes * 255 + 2)

  /** Cycles of the search for one active node with left/right ranges dhiL/dhiR at the worst block alignment: node
    * start, per sweep a second reference read, its blocks and a decision cycle (ElasParams.supportNodeCycles).
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
      s"2 views x ${slots(p)} slots x rows v-r, v+r, ${banks(p)} banks of SyncReadMem 1R1W (both views per bank)"),
    MemoryUse("Support", "texture", slots(p) * p.maxWidth, 2, s"${slots(p)} slots x 2 views, SyncReadMem 1R1W")
  )
}

/** Ports of the stage-test chains that end in a lattice stream: pixel pairs in, lattice values out. */
class LatticeChainIO(p: ElasParams) extends Bundle {
  val in = Flipped(Decoupled(new PixelPair))
  val frameWidth = Input(UInt(p.colBits.W))
  val frameHeight = Input(UInt(p.rowBits.W))
  val out = Decoupled(new Framed(SInt((p.dispBits + 1).W)))
}

/** A stage-test chain from pixel pairs to a lattice stream. */
abstract class LatticeChain(p: ElasParams) extends Module {
  val io = IO(new LatticeChainIO(p))
}

/** Stage-test chain: pixel input -> [[Descriptor]] -> [[SupportMatcher]] (frame size ports shared by both). */
class SupportChain(p: ElasParams) extends LatticeChain(p) {
  val descriptor = Module(new Descriptor(p))
  val matcher = Module(new SupportMatcher(p))
  descriptor.io.in <> io.in
  descriptor.io.frameWidth := io.frameWidth
  descriptor.io.frameHeight := io.frameHeight
  matcher.io.in <> descriptor.io.out
  matcher.io.frameWidth := io.frameWidth
  matcher.io.frameHeight := io.frameHeight
  io.out <> matcher.io.out
}
