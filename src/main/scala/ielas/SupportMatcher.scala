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
  val sIdle :: sNode :: sSweep :: sWait :: Nil = Enum(4)
  val state = RegInit(sIdle)
  val phaseLeft = RegInit(true.B) // sweeping with the left view as reference
  val uRef = RegInit(0.U(p.colBits.W)) // reference column of the current sweep
  val refC0 = RegInit(0.U(colW.W)) //     uRef - r: the reference window's first column

  val rowActive = walkV >= margin.U && walkV +& margin.U < height
  val nodeActive = rowActive && walkU >= margin.U && walkU +& margin.U < width
  val rowReady = !rowActive || bottomRow.v > walkV // both descriptor rows of this lattice row are in
  // per frame: the last column t - r (maxC1) a right sweep may reach, W - 1 - margin - r (width is held all frame)
  val rightLimit = RegNext(width - (1 + margin + r).U)

  // ---- reads: word j of every bank is the aligned block of columns jL .. jL + L - 1, lane k = bank k ----
  val blockW = log2Ceil(wordsPerRow + 1)
  def blockOf(col: UInt): UInt = (col >> bankBits)(blockW - 1, 0)
  val j = RegInit(0.U(blockW.W)) //   block the sweep reads this cycle (the sweep runs from j down to jLo)
  val jLo = RegInit(0.U(blockW.W))
  val sweepStart = RegInit(false.B) // the sweep's first block (its result starts the running best)
  val minC1 = RegInit(0.U(colW.W)) // target columns t - r of the sweep's disparities: minC1 .. maxC1
  val maxC1 = RegInit(0.U(colW.W))
  // One read per bank and cycle. A reference read fetches the L consecutive columns from c0 = u - r on (banks below
  // c0 mod L read the next word), so u - r and u + r (2r < L) arrive together; a sweep reads the aligned block j.
  val readView = WireDefault(phaseLeft) // sweep: the target view (the right one for the left sweep)
  val readWord = WireDefault(j)
  val readSplit = WireDefault(0.U(bankBits.W))
  val loRead = RegInit(false.B) // the data of this cycle is a reference read
  loRead := false.B
  def readReference(view: Bool, c0: UInt): Unit = {
    readView := view
    readWord := blockOf(c0)
    readSplit := c0(bankBits - 1, 0)
    refC0 := c0
    loRead := true.B
  }
  val data = (0 until 2).map(kind => (0 until banks).map { b =>
    val word = readWord +& (b.U < readSplit).asUInt
    rowMem(kind)(b).read(rowAddress(readView, walkSlot, word(blockW - 1, 0)))
  })
  val texBits = texMem.read(texAddress(walkSlot, uRef))

  // ---- the sweep's reference descriptors (columns c0 and c0 + 2r of the reference read), kept in registers ----
  def column(data: Seq[UInt], col: UInt): UInt = Mux1H(data.indices.map(b => col(bankBits - 1, 0) === b.U), data)
  val refLo = Reg(Vec(2, UInt(descBits.W)))
  val refHi = Reg(Vec(2, UInt(descBits.W)))
  when(loRead) {
    for (kind <- 0 until 2) {
      refLo(kind) := column(data(kind), refC0)
      refHi(kind) := column(data(kind), refC0 + (2 * r).U)
    }
  }

  // ---- search pipeline: issue (read) -> A: SADs -> B: lane costs, first merge levels -> C: block best ->
  // merge into the running best. A sweep's result is final 4 cycles after its last block is issued. ----
  class Tag extends Bundle {
    val left = Bool() //  the block belongs to a left sweep
    val first = Bool() // the sweep's first block
    val last = Bool() //  the sweep's last block
  }
  val hold = WireDefault(false.B) // the right sweep's last block waits for the previous node's decision
  val issue = state === sSweep && !hold
  val tag = Wire(new Tag)
  tag.left := phaseLeft; tag.first := sweepStart; tag.last := j === jLo
  val s0Valid = RegNext(issue, false.B)
  val s0Tag = RegNext(tag)
  val s0Block = RegNext(j)
  val s0MinC1 = RegNext(minC1)
  val s0MaxC1 = RegNext(maxC1)
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
  /** Merges two results; `bFirst` says b holds the smaller disparities: the smaller d wins a tie (first minimum), and a
    * tie makes E2 = E1.
    */
  def merge(a: Best, b: Best, bFirst: Bool): Best = {
    val bWins = Mux(bFirst, b.e1 <= a.e1, b.e1 < a.e1)
    best(Mux(bWins, b.e1, a.e1), Mux(bWins, b.d1, a.d1),
      Mux(bWins, SupportMatcher.min(a.e1, b.e2), SupportMatcher.min(a.e2, b.e1)))
  }
  /** One level of the lane tree: neighbours k, k + 1 (lane k + 1 holds the smaller d in a left sweep). */
  def treeLevel(xs: Seq[Best], left: Bool): Seq[Best] = xs.grouped(2).map(g => merge(g(0), g(1), left)).toSeq

  // A: the four SADs per lane (lane k: target column c1 = jL + k and its partner c1 + 2r, in this block or the one
  // issued before), whether c1 is in the sweep and its d (left sweep d = maxC1 - c1, right d = c1 - minC1)
  val aValid = RegNext(s0Valid, false.B)
  val aTag = RegEnable(s0Tag, s0Valid)
  val aSad = (0 until lanes).map { k =>
    RegEnable(VecInit((0 until 2).flatMap { kind =>
      val cur = data(kind)
      val partner = if (k + 2 * r < banks) cur(k + 2 * r) else prevBlock(kind)(k + 2 * r - banks)
      Seq(sad(refLo(kind), cur(k)), sad(refHi(kind), partner))
    }), s0Valid)
  }
  val aLane = (0 until lanes).map { k =>
    val c1 = Cat(s0Block, k.U(bankBits.W))
    val inSweep = c1 >= s0MinC1 && c1 <= s0MaxC1
    val d = Mux(s0Tag.left, s0MaxC1 - c1, c1 - s0MinC1)(baseW - 1, 0)
    (RegEnable(inSweep, s0Valid), RegEnable(d, s0Valid))
  }
  // B: lane costs and the first levels of the lane tree (ascending lanes, ties to the smaller d)
  private val treeLevels = log2Ceil(lanes)
  private val levelsB = treeLevels / 2
  val laneBest = aSad.zip(aLane).map { case (sads, (inSweep, d)) =>
    best(Mux(inSweep, SupportMatcher.sumTree(sads), costInf), d, costInf)
  }
  val bValid = RegNext(aValid, false.B)
  val bTag = RegEnable(aTag, aValid)
  val bBest = (0 until levelsB).foldLeft(laneBest: Seq[Best])((xs, _) => treeLevel(xs, aTag.left)).map(RegEnable(_, aValid))
  // C: the rest of the tree
  val cValid = RegNext(bValid, false.B)
  val cTag = RegEnable(bTag, bValid)
  val blockBest = RegEnable((levelsB until treeLevels).foldLeft(bBest: Seq[Best])((xs, _) => treeLevel(xs, bTag.left)).head, bValid)
  // merge: each later block holds higher d (left sweep) or lower d (right sweep)
  val running = Reg(new Best)
  val merged = Mux(cTag.first, blockBest, merge(running, blockBest, !cTag.left))
  when(cValid) { running := merged }
  val leftDone = cValid && cTag.last && cTag.left //   this cycle's merged is the left sweep's result
  val rightDone = cValid && cTag.last && !cTag.left // ... the right sweep's

  // ---- the node whose right sweep is done waits here for its decision and the output register ----
  val pendBusy = RegInit(false.B)
  val pendStage = RegInit(0.U(2.W)) // 1: its right result is in, 2: the decision is in pendOk
  val pendFlags = Reg(Vec(3, Bool())) // sof, eol, eof
  val pendLeft = Reg(new Best) //  the left sweep's result
  val pendRight = Reg(new Best)
  val pendTexL = Reg(Bool())
  val pendTexR = Reg(Bool())
  val pendRangeOk = Reg(Bool()) // the right sweep's range reaches supportMinRange
  val pendOk = Reg(Bool())
  val curLeft = Reg(new Best) //   the current node's left result and texture bit
  val curTexL = Reg(Bool())

  // ---- output register ----
  val outValid = RegInit(false.B)
  val outBits = Reg(new Framed(SInt((p.dispBits + 1).W)))
  val outFree = !outValid || io.out.ready
  when(io.out.fire) { outValid := false.B }
  io.out.valid := outValid
  io.out.bits := outBits

  val nodeEol = walkU === width - 1.U
  val nodeEof = nodeEol && walkV === height - 1.U
  val nodeSof = walkU === 0.U && walkV === 0.U
  def output(value: SInt, sof: Bool, eol: Bool, eof: Bool): Unit = {
    outValid := true.B
    outBits.data := value
    outBits.sof := sof
    outBits.eol := eol
    outBits.eof := eof
  }
  /** Moves the walker to the next node. */
  def advance(): Unit = {
    state := sNode
    when(nodeEol) {
      walkU := 0.U
      walkV := Mux(walkV +& step.U < height, walkV + step.U, height - 1.U)
      walkSlot := Mux(walkSlot === (slots - 1).U, 0.U, walkSlot + 1.U)
      when(nodeEof) { state := sIdle; walkBusy := false.B }
    }.otherwise {
      walkU := Mux(walkU +& step.U < width, walkU + step.U, width - 1.U)
    }
  }
  val none = (-1).S((p.dispBits + 1).W)
  def dispMin(a: UInt): UInt = Mux(a > p.dispMax.U, p.dispMax.U, a)
  def ratioOk(b: Best): Bool = (b.e1 * 100.U) < (b.e2 * p.supportThresholdPercent.U)

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
        // emitted here, after the previous node's decision
        when(rowReady && outFree && !pendBusy) {
          output(none, nodeSof, nodeEol, nodeEof)
          advance()
        }
      }.elsewhen(rowReady) {
        phaseLeft := true.B; uRef := walkU
        readReference(false.B, walkU - r.U)
        sweepStart := true.B
        minC1 := walkU - r.U - dhiL
        maxC1 := walkU - r.U
        j := blockOf(walkU + r.U)
        jLo := blockOf(walkU - r.U - dhiL)
        state := sSweep
      }
    }
    is(sSweep) {
      when(issue) {
        sweepStart := false.B
        j := j - 1.U
        when(j === jLo) {
          when(phaseLeft) {
            state := sWait
          }.otherwise { // hand the node to the decision and go on with the next one
            pendBusy := true.B
            pendFlags := VecInit(nodeSof, nodeEol, nodeEof)
            pendLeft := curLeft
            pendTexL := curTexL
            pendRangeOk := maxC1 - minC1 >= p.supportMinRange.U
            advance()
          }
        }
      }
    }
    is(sWait) { // the left sweep's result is 4 cycles behind its last block
      when(leftDone) {
        // the right sweep (reference u' = u - d1) starts at once; a rejected left result is dropped at the decision
        val d1 = merged.d1(p.dispBits - 1, 0)
        val c0 = refC0 - d1 // u' - r
        curLeft := merged
        curTexL := texBits(0) // read at uRef = u
        phaseLeft := false.B
        uRef := uRef - d1
        readReference(true.B, c0)
        sweepStart := true.B
        // dhiR = min(W - 1 - margin - u', dispMax): maxC1 = u' - r + dhiR
        val top = c0 +& p.dispMax.U
        val maxR = Mux(top > rightLimit, rightLimit, top)(colW - 1, 0)
        minC1 := c0
        maxC1 := maxR
        j := blockOf(maxR + (2 * r).U)
        jLo := blockOf(c0)
        state := sSweep
      }
    }
  }
  // the last right block of the next node waits until this node's decision has left
  when(state === sSweep && !phaseLeft && j === jLo && pendBusy) { hold := true.B }

  // decision of the pending node: its right result, then the tests, then the output register
  when(RegNext(state === sSweep && issue && !phaseLeft && j === jLo, false.B)) { pendTexR := texBits(1) } // at u'
  when(rightDone) { pendRight := merged; pendStage := 1.U }
  when(pendStage === 1.U) {
    val diff = Mux(pendLeft.d1 > pendRight.d1, pendLeft.d1 - pendRight.d1, pendRight.d1 - pendLeft.d1)
    pendOk := pendTexL && ratioOk(pendLeft) && pendRangeOk && pendTexR && ratioOk(pendRight) &&
      diff <= p.lrThreshold.U
    pendStage := 2.U
  }
  when(pendStage === 2.U && outFree) {
    output(Mux(pendOk, pendLeft.d1(p.dispBits - 1, 0).zext, none), pendFlags(0), pendFlags(1), pendFlags(2))
    pendBusy := false.B
    pendStage := 0.U
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
