package ielas

import chisel3._
import chisel3.util._

/** Stage `post`, step 1: bounded small-segment removal (docs/ALGORITHM.md "post" 1, golden removeSmallSegments).
  *
  * Input: lrcheck_L in raster order (-1 invalid), frame size sampled at start of frame. Output: the same map with the
  * pixels of small closed segments set to -1, same framing (eof on the last pixel).
  *
  * Rule: a pixel in row v of segment S becomes -1 iff |S| < speckleSize and NOT (v + L - 1 < H - 1 and S reaches
  * row v + L - 1), L = speckleWindowRows.
  *
  * How it streams (one row = one "row step" of four engines, each 1 item per clock):
  *  - A (labelling) takes row k. Each run of horizontally connected pixels gets a node id (0..N_k-1, left to
  *    right). Row k-1's components ("classes", flat ids from K_{k-1}) touched by row k are merged through the
  *    table R_k (class -> a row-k node). Because the pixel graph is planar, the classes along a row form a
  *    non-crossing partition, so the row-k components behave like a stack: a merge always joins the current top
  *    with an older node m (whose class is still touched later), and m becomes the top; nothing but the merge
  *    pointer P_k[top] = m (m < top) and m's saturating size changes. No find() chain is ever followed in A.
  *  - B (flatten) sweeps P_k in increasing id order during row k+1: K_k[x] = x if P_k[x] = x else K_k[P_k[x]]
  *    (P_k[x] < x is already flat). A reads K_k (with a bypass of B's current position) while B writes it.
  *    K_k[0] = 0 (node 0 never merges), so B starts while row k's last pixel is still in A's last step.
  *  - C (forward map) builds F_k during row k+1: for each row-(k-1) node x, F_k[x] = "open, node R_k[c]" if its
  *    class c = K_{k-1}[x] was touched by row k, else "closed, size S_{k-1}[c]" (final). After a frame's last row
  *    a virtual empty row closes every class.
  *  - D (output) reads row v from the delay line and sends every pixel's node through F_{v+1} .. F_{v+n},
  *    n = L - 1, or H - v at the end of the frame (then the chain ends at the virtual row, where all are closed):
  *    one lookup per step, 1 pixel per clock. The steps run on a ring of L + 2 units, one per map slot: step i of
  *    row v is in unit (v + i) mod (L + 2), beside the map it reads, and hands the beat to the next unit (no
  *    crossbar from every map to every step). A closed small result is removed, open is kept.
  *
  * Buffers (W = maxWidth, ids idW = log2(W) bits, size sW = log2(speckleSize + 1) bits, L = speckleWindowRows):
  *   delay line   (L + 4) rows x W x (dispBits + 1 + idW)
  *   F maps       (L + 2) rows x W x (1 + max(idW, sW)), one memory per row, 2 read ports
  *   P, R         2 rows x W x idW each (R: 2 replicas);  K, S  3 rows x W x idW / sW (3 replicas each)
  *   R valid flags 2 x W bits (registers; each lookup takes its selects from registers beside each chunk of flags)
  *   row above    2^(colBits + 1) x (dispBits + 1 + idW) (A's last pixels again, >= 2 rows)
  *   output queue 3 L + 9 x (dispBits + 1 + 4 + colBits) (D's chain never stalls; D issues with a credit)
  * A is a pipeline of eight steps, so that no step follows a chain of lookups (each about 6 LUT levels) and no table's
  * block-RAM word is the next table's read address in the same clock (each such link has a register step):
  *  - T takes the input beat into registers and decides whether it joins the left pixel's run; ready depends on
  *    registers only, not on the beat.
  *  - A0: the run's node id and node count (a recurrence on the input alone), the delay line
  *    and row-above writes; the up node (the row above's word) is registered.
  *  - AK0: K_{k-1}[up node] is read.
  *  - AK: the flat class cls = K_{k-1}[up node] (0 for node 0), registered; the up pixel's connection.
  *  - AR: R_k[cls] and S_{k-1}[cls] are read.
  *  - A1R: both words are registered.
  *  - A1: R_k[cls] (the word, or the node A2 wrote there a clock ago), the touched flag, the comparisons A2's decision
  *    needs; S_k of that node is read (the read includes A2's write-back of this cycle).
  *  - A2: the label state (top node, its size) and the writes of R_k, P_k, S_k; the touched flag is written a clock
  *    later, from registers. A2 forwards its own flag write of the cycle in which A1 read (the same class touched
  *    first by the previous pixel), A1 the write then in flight (the pixel before), and C1 the same.
  *  A row's first pixel is taken once the previous row's last pixel has left AK0 (its AR reads of S_{k-1} then see
  *  A2's last writes), its second pixel once B1 works on row k - 1 or is past it (so from the second pixel on,
  *  K_{k-1} of the up node is written by the pixel's AK0: node ids are at most the column and B does one per clock).
  *  B and C start a row while its last pixel is in A2, so a row takes W + 5 clocks when the engines keep up (W before
  *  the pipeline). B works in three steps (B0: P_k[x] is read and registered; B1: K_k[P_k[x]]
  *  is read; B2: K_k[x] is written),
  *  C in five (the class, its entry, the entry registered, a register per map, then the map write, two clocks after
  *  the row's end).
  * Latency: row v leaves once C has built F_{v+L-1}, i.e. while row v + L is labelled (v + L + 1 when rows have
  * about W nodes), plus 3 L + 5 clocks of chain and A's steps; at W + 5 clocks a row that is within L + 2 rows of W
  * for W >= 4 L + 10, and the 5 clocks per row add up over a frame: [[PostProcessSpeckle.latencyRows]] adds
  * ceil(5 maxHeight / maxWidth) rows for them (narrower frames stay within the constant of the spec's bound).
  * Memories: every memory is block RAM, each read one cycle ahead at the address its reader holds next cycle (D's
  * row and column, A's pixel count, B's node), at the address a pipeline step forms for the next step, or (D's ring)
  * from a lane's address register, the beat waiting a clock for its word. Every memory is read-first (`Mem` read into
  * a register, so Yosys emulates no transparency) and either never meets a write of its cycle (the row above, written
  * W pixels before it is read; the delay line and F maps: D reads rows A has finished, C writes maps no beat in the
  * chain still needs) or forwards it: K, R, S (one replica per reader; K: AK0, B1, C0; R: AR, C1; S: AR, A1, C1) compare the write's slot and entry with the read's (R and S a cycle later,
  * between registers, when the word arrives; C0's K replica is read a clock earlier still and its word registered
  * once more, with a second compare for the write of the following cycle), P (written a cycle after A
  * asks, from registers) forwards that write and the one asked for this cycle (A's last pixels write while B starts
  * that row). A write in the cycle after the read is forwarded by the reader (A2: the previous pixel's first touch,
  * through its touched flag, which also stands in for that pixel's R write missing from A1's word). B, C and D read
  * the per-row metadata from registers one cycle old (written at least two cycles before a row becomes theirs). Row
  * slots are wrapping counters, not `seq % n`; D's ring needs no slot in its beats (the unit is the slot), only the
  * unit of the last step, where the output takes the result.
  */
class PostProcessSpeckle(p: ElasParams) extends Module {
  private val L = p.speckleWindowRows
  private val W = p.maxWidth
  private val ND = PostProcessSpeckle.delayRows(p)
  private val NF = PostProcessSpeckle.mapRows(p)
  private val idW = PostProcessSpeckle.idBits(p)
  private val sW = PostProcessSpeckle.sizeBits(p)
  private val fW = math.max(idW, sW)
  private val cap = p.speckleSize
  private val T = p.speckleSimThreshold
  private val vW = p.signedDispBits
  private val seqW = 16 // row sequence counters; engines are never more than ND rows apart

  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(SInt(vW.W))))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val out = Decoupled(new Framed(SInt(vW.W)))
    /** With io.out: the pixel lies in the frame's last row. */
    val outLastRow = Output(Bool())
    /** With io.out: the frame width. */
    val outWidth = Output(UInt(p.colBits.W))
  })

  private def satAdd(a: UInt, b: UInt): UInt = { val s = a +& b; Mux(s >= cap.U, cap.U, s)(sW - 1, 0) }
  /** min(cap, a + b + c) with c as the carry in: one carry chain ((2a + c) + (2b + c)) / 2, not a + b and then + c. */
  private def satAdd3(a: UInt, b: UInt, c: UInt): UInt = {
    val s = (Cat(a, c) +& Cat(b, c)) >> 1
    Mux(s >= cap.U, cap.U, s)(sW - 1, 0)
  }
  /** |a - b| <= T for a, b >= 0 (the only values it decides on), as two compares side by side: no absolute value
    * (a negation) after the subtraction. */
  private def similar(a: SInt, b: SInt): Bool = (a -& b) <= T.S && (b -& a) <= T.S

  // ---- per-row metadata ring, indexed by row sequence mod ND ----
  // Written by A0 (N at the row's last pixel, the rest at its first) or at the virtual row's start; B, C and D read
  // registered copies (one cycle old), which is safe as a row becomes theirs at least two cycles after these writes.
  val metaVirtual = Reg(Vec(ND, Bool()))
  val metaFirst = Reg(Vec(ND, Bool())) // row 0 of its frame
  val metaLast = Reg(Vec(ND, Bool())) // row H - 1 of its frame
  val metaLen = Reg(Vec(ND, UInt(log2Ceil(L + 2).W))) // D's chain length n (0 for the virtual row)
  val metaW = Reg(Vec(ND, UInt(p.colBits.W)))
  val metaWm1 = Reg(Vec(ND, UInt(p.colBits.W))) // W - 1
  val metaN = Reg(Vec(ND, UInt((idW + 1).W))) // nodes of the row
  /** A row's meta (all but N) as written by A0's row start or the virtual row's start, registered and written a
    * clock later: the slot decode and the register enables start at flip-flops. Only D reads these, and only rows A
    * has labelled (a real row W >= 32 clocks after its start; the virtual row's `aInc` waits a clock more). */
  class MetaWrite extends Bundle {
    val slot = UInt((log2Ceil(ND) max 1).W)
    val virtual = Bool(); val first = Bool(); val last = Bool()
    val len = UInt(log2Ceil(L + 2).W); val w = UInt(p.colBits.W); val wm1 = UInt(p.colBits.W)
  }
  val metaWrite = RegInit(0.U.asTypeOf(Valid(new MetaWrite)))
  metaWrite.valid := false.B
  /** Writes a row's meta (through `metaWrite`) for the frame now in A (its width). */
  private def writeMeta(slot: UInt, virtual: Bool, first: Bool, last: Bool, len: UInt): Unit = {
    metaWrite.valid := true.B
    val m = metaWrite.bits
    m.slot := slot; m.virtual := virtual; m.first := first; m.last := last; m.len := len
    m.w := frameW; m.wm1 := frameW - 1.U
  }
  when(metaWrite.valid) {
    val m = metaWrite.bits
    metaVirtual(m.slot) := m.virtual; metaFirst(m.slot) := m.first; metaLast(m.slot) := m.last
    metaLen(m.slot) := m.len; metaW(m.slot) := m.w; metaWm1(m.slot) := m.wm1
  }
  /** A row sequence counter's residue mod n as a wrapping register (no `seq % n`): `cur` now, `next` next cycle
    * (for read addresses issued one cycle ahead), `prev` = (seq - 1) mod n, `succ` = (seq + 1) mod n. */
  class Slot(n: Int) {
    private val w = log2Ceil(n) max 1
    val cur: UInt = RegInit(0.U(w.W))
    val next: UInt = WireDefault(cur)
    cur := next
    /** (cur + 1) mod n, kept as a register */
    val succ: UInt = RegInit((1 % n).U(w.W))
    val incW: Bool = WireDefault(false.B)
    when(incW) { succ := Mux(succ === (n - 1).U, 0.U, succ + 1.U) }
    /** (cur - 1) mod n, kept as a register */
    val prev: UInt = RegInit((n - 1).U(w.W))
    when(incW) { prev := cur }
    def inc(): Unit = { incW := true.B; next := succ }
    /** `v(slot)` one cycle old, of the slot held now: read at the slot held next (this one or its successor). */
    def regRead[T <: Data](v: Vec[T]): T = RegNext(Mux(incW, v(succ), v(cur)))
    /** The same value, from two registers (of this slot and of its successor) and the last cycle's increment: the
      * multiplexer is after the registers, off the path from the increment. */
    def regRead2[T <: Data](v: Vec[T]): T = Mux(RegNext(incW, false.B), RegNext(v(succ)), RegNext(v(cur)))
    /** (cur + 2) mod n, kept as a register */
    private val succ2: UInt = RegInit((2 % n).U(w.W))
    when(incW) { succ2 := Mux(succ2 === (n - 1).U, 0.U, succ2 + 1.U) }
    /** `v(succ)` one cycle old, of the successor held now (read at the successor held next). */
    def regReadSucc[T <: Data](v: Vec[T]): T = RegNext(Mux(incW, v(succ2), v(succ)))
    /** Copies of cur and succ of one reader's own, held XOR `key` (1 .. 2^w - 1): each reader's slot multiplexers
      * then hang on registers of their own instead of all on `succ` and `cur` (one net to every field's multiplexer
      * was the speckle stage's worst path at kitti). Different keys keep synthesis from merging the copies; the
      * multiplexer's inputs are permuted by the key, so it needs no XOR. */
    class Keyed(key: Int) {
      require(key > 0 && key < (1 << w), s"Slot: key $key outside 1 .. ${(1 << w) - 1}")
      private val k = key.U(w.W)
      val curK: UInt = RegInit(key.U(w.W))
      val succK: UInt = RegInit(((1 % n) ^ key).U(w.W))
      when(incW) { curK := succK; succK := Mux(succK === ((n - 1) ^ key).U, k, ((succK ^ k) + 1.U) ^ k) }
      assert((curK ^ k) === cur && (succK ^ k) === succ, "speckle: a keyed slot copy differs from its slot")
      private def keyed[T <: Data](v: Vec[T]): Vec[T] = VecInit(Seq.tabulate(1 << w)(i => v(if ((i ^ key) < n) i ^ key else 0)))
      /** regRead2 from the copies. */
      def regRead2[T <: Data](v: Vec[T]): T = Mux(RegNext(incW, false.B), RegNext(keyed(v)(succK)), RegNext(keyed(v)(curK)))
    }
  }

  // ---- memories ----
  // Delay line (block RAM, 1R1W): written by A, read by D one cycle ahead. A reads the row above from `upRows`, its
  // last 2^(colBits + 1) pixels again (block RAM, 1R1W), so the large memory needs no second read port.
  // (the delay line is read-first, a `Mem` read into a register: D reads rows A has finished, never one A writes)
  // In depth chunks of `delayChunkRows` entries (one block deep at this width on the ECP5, where the line is the stage's
  // largest memory): each chunk's read address comes from its own copy of D's address registers (below), so no one
  // net reaches every block of the line.
  private val delayChunkRows = math.min(PostProcessSpeckle.delayChunkRows, ND * W)
  private val delayChunks = (ND * W + delayChunkRows - 1) / delayChunkRows
  private val delayLoW = log2Ceil(delayChunkRows)
  val delay = Seq.tabulate(delayChunks)(i => Mem(math.min(delayChunkRows, ND * W - i * delayChunkRows), UInt((vW + idW).W)))
  private def delayChunk(a: UInt): UInt = if (delayChunks == 1) 0.U else a >> delayLoW
  // (read-first, a `Mem` read into a register: a SyncReadMem registers its address, and Yosys then took AK0's up-node
  // register into the block RAM as its read register, which put the row above's word back on K's read address)
  val upRows = Mem(2 << p.colBits, UInt((vW + idW).W))
  // F maps, one memory per row slot, {closed, size or node}. Chain stage i reads slot (seq + i) mod NF; stages of
  // one row read consecutive slots and only adjacent stages (across a row boundary) can meet on one slot, so two
  // read ports per slot suffice: even stages on port 0, odd stages on port 1.
  // A `Mem` read into a register (block RAM, read-first): no read that is used meets a write of its cycle (C writes
  // a map only once D's beats that apply it are retired or not yet issued), so the transparency of a SyncReadMem
  // (address compare and bypass multiplexer after the read address) would be dead logic on the chain's path.
  val fMaps = Seq.fill(NF)(Mem(W, UInt((1 + fW).W)))
  // P: written by A, read by B only, at B's next node (one cycle ahead; block RAM). A's write of a node B reads next
  // cycle (A2's last pixels of the row B has just started) is forwarded.
  // read-first (`Mem` read into a register): the write of the read's own cycle is forwarded below (hit2) anyway
  val pMem = Mem(2 * W, UInt(idW.W))
  val pWen = WireDefault(false.B); val pWSlot = WireDefault(0.U(1.W)); val pWNode = WireDefault(0.U(idW.W))
  val pWData = WireDefault(0.U(idW.W))
  // the write reaches the memory a cycle later, from registers (A's labelling logic stays off the RAM's address pins)
  val pwEn = RegNext(pWen, false.B); val pwSlot = RegEnable(pWSlot, pWen); val pwNode = RegEnable(pWNode, pWen)
  val pwData = RegEnable(pWData, pWen)
  when(pwEn) { pMem.write(addr(pwSlot, pwNode), pwData) }
  // P_k[1] of both slots also in registers, so the block RAM's read address is always B's node bx + 2 of its slot (from
  // registers): the read for node 1 (B idle, or ending a row) depends on whether B starts, a decision that was the
  // whole top's critical path in front of the address pins
  val pNode1 = Reg(Vec(2, UInt(idW.W)))
  when(pwEn && pwNode === 1.U) { pNode1(pwSlot) := pwData }
  /** A table with one writer and several readers: one block-RAM replica per reader (1R1W each), all written alike.
    * A read is issued a cycle before its data is used and sees every write up to and including its own cycle; later
    * writes are forwarded by the reader. Each replica is read-first (a `Mem` read into a register, Yosys' block RAM
    * read register) and the write of the read's own cycle is forwarded here, compared by slot and entry: a
    * transparent SyncReadMem would make Yosys compare the whole addresses, after the slot x W + x adders (and after
    * the write's decision, which multiplexed the write address), on the read address's path. */
  class Table(name: String, slots: Int, width: Int, readers: Int, lateCompare: Boolean) {
    private val depth = slots * W
    private val mems = Seq.tabulate(readers)(i => Mem(depth, UInt(width.W)).suggestName(s"${name}_$i"))
    // the address and data are don't-cares without a write, so they do not wait for the write's decision
    val wen = WireDefault(false.B)
    val wslot = Wire(UInt((log2Ceil(slots) max 1).W)); wslot := DontCare
    val wx = Wire(UInt(idW.W)); wx := DontCare
    val wdata = Wire(UInt(width.W)); wdata := DontCare
    private val waddr = addr(wslot, wx)
    when(wen) { mems.foreach(_.write(waddr, wdata)) }
    def write(slot: UInt, x: UInt, d: UInt): Unit = { wen := true.B; wslot := slot; wx := x; wdata := d }
    def read(reader: Int, slot: UInt, x: UInt): UInt = {
      val (hit, written, word) = readParts(reader, slot, x)
      Mux(hit, written, word)
    }
    // the write a cycle later, for the late forwarding compares
    private val wenLate = RegNext(wen, false.B)
    private val wslotLate = RegNext(wslot)
    private val wxLate = RegNext(wx)
    /** The read as (the write of its cycle hit, that write's data, the word read): a reader that computes from the
      * word can compute from both and select after (the block RAM's output then meets no multiplexer first).
      * The hit compares the write's slot and entry with the read's. With `lateCompare` (R and S, whose write address
      * is A2's decision and whose read addresses follow a K lookup) it is compared a cycle after the read, between
      * registers, when the word arrives: in the read's own cycle that compare came after both the decision and a
      * block-RAM word, the stage's critical path. Without it (K, written from B2's registers) it is compared in the
      * read's cycle and registered, so the hit is a flip-flop where the word is used. */
    def readParts(reader: Int, slot: UInt, x: UInt): (Bool, UInt, UInt) = {
      val word = Reg(UInt(width.W)); word := mems(reader).read(addr(slot, x))
      val written = Reg(UInt(width.W)); written := wdata
      val hit =
        if (lateCompare) wenLate && wslotLate === RegNext(slot) && wxLate === RegNext(x)
        else RegNext(wen && wslot === slot && wx === x, false.B)
      (hit, written, word)
    }
    /** The same as [[readParts]] a clock later and already merged, for a reader that knows its next entry: the read
      * is issued at (slot, x), the entry it will hold next cycle, and the value (the word, or a write it missed) is
      * registered in the fabric, so it leaves a flip-flop where it is used. The write of the issue cycle is compared
      * with (slot, x), the write of the next with (nowSlot, nowX), the entry then held; `nowZero` (entry 0, whose
      * word is 0 and needs no read) counts as a write of 0. Returns the register and its next value. */
    def readEarly(reader: Int, slot: UInt, x: UInt, nowSlot: UInt, nowX: UInt, nowZero: Bool): (UInt, UInt) = {
      val word = Reg(UInt(width.W)); word := mems(reader).read(addr(slot, x))
      val hitEarly = RegNext(wen && wslot === slot && wx === x, false.B)
      val writtenEarly = Reg(UInt(width.W)); writtenEarly := wdata
      val hitNow = wen && wslot === nowSlot && wx === nowX
      val next = Mux(nowZero, 0.U, Mux(hitNow, wdata, Mux(hitEarly, writtenEarly, word)))
      val held = Reg(UInt(width.W)); held := next
      (held, next)
    }
  }
  // K: flat classes, 3 rows (B never waits for C to finish reading K_{k-2}); written by B2, read by A0, B1, C0.
  val kTab = new Table("kMem", 3, idW, 3, lateCompare = false)
  // R: class -> row-k node, 2 rows; written by A2, read by AK and C1.
  val rTab = new Table("rMem", 2, idW, 2, lateCompare = true)
  // S: saturating sizes, 3 rows; written by A2, read by AK (S_{k-1}), A1 (S_k) and C1 (S_{k-1}).
  val sTab = new Table("sMem", 3, sW, 3, lateCompare = true)
  val rValid = Seq.fill(2)(RegInit(0.U(W.W))) // per R buffer: which classes row k has touched
  // A buffer's clear (a row's start in A0, the virtual row's start) and A2's flag write land a clock late, from
  // registers (see A2): the 2 x W flags' enables then start at flip-flops. `touchLate*` is the write in flight.
  val rowClear = WireDefault(false.B); val virtualClear = WireDefault(false.B)
  val touchLate = RegInit(false.B); val touchLateSlot = Reg(UInt(1.W)); val touchLateCls = Reg(UInt(idW.W))
  val touchLateTop = Reg(UInt(idW.W)) // the R write in flight: its data (the pushed top)
  /** The touched flag of a class in two steps, for a register between them (a W:1 multiplexer is too deep and too
    * wide for one step): `groups` looks it up in each group of 2^lo classes (at most 2^hiBits groups), `pick` takes
    * the group. The first step's selects come from registers loaded a clock ahead by `load`, beside the flags they
    * select among: one index register driving a lookup across 2 x W flip-flops was a 7.8 ns net at kitti, and A1's
    * class register driving every group's chunk select 5.0 ns. Synthesis merges registers that load the same value
    * under the same condition, so copies must differ in what or when they load:
    *  - `loadWhenMine` (A, whose class comes from a register): per chunk of 2^cb classes the buffer and the class's
    *    low cb bits, per group the chunk within the group, each loaded only when the class is in that chunk (group).
    *    The lookup only uses the class's own chunk and group, and each register has a load condition of its own.
    *  - otherwise (C, whose class is a block-RAM word at the load, too late for a decode): registers loaded every
    *    clock, copy k holding its value XOR k and serving a run of chunks wired accordingly. Only the key bits
    *    differ, so synthesis keeps at most two registers per bit (one per polarity). */
  private class FlagLookup(hiBits: Int, loadWhenMine: Boolean) {
    val lo: Int = idW - math.min(hiBits, idW)
    val count: Int = (W + (1 << lo) - 1) >> lo
    private val cb = math.min(5, lo) // a chunk: 2^cb classes of both buffers
    private val chunks = (W + (1 << cb) - 1) >> cb
    private val perGroup = 1 << (lo - cb) // chunks per group
    require(loadWhenMine || perGroup == 1, "speckle: keyed flag copies serve groups of one chunk")
    private val perCopy = if (loadWhenMine) 1 else (chunks + (2 << cb) - 1) / (2 << cb) // the keys must be distinct
    private def copyOf(c: Int): Int = c / perCopy
    private def keyOf(c: Int): Int = if (loadWhenMine) 0 else copyOf(c)
    /** The selects for next cycle's lookup of (buf, idx): per chunk (or run of chunks), then per group (none when a
      * group is a chunk). */
    def load(buf: UInt, idx: UInt): (Seq[UInt], Seq[UInt]) = (loadChunks(buf, idx), loadGroups(idx))
    def loadChunks(buf: UInt, idx: UInt): Seq[UInt] = {
      val v = if (cb == 0) buf else Cat(buf, idx(cb - 1, 0))
      Seq.tabulate((chunks + perCopy - 1) / perCopy) { k =>
        val r = Reg(UInt((cb + 1).W))
        if (loadWhenMine) when((idx >> cb) === k.U) { r := v } else r := v ^ k.U((cb + 1).W)
        r
      }
    }
    def loadGroups(idx: UInt): Seq[UInt] = if (perGroup == 1) Seq() else Seq.tabulate(count) { g =>
      val r = Reg(UInt((lo - cb).W))
      when((idx >> lo) === g.U) { r := idx(lo - 1, cb) }
      r
    }
    /** The class's flag within each chunk (the flags as they are this cycle). */
    def chunkBits(chunkSel: Seq[UInt]): Seq[Bool] = (0 until chunks).map { c =>
      val flags = Seq.tabulate(2 << cb) { i =>
        val j = (c << cb) + (i & ((1 << cb) - 1))
        if (j < W) rValid(i >> cb)(j) else false.B
      }
      bitAt(VecInit(Seq.tabulate(2 << cb)(i => flags(i ^ keyOf(c)))).asUInt, chunkSel(copyOf(c)))
    }
    /** Each group's chunk. */
    def groupsOf(chunkBits: Seq[Bool], groupSel: Seq[UInt]): UInt =
      VecInit(chunkBits.grouped(perGroup).zipWithIndex.map { case (g, gi) =>
        if (perGroup == 1) g.head else bitAt(VecInit(g).asUInt, groupSel(gi))
      }.toSeq).asUInt
    def groups(sel: (Seq[UInt], Seq[UInt])): UInt = groupsOf(chunkBits(sel._1), sel._2)
    def pick(groups: UInt, idx: UInt): Bool =
      if (count == 1) groups(0) else VecInit(groups.asBools.take(count))(idx(idW - 1, lo))
  }
  // C: groups of one chunk (32 classes; at least 32 groups), so C1's lookup takes every index bit it uses from the
  // copies beside the flags (at kitti a class bit that chose between two chunks in every group was an 8.8 ns net);
  // the pick has time in C2. A: 4 groups (the pick is one LUT in A2's decision); A's lookup takes three steps (the
  // chunks in A1R, the groups in A1, the pick in A2): at kitti the chunks and groups in one clock, across the 2 x W
  // flags, ran at 95 MHz

  private val rvC = new FlagLookup(math.max(5, idW - 5), loadWhenMine = false)
  private val rvA = new FlagLookup(2, loadWhenMine = true)
  /** Bit idx of v as a tree of 4:1 multiplexers (two index bits per LUT level). */
  private def bitAt(v: UInt, idx: UInt): Bool = {
    var level: Seq[Bool] = v.asBools
    var lo = 0
    while (level.size > 1) {
      val k = if (level.size > 2 && lo + 1 < idx.getWidth) 2 else 1
      level = level.grouped(1 << k).map { g =>
        val x = g.padTo(1 << k, false.B)
        if (k == 1) Mux(idx(lo), x(1), x(0))
        else Mux(idx(lo + 1), Mux(idx(lo), x(3), x(2)), Mux(idx(lo), x(1), x(0)))
      }.toSeq
      lo += k
    }
    level.head
  }
  // The last top node of a finished row and its size (not written back to sMem), per S buffer; the size in A2's two
  // parts (see topA), summed where it is read.
  val finTop = Reg(Vec(3, UInt(idW.W)))
  val finSizeA = Reg(Vec(3, UInt(sW.W))); val finSizeP = Reg(Vec(3, UInt(sW.W)))
  private def finSize(buf: UInt): UInt = VecInit((0 until 3).map(i => satAdd(finSizeA(i), finSizeP(i))))(buf)
  val finAny = RegInit(VecInit(Seq.fill(3)(false.B)))
  /** Entry x (< W) of row slot `slot`: a concatenation when W is a power of 2, else the slot's base (a table of the
    * constants i x W, a LUT per bit; a product by W became a multiplier block on the ECP5, 3 ns and its nets on
    * every table address) plus x. */
  private def addr(slot: UInt, x: UInt): UInt =
    if (isPow2(W)) Cat(slot, x(log2Ceil(W) - 1, 0))
    else VecInit(Seq.tabulate(1 << slot.getWidth)(i => (i * W).U(log2Ceil((1 << slot.getWidth) * W).W)))(slot) + x
  /** S of a finished row: the word read, unless x is the row's last top (kept in registers, not written back). */
  private def finS(buf: UInt, x: UInt, word: UInt): UInt = Mux(finAny(buf) && finTop(buf) === x, finSize(buf), word)

  // ---- engine counters (row sequence numbers) ----
  val aNext = RegInit(0.U(seqW.W)) // rows that have left A's last step
  val aBusy = RegInit(false.B) // T is inside a row
  val aD = new Slot(ND); val a2 = new Slot(2); val a3 = new Slot(3) // A's slots, of the row T takes (tNext)
  val aIncW = WireDefault(false.B); val tIncW = WireDefault(false.B); val bIncW = WireDefault(false.B)
  val cIncW = WireDefault(false.B); val dDoneIncW = WireDefault(false.B); val dNextIncW = WireDefault(false.B)
  def aInc(): Unit = { aNext := aNext + 1.U; aIncW := true.B }
  def tInc(): Unit = { tIncW := true.B; aD.inc(); a2.inc(); a3.inc() }
  val bNext = RegInit(0.U(seqW.W)); val bBusy = RegInit(false.B)
  val bD = new Slot(ND); val b2 = new Slot(2); val b3 = new Slot(3)
  val cNext = RegInit(0.U(seqW.W)); val cBusy = RegInit(false.B)
  val c2Last = RegInit(false.B) // C2 forms the last entry of row cNext (C4 writes it)
  val cD = new Slot(ND); val c2 = new Slot(2); val c3 = new Slot(3); val cF = new Slot(NF)
  val dDone = RegInit(0.U(seqW.W)) // rows retired by D (left the last chain stage)
  /** x - y of two row counters as a small signed register, updated with their increments: the engines' start
    * conditions compare these (a few bits) instead of 16-bit sequence numbers. Engines stay within ND + 2 rows. */
  class RowDiff(incX: Bool, incY: Bool) {
    val r: SInt = RegInit(0.S(9.W))
    r := r + incX.asUInt.zext - incY.asUInt.zext
    /** cmp(r, c) as a register, cmp one of >=, <=, === with a constant c: next cycle's r is r + 1, r or r - 1, and
      * cmp(r + 1, c) = cmp(r, c - 1), so the three compares are made on r alone and the increments only select (the
      * start conditions then read flip-flops, not a 9-bit compare after the increments). */
    def is(cmp: (SInt, SInt) => Bool, c: Int): Bool = {
      val next = Mux(incX === incY, cmp(r, c.S), Mux(incX, cmp(r, (c - 1).S), cmp(r, (c + 1).S)))
      RegNext(next, cmp(0.S(9.W), c.S))
    }
  }
  private def diff(incX: Bool, incY: Bool): RowDiff = new RowDiff(incX, incY)
  val dAB = diff(aIncW, bIncW) // aNext - bNext
  val dCB = diff(cIncW, bIncW) // cNext - bNext
  val dCA = diff(cIncW, aIncW) // cNext - aNext
  val dBT = diff(bIncW, tIncW) // bNext - tNext (tNext: rows T has ended)
  val dCT = diff(cIncW, tIncW) // cNext - tNext
  val dDT = diff(dDoneIncW, tIncW) // dDone - tNext
  val dDC = diff(dDoneIncW, cIncW) // dDone - cNext
  val dAN = diff(aIncW, dNextIncW).r // aNext - dNext
  val dCN = diff(cIncW, dNextIncW).r // cNext - dNext

  // ===== A: labelling, a pipeline T -> A0 -> AK0 -> AK -> AR -> A1R -> A1 -> A2 (one pixel per clock) =====
  // T takes the input beat into registers (no logic on its bits) and does the row's start bookkeeping; A0 finds the
  // pixel's run (left connection, node id) and writes the delay line and the row above; AK0 and AK look up the up
  // pixel's flat class; AR and A1R read that class's row-k entries (node, sizes), A1 its touched flag and S_k of its
  // node; A2 updates the label state (top node and its size) and writes R, P, S. Only A2 is a recurrence. A's row
  // slots advance when T ends a row and travel with each pixel; aNext counts rows that have left A2 (what B, C and D
  // wait for).
  // Row boundary: T takes row k's first pixel once row k - 1's last has left AK0 (so that pixel's AR reads of
  // S_{k-1} follow A2's last writes of row k - 1), and its second pixel once B works on row k - 1 (or is past it).
  // B and C start row k - 1 in the cycle its last pixel is in A2 (their reads of what A2 writes come later), and T
  // takes row k's second pixel in B's first clock on row k - 1. So a row costs W + 5 clocks when the engines keep up.
  val inFrame = RegInit(false.B) // rows of a frame remain to be taken
  val needVirtual = RegInit(false.B) // the frame's last row is taken; the virtual row comes next
  val frameW = Reg(UInt(p.colBits.W)); val frameH = Reg(UInt(p.rowBits.W))
  val aRow = Reg(UInt(p.rowBits.W)) // row in frame of the next / current row
  val aCol = Reg(UInt(p.colBits.W))
  val leftVal = Reg(SInt(vW.W)) // the previous input pixel

  /** A's row slots, set by T: delay line and meta (D), R and P (2), S and K (3) and the previous row's S and K. */
  class ASlots extends Bundle {
    val d = UInt((log2Ceil(ND) max 1).W); val r = UInt(1.W); val s = UInt(2.W); val sPrev = UInt(2.W)
  }
  class A0Beat extends Bundle {
    val sl = new ASlots
    val v = SInt(vW.W)
    val newRun = Bool() // v >= 0 and not joined to the left pixel's run (decided in T, off A0's node count path)
    val rowStart = Bool(); val lastCol = Bool()
    val row = UInt(p.rowBits.W); val hasUp = Bool(); val col = UInt(p.colBits.W); val pos = UInt((p.colBits + 1).W)
  }
  class AKBeat extends Bundle {
    val sl = new ASlots
    val rowStart = Bool(); val lastCol = Bool()
    val valid = Bool(); val newRun = Bool(); val node = UInt(idW.W); val upId = UInt(idW.W)
    // the up pixel's connection is tested in AK, from these registers (not after A0's upRows block-RAM read)
    val upOk = Bool(); val v = SInt(vW.W); val upVal = SInt(vW.W)
  }
  class A1Beat extends Bundle {
    val sl = new ASlots
    val rowStart = Bool(); val lastCol = Bool()
    val valid = Bool(); val newRun = Bool(); val node = UInt(idW.W); val connectU = Bool(); val cls = UInt(idW.W)
  }
  private val clsLoBits = math.min(5, idW)
  class A2Beat extends Bundle {
    val p = new A1Beat
    val rvGroups = UInt(rvA.count.W); val rn = UInt(idW.W) // R_k flag (its first lookup step) and node of cls in A1
    val sPrev = UInt(sW.W) // S_{k-1}[cls]
    val hitPre = Bool() // the pixel then in A2 had the same class
    val hitLate = Bool() // one of the two pixels before that touched this class first (not in A1R's flag read)
    val neNode = Bool() // rn =/= node
    val eqT = Bool(); val eqN = Bool(); val eqR = Bool() // rn equals the pixel then in A2's top, node, rn
    // cls decoded in two parts (low clsLoBits bits, the rest), so A2's touched-flag write is an AND of two of these
    val clsLo = UInt((1 << clsLoBits).W); val clsHi = UInt((1 << (idW - clsLoBits)).W)
  }
  val inA0v = RegInit(false.B); val inA0 = Reg(new A0Beat)
  val inAK0v = RegInit(false.B); val inAK0 = Reg(new AKBeat)
  val inAKv = RegInit(false.B); val inAK = Reg(new AKBeat)
  val inARv = RegInit(false.B); val inAR = Reg(new A1Beat)
  val inA1Rv = RegInit(false.B); val inA1R = Reg(new A1Beat)
  val inA1v = RegInit(false.B); val inA1 = Reg(new A1Beat)
  // A2's beat with a reset: its flip-flops then never become the tail of a shift register (an SRL read is a LUT level)
  val inA2v = RegInit(false.B); val inA2 = RegInit(0.U.asTypeOf(new A2Beat))
  /** A2 holds the last pixel of row aNext: B and C may start that row now. */
  val aLastInA2 = RegNext(inA1v && inA1.lastCol, false.B) // a register of its own (inA2.p.lastCol may become an SRL)

  // B (declared here: A0 reads K_{k-1} while B writes it)
  val bx = RegInit(0.U((idW + 1).W)) // B's node; 0 whenever B is idle
  val bxN = WireDefault(bx); bx := bxN
  // bx + 2 (mod 2^idW) as a register of its own: P's read address (B0 below) then has no adder before its multiplexer
  val bxPlus2 = RegInit(2.U(idW.W)) // stepped with bx (B below)
  // row bNext is labelled (aNext >= bNext + 1, or its last pixel is in A2), cNext + 1 >= bNext
  val bCanStart = !bBusy && (dAB.is(_ >= _, 1) || dAB.is(_ === _, 0) && aLastInA2) && dCB.is(_ >= _, -1)
  val bActive = bBusy || bCanStart
  val bComputed = Wire(UInt(idW.W)) // B2's K entry of this cycle
  val b1v = Wire(Bool()) // B1 holds a node of its row (B2 writes it next cycle)
  val b2v = RegInit(false.B) // B2 computes and writes K_k[b2x] now
  val b2x = Reg(UInt(idW.W)); val b2Slot = Reg(UInt(2.W))

  // ---- T ----
  // row k = tNext: bNext >= k - 1, cNext + 1 >= k (or C writes its last entry of row k - 2 now), dDone + ND >= k + 1
  val rowOk = !aBusy && !inA0v && !inAK0v && dBT.is(_ >= _, -1) && (dCT.is(_ >= _, -1) || dCT.is(_ === _, -2) && c2Last) &&
    dDT.is(_ >= _, 1 - ND)
  // B works on row k - 1 or is past it (the second pixel of a row needs K_{k-1}, see AK0): from registers, through
  // B's start decision
  val bOnRow = dBT.is(_ >= _, 0) || dBT.is(_ === _, -1) && bActive
  val rowStartNow = !aBusy
  val col = Mux(aBusy, aCol, 0.U)
  // col === frameW - 1 and aRow === frameH - 1 as registers, set at the take a cycle before (compares with frameW - 2
  // and frameH - 2), so the take only enables: rows are at least 2 wide, so a row's first column never ends it
  val frameWm2 = Reg(UInt(p.colBits.W)); val frameHm2 = Reg(UInt(p.rowBits.W))
  val aColIsLast = RegInit(false.B); val aRowIsLast = RegInit(false.B)
  val lastCol = aBusy && aColIsLast
  // upRows is a ring of A's pixels by pixel count; the up pixel was written (by A0) frameW > 1 pixels before this
  // one, so never in the cycle of this read. Read at the take, the word is there when the pixel is in A0.
  val upPos = RegInit(0.U((p.colBits + 1).W)) // pixels taken, mod 2^(colBits + 1) >= 2 maxWidth
  val upWord = RegNext(upRows.read(upPos - frameW))
  val aColIsOne = RegInit(false.B) // aCol === 1 (T waits for the row's second pixel), as a register
  io.in.ready := inFrame && Mux(aBusy, !aColIsOne || bOnRow, rowOk)
  val take = io.in.fire
  when(take) { aColIsOne := rowStartNow }

  // idle between frames: a beat starts a frame (size sampled now, the beat is taken from the next cycle on)
  when(!inFrame && !needVirtual && !aBusy && io.in.valid) {
    inFrame := true.B; frameW := io.frameWidth; frameH := io.frameHeight; aRow := 0.U
    frameWm2 := io.frameWidth - 2.U; frameHm2 := io.frameHeight - 2.U; aRowIsLast := io.frameHeight === 1.U
  }
  inA0v := take
  inA0.sl.d := aD.cur; inA0.sl.r := a2.cur; inA0.sl.s := a3.cur; inA0.sl.sPrev := a3.prev
  inA0.v := io.in.bits.data; inA0.rowStart := rowStartNow; inA0.lastCol := lastCol
  inA0.newRun := io.in.bits.data >= 0.S &&
    !(!rowStartNow && leftVal >= 0.S && similar(io.in.bits.data, leftVal))
  inA0.row := aRow; inA0.hasUp := aRow =/= 0.U; inA0.col := col; inA0.pos := upPos
  when(take) {
    when(rowStartNow) { aBusy := true.B }
    upPos := upPos + 1.U
    leftVal := io.in.bits.data
    aCol := col + 1.U
    aColIsLast := Mux(aBusy, aCol === frameWm2, frameWm2 === 0.U)
    when(lastCol) {
      aBusy := false.B
      aRow := aRow + 1.U
      aRowIsLast := aRow === frameHm2
      when(aRowIsLast) { inFrame := false.B; needVirtual := true.B }
    }
  }
  // The virtual row after a frame: no pixels, no nodes, no touches (closes every class of the last row). It starts
  // with A empty and counts as labelled two cycles later (after its meta writes land, for B's and D's registered copies).
  // Its condition is taken a cycle old: once true it stays true while the frame's last row drains (no pixel comes).
  val virtualStart = needVirtual && RegNext(rowOk && bOnRow && !inAKv && !inARv && !inA1Rv && !inA1v && !inA2v, false.B)
  when(virtualStart) {
    needVirtual := false.B
    virtualClear := true.B
    writeMeta(aD.cur, virtual = true.B, first = false.B, last = false.B, len = 0.U)
    metaN(aD.cur) := 0.U
    finAny(a3.cur) := false.B
    tInc()
  }
  when(RegNext(RegNext(virtualStart, false.B), false.B)) { aInc() } // after metaWrite has landed

  // ---- A0: run and node (a recurrence on the input alone), up pixel, up class ----
  val cnt = Reg(UInt((idW + 1).W)) // nodes allocated in this row
  val runId = Reg(UInt(idW.W))
  val a0Valid = inA0.v >= 0.S
  val newRun = inA0.newRun // a0Valid && !(the pixel joins the left pixel's run)
  val cntBase = Mux(inA0.rowStart, 0.U, cnt)
  val nodeNow = cntBase(idW - 1, 0)
  val thisRun = Mux(newRun, nodeNow, runId)
  val upVal = upWord(vW + idW - 1, idW).asSInt
  val upId = upWord(idW - 1, 0)
  // the row's start bookkeeping (a cycle after T; A1 reads R_k's flags a cycle later)
  val dwAddr = addr(inA0.sl.d, inA0.col) // the delay line's write address
  // upRows: the write is at the pixel taken a clock ago (upPos - 1), the read frameW > 1 pixels back
  CollisionFree.check("speckle: upRows", Seq(upRows), Seq(CollisionFree.Read(upPos - frameW, true.B)),
    Seq(CollisionFree.Write(inA0v, inA0.pos)))
  when(inA0v && inA0.rowStart) {
    val d = inA0.sl.d
    writeMeta(d, virtual = false.B, first = inA0.row === 0.U, last = inA0.row === frameH - 1.U,
      len = Mux(inA0.row +& (L - 1).U < frameH - 1.U, (L - 1).U, frameH - inA0.row))
    finAny(inA0.sl.s) := false.B
    rowClear := true.B
  }
  when(inA0v && inA0.lastCol) { tInc() } // T's slots: the next row's (T starts it once A0 is empty)
  when(inA0v) {
    cnt := cntBase + newRun.asUInt
    when(newRun) { runId := nodeNow }
    for ((m, i) <- delay.zipWithIndex) when(delayChunk(dwAddr) === i.U) { m.write(dwAddr(delayLoW - 1, 0), Cat(inA0.v.asUInt, thisRun)) }
    upRows.write(inA0.pos, Cat(inA0.v.asUInt, thisRun))
    when(inA0.lastCol) { metaN(inA0.sl.d) := cntBase + newRun.asUInt }
  }
  inAK0v := inA0v
  inAK0.sl := inA0.sl
  inAK0.rowStart := inA0.rowStart; inAK0.lastCol := inA0.lastCol; inAK0.valid := a0Valid; inAK0.newRun := newRun
  inAK0.node := nodeNow; inAK0.upId := upId
  inAK0.upOk := a0Valid && inA0.hasUp; inAK0.v := inA0.v; inAK0.upVal := upVal

  // ---- AK0: K_{k-1}[up node] is read (the up node from a register, not from the row above's block-RAM word) ----
  val kWordA = kTab.read(0, inAK0.sl.sPrev, inAK0.upId)
  inAKv := inAK0v
  inAK := inAK0

  // ---- AK: the flat class cls = K_{k-1}[up node], registered for AR ----
  // K_{k-1}[upId] is final: an up node id is at most the column, node 0 is always its own class, and from the second
  // pixel on B works on row k - 1 (one node per clock, never stalling; T took the second pixel no earlier than B1's
  // first cycle on the row) or is past it: B2 wrote node upId no later than this pixel's AK0, so the word read there
  // holds it (a write of that same cycle is forwarded by the table). The class thus comes from one block-RAM word,
  // not also from B2's result. While a pixel of row k is in AK, B cannot have started row k.
  val clsZero = RegNext(inAK0.upId === 0.U)
  val cls = Mux(clsZero, 0.U, kWordA)
  // (B2 never computes the up node while the pixel is in AK: checked against B1 a cycle earlier, for the pixels
  // that use the class; an invalid up pixel carries the last run's id, not a node at most its column)
  val bComputesUp = RegNext(b1v && b3.cur === inAK0.sl.sPrev && bx === inAK0.upId, false.B)
  assert(!(inAKv && inAK.upOk && inAK.upVal >= 0.S && !clsZero && bComputesUp),
    "speckle: the up node's class is written after AK0 read it")
  inARv := inAKv
  inAR.sl := inAK.sl
  inAR.rowStart := inAK.rowStart; inAR.lastCol := inAK.lastCol; inAR.valid := inAK.valid; inAR.newRun := inAK.newRun
  inAR.node := inAK.node; inAR.cls := cls
  inAR.connectU := inAK.upOk && inAK.upVal >= 0.S && similar(inAK.v, inAK.upVal)

  // ---- AR: R_k[cls] and S_{k-1}[cls] are read (the class from a register, not from K's block-RAM word) ----
  val rWordA = rTab.read(0, inAR.sl.r, inAR.cls)
  val sPrevWord = sTab.read(0, inAR.sl.sPrev, inAR.cls)
  val rvAChunkSel = rvA.loadChunks(inAR.sl.r, inAR.cls) // for A1R's chunk lookup
  inA1Rv := inARv
  inA1R := inAR

  // ---- A1R: the words, registered for A1 ----
  // R_k[cls] misses A2's R writes of this clock and the next (the two pixels ahead; the write of AR's clock is in
  // the word). The next clock's is the pixel ahead's, which A2 handles (hitR); this clock's, by the pixel two ahead,
  // is forwarded in A1 from registers: whether that pixel has this class (compared now, both in registers) and its
  // pushed top (registered as it is written: `touchLateTop`).
  val a1RWord = RegNext(rWordA)
  val a1SPrev = RegNext(finS(inA1R.sl.sPrev, inA1R.cls, sPrevWord))
  val a1LateEq = RegNext(inA2v && inA2.p.sl.r === inA1R.sl.r && inA2.p.cls === inA1R.cls, false.B)
  inA1v := inA1Rv
  inA1 := inA1R
  // R_k's touched flag of cls, first step: per chunk, from the flags as they are now. The flag write in flight now
  // (the pixel three ahead's, see A2) is not in them: forwarded as `a1HitEarly`.
  val rvAChunks = RegNext(VecInit(rvA.chunkBits(rvAChunkSel)))
  val rvAGroupSel = rvA.loadGroups(inA1R.cls) // for A1's group lookup
  val a1HitEarly = RegNext(touchLate && touchLateSlot === inA1R.sl.r && touchLateCls === inA1R.cls, false.B)

  // ---- A1: the class's row-k entries ----
  // R_k[cls]: the word read in AK; S_k of that node is read now (and seen by A2: the read includes A2's write-back of
  // this cycle). A2's R and rValid writes of this cycle are not in the words read here, and nothing is forwarded in
  // A1 (that kept A2's decision off the S read address): such a write means the pixel in A2 touched this class
  // first, and A2 then finds hitR, takes rn as its top and uses none of rn, m's size and the rn compares below.
  // R_k's flags were cleared at the row start.
  // The pixel in A2 is the previous one of the same row (a row's first pixel finds A2 empty); S_{k-1} is complete
  // for a row's first pixel (T takes it once the previous row's last pixel has left A0: that pixel's last S write
  // and finTop come no later than this pixel's AK read).
  val top = Reg(UInt(idW.W)); val topA = Reg(UInt(sW.W)); val topP = Reg(UInt(sW.W)); val topAny = Reg(Bool())
  val rnRaw = Mux(a1LateEq && touchLate, touchLateTop, a1RWord)
  val (mHit, mWritten, mRead) = sTab.readParts(1, inA1.sl.s, rnRaw) // S_k[rn]: mWritten if mHit, else mRead
  inA2v := inA1v
  inA2.p := inA1
  inA2.rvGroups := rvA.groupsOf(rvAChunks, rvAGroupSel)
  // the touched-flag writes of the two pixels before the one ahead land now and landed a cycle ago (see touchLate
  // below): A1R's chunk lookup holds neither
  inA2.hitLate := touchLate && touchLateSlot === inA1.sl.r && touchLateCls === inA1.cls || a1HitEarly
  inA2.rn := rnRaw
  inA2.sPrev := a1SPrev
  // the next top is one of the current top, the node of the pixel in A2 or its rn: compare rn with each now
  inA2.eqT := rnRaw === top; inA2.eqN := rnRaw === inA2.p.node; inA2.eqR := rnRaw === inA2.rn
  inA2.hitPre := inA2v && inA2.p.cls === inA1.cls
  inA2.neNode := rnRaw =/= inA1.node
  inA2.clsLo := UIntToOH(inA1.cls(clsLoBits - 1, 0), 1 << clsLoBits)
  inA2.clsHi := UIntToOH(inA1.cls >> clsLoBits, 1 << (idW - clsLoBits))

  // ---- A2: label state ----
  // hitR: the previous pixel touched this class first (its R write is not in A1's read): then rn is that pixel's
  // pushed top, which is the top now (a first touch never merges).
  val q = inA2.p
  val aP = q.sl.r; val aS = q.sl.s
  val topAnyBase = !q.rowStart && topAny
  val hitR = inA2.hitPre && touchLate
  val rv = rvA.pick(inA2.rvGroups, q.cls) || hitR || inA2.hitLate
  // where the top came from in the previous cycle (T: kept, N: the pushed node, R: that pixel's rn)
  val topFrom = RegInit(0.U(2.W))
  val rnIsTop = hitR || Mux1H(Seq(topFrom === 0.U, topFrom === 1.U, topFrom === 2.U), Seq(inA2.eqT, inA2.eqN, inA2.eqR))
  val rn = Mux(hitR, top, inA2.rn)
  val pushTop = Mux(q.newRun, q.node, top)
  val touchNew = q.connectU && !rv
  // rn =/= pushTop: after a push rn is older than the new node unless it is that node; else rn =/= top
  val touchOld = q.connectU && rv && Mux(q.newRun, hitR || inA2.neNode, !rnIsTop)
  // m's size: in S_k, or the top's size when m is the old top written back by a push this very cycle
  val mIsTop = q.newRun && topAnyBase && rnIsTop
  val newTop = Mux(touchOld, rn, pushTop)
  // The top's size is kept as two registers, topSize = min(cap, topA + topP), topP holding m's size straight from the
  // S block RAM's word when a merge read it: the word meets one multiplexer before a flip-flop and no adder (added
  // to a base and saturated in this cycle, the word crossed the device first and the stage ran at 82 MHz at kitti).
  // Every other candidate is a sum of registers formed beside the decision, which only selects. Sums of sizes
  // saturate once, min(cap, a + b + valid): nested saturation of non-negative terms is the same (sizes <= cap), so
  // topA + topP may stay unsummed while the new size adds to them: topA takes the rest of the sum, topP is kept.
  val v = q.valid.asUInt
  val useRead = touchOld && !mHit && !(q.newRun && mIsTop)
  val topSize = satAdd(topA, topP) // the true size, from registers (the S write-back of an old top)
  val newA = Mux(q.newRun,
    Mux(touchNew, satAdd(1.U(sW.W), inA2.sPrev),
      Mux(touchOld, Mux(mIsTop, satAdd(topA, v), Mux(mHit, satAdd(1.U(sW.W), mWritten), 1.U(sW.W))), 1.U(sW.W))),
    Mux(touchNew, satAdd3(topA, inA2.sPrev, v),
      Mux(touchOld, Mux(mHit, satAdd3(topA, mWritten, v), satAdd3(topA, topP, v)), satAdd(topA, v))))
  val keepP = !q.newRun || touchOld && mIsTop
  val newP = Mux(useRead, mRead, Mux(keepP, topP, 0.U))
  topFrom := Mux(!inA2v, 0.U, Mux(touchOld, Mux(hitR, 0.U, 2.U), Mux(q.newRun, 1.U, 0.U)))
  // The flag write lands a clock later, from registers: per buffer one enable per group of 2^clsLoBits classes
  // (decided now, so A2's decision drives 2 x 2^(idW - clsLoBits) registers, not 2 x W enables) and the class's
  // one-hot low part. A1R and A1 forward the writes in flight (hitLate), C1 too (c2LateHit). A buffer's clear comes a clock
  // late as well, so it keeps its order with the writes: it never meets one of its own buffer (asserted).
  touchLate := inA2v && touchNew; touchLateSlot := aP; touchLateCls := q.cls; touchLateTop := pushTop
  val touchLo = RegNext(inA2.clsLo)
  // The clear reaches the W flags through one register per group: a single clear register's net to all W flags'
  // resets was PostProcess's worst path at kitti (10.3 ns of routing). Copy g is the clear unless group g is written
  // this clock, which the assertion rules out; that difference keeps synthesis from merging the copies into one.
  for ((r, b) <- rValid.zipWithIndex) {
    val groupEnNext = VecInit(Seq.tabulate(1 << (idW - clsLoBits))(g => inA2v && touchNew && aP === b.U && inA2.clsHi(g)))
    val groupEn = RegNext(groupEnNext.asUInt, 0.U)
    val clearNext = rowClear && inA0.sl.r === b.U || virtualClear && a2.cur === b.U
    val clear = RegNext(clearNext, false.B)
    val groupClear = VecInit(groupEnNext.map(en => RegNext(clearNext && !en, false.B)))
    val mask = VecInit((0 until W).map(j => groupEn(j >> clsLoBits) && touchLo(j & ((1 << clsLoBits) - 1)))).asUInt
    assert(!(clear && groupEn =/= 0.U), "speckle: a touched-flag write meets its buffer's clear")
    assert(groupClear.asUInt === Fill(groupClear.length, clear), "speckle: the touched flags' clear copies")
    r := VecInit((0 until W).map(j => !groupClear(j >> clsLoBits) && (r(j) || mask(j)))).asUInt
  }
  when(inA2v) {
    when(q.newRun && topAnyBase) { sTab.write(aS, top, topSize) } // the old top stops being the top
    when(touchNew) { rTab.write(aP, q.cls, pushTop) }
    when(q.newRun || touchOld) { pWen := true.B; pWSlot := aP; pWNode := pushTop; pWData := Mux(touchOld, rn, pushTop) }
    top := newTop
    topA := newA; topP := newP
    topAny := topAnyBase || q.valid
    when(q.lastCol) {
      aInc()
      finAny(aS) := topAnyBase || q.valid
      finTop(aS) := newTop
      finSizeA(aS) := newA; finSizeP(aS) := newP
    }
  }

  // ===== B: flatten P_k into K_k (one node per clock, from the cycle it may start) =====
  // K_k[0] = 0 (node 0 never merges: P_k[0] = 0), so B does not read P_k[0]; it starts a clock after the row's last
  // pixel was in A2, whose P write is forwarded to the read of node 1 (issued in that clock).
  val bKslot = b3.cur
  val bN = bD.regRead2(metaN)
  // B0: P is read for the node B1 holds two clocks later and P_k[x] is registered for B1 (`bPx`), so K's read
  // address in B1 does not start at P's block-RAM word. The node read: bx + 2 while B goes on, node 1 of the next
  // slot when B1 holds its row's last node (B may start the next row next clock), node 1 of this slot while idle (a
  // start holds node 0, which needs no P). Node 1 comes from registers (`pNode1`), so the block RAM is always read at
  // bx + 2, an address formed from registers; B's decisions only select after the read.
  // The word misses the P writes of its read's clock and of the next; they are compared with the read (registers)
  // as the word arrives. A write asked for in the clock bPx is loaded (A2 holds a row's last pixel as B starts the
  // row) is compared a clock ahead with the node B1 then holds, and taken in B1 (`kNode`).
  // bx + 1 >= bN (B1 holds its row's last node) without a compare after bN's multiplexer: a row's first node (bx = 0)
  // is its last when bN <= 1, a flag per slot read like bN; a later node's was compared a cycle ahead (bN stays while
  // B is on a row, bx steps by one), so the row's end only selects between two registers
  val bNAtMostOne = bD.regRead2(VecInit(metaN.map(_ <= 1.U)))
  val bLastAhead = RegNext(bN <= bx +& 2.U, false.B) // for the next node, if B goes on
  val bLast = Mux(bBusy, bLastAhead, bNAtMostOne)
  val bPx = {
    assert(bxPlus2 === bx(idW - 1, 0) + 2.U, "speckle: bxPlus2 differs from bx + 2")
    val toNode1 = !(bActive && !bLast) // the read is for node 1 (of this slot, or of the next when the row ends)
    val node = Mux(toNode1, 1.U, bxPlus2)
    val slot = Mux(bActive && bLast, b2.succ, b2.cur)
    val word = RegNext(pMem.read(addr(b2.cur, bxPlus2))) // used only when the read is for node bx + 2
    val node1 = RegNext(pNode1(slot)) // read like the block RAM: the writes of this clock and the next are hits
    val fromNode1 = RegNext(toNode1)
    val hitA = RegNext(pwEn && pwSlot === slot && pwNode === node, false.B)
    val dataA = RegNext(pwData)
    val hitB = pwEn && pwSlot === RegNext(slot) && pwNode === RegNext(node)
    RegNext(Mux(hitB, pwData, Mux(hitA, dataA, Mux(fromNode1, node1, word))))
  }
  val kNode = {
    val nextNode = Mux(bBusy, bx(idW - 1, 0) + 1.U, 1.U) // the node B1 holds next cycle, if it holds one
    val pushIsNext = Mux(q.newRun, q.node === nextNode, top === nextNode)
    val hitLate = RegNext(pWen && aP === b2.cur && pushIsNext, false.B)
    Mux(hitLate, pwData, bPx)
  }
  // B1 (node bx): P_k[bx] is here; K_k[P_k[bx]] is read. B2 (node b2x, a cycle later) computes and writes K_k[b2x];
  // P_k[x] < x, so the read sees B2's write of node x - 1 made in the same cycle.
  val kWordB = kTab.read(1, bKslot, kNode)
  val b2Px = RegNext(kNode)
  b1v := bActive && bx < bN
  b2v := b1v
  b2x := bx(idW - 1, 0); b2Slot := bKslot
  // x = 0 and P_k[x] = x decided in B1 (registers into B2's multiplexer)
  val b2Zero = RegNext(bx === 0.U); val b2Self = RegNext(kNode === bx(idW - 1, 0))
  bComputed := Mux(b2Zero, 0.U, Mux(b2Self, b2Px, kWordB))
  when(b2v) { kTab.write(b2Slot, b2x, bComputed) }
  when(bActive) {
    when(bLast) {
      bBusy := false.B; bxN := 0.U; bxPlus2 := 2.U; bNext := bNext + 1.U; bIncW := true.B; bD.inc(); b2.inc(); b3.inc()
    }.otherwise { bBusy := true.B; bxN := bx + 1.U; bxPlus2 := bxPlus2 + 1.U }
  }

  // ===== C: forward map F_k for the nodes of row k - 1, in three steps =====
  // C0 holds node x (its class K_{k-1}[x] read a clock earlier), C1 reads its entry (R_k, S_{k-1}, the touched flag),
  // C2 forms F_k[x], C3 and C4 carry it to its map.
  // C may start while row k's last pixel is in A2 (C1 reads R_k a cycle later) and once B1 has finished row k - 1
  // (C0's read then sees B2's last K write). The row ends (cNext, C's slots) when C2 forms the last entry; C0 starts
  // the next row a clock later, so C's slots stay fixed while a row is in its steps.
  val cx = Reg(UInt((idW + 1).W))
  val cFirst = RegInit(true.B) // sequence 0 has no row before it
  val cPrevN = RegNext(Mux(cIncW, metaN(cD.cur), Mux(cFirst, 0.U, metaN(cD.prev))), 0.U) // N of row cNext - 1
  val c1v = RegInit(false.B); val c1Last = RegInit(false.B)
  val c1x = Reg(UInt(idW.W))
  // row cNext is labelled (aNext >= cNext + 1, or its last pixel is in A2), bNext >= cNext, dDone + NF >= cNext + 1
  val cCanStart = !cBusy && !c1Last && !c2Last && (dCA.is(_ <= _, -1) || dCA.is(_ === _, 0) && aLastInA2) &&
    dCB.is(_ <= _, 0) && dDC.is(_ >= _, 1 - NF)
  val cActive = cBusy || cCanStart
  val cxEff = Mux(cBusy, cx, 0.U)
  c1v := cActive && cxEff < cPrevN
  c1Last := cActive && cxEff + 1.U >= cPrevN
  c1x := cxEff(idW - 1, 0)
  // K_{k-1}[x] is read a clock before C0 holds node x (at cxEff + 1, the node C0 holds next if the row goes on; a row
  // starts at node 0, whose class is 0), so the word reaches R's and S's read addresses from a flip-flop.
  val cxP1 = Reg(UInt((idW + 1).W)) // cx + 1
  val (c1Class, c1ClassNext) =
    kTab.readEarly(2, c3.prev, Mux(cBusy, cxP1, 1.U)(idW - 1, 0), c3.prev, cxEff(idW - 1, 0), !cBusy)
  when(cActive) {
    when(cxEff + 1.U >= cPrevN) { cBusy := false.B }
      .otherwise { cBusy := true.B; cx := cxEff + 1.U; cxP1 := cxEff + 2.U }
  }
  val cRbuf = c2.cur
  val rvCCopies = rvC.load(c2.next, c1ClassNext) // for C1's flag lookup
  val cSbuf = c3.prev
  // C1
  val rWordC = rTab.read(1, cRbuf, c1Class)
  val sWordC = sTab.read(2, cSbuf, c1Class)
  val c2v = RegNext(c1v, false.B)
  c2Last := c1Last
  val c2x = RegNext(c1x)
  // the touched flag in two steps: the group flags now, the group in C2; and A2's flag write in flight, which the
  // flags do not hold yet (C1 may read a row's flags a clock after its last pixel's decision)
  val c2OpenGroups = Reg(UInt(rvC.count.W)); c2OpenGroups := rvC.groups(rvCCopies)
  val c2LateHit = RegNext(touchLate && touchLateSlot === cRbuf && touchLateCls === c1Class, false.B)
  val c2Class = RegNext(c1Class)
  val c2Fin = RegNext(finAny(cSbuf)) && c2Class === RegNext(finTop(cSbuf)) // compared in C2, after registers
  // C2
  val c2Open = rvC.pick(c2OpenGroups, c2Class) || c2LateHit
  val cEntry = Mux(c2Open, Cat(0.U(1.W), rWordC.pad(fW)), Cat(1.U(1.W), Mux(c2Fin, finSize(cSbuf), sWordC).pad(fW)))
  // C3 registers the entry (the multiplexer after the S and R block-RAM reads stays off the long nets); C4 is one
  // register per map, loaded only for its own slot (so synthesis keeps them apart and places each by its map), and
  // writes it: one net from C3 to each map, not one to every map cell across the device. The row has ended two
  // clocks before the last write lands (cNext changes at C2): D cannot see that yet, its first map read of a row
  // is at the fifth clock edge after cNext changes (dCN, dReady, s1, the chain's stage 0, its address register), and A's and B's
  // conditions on C concern its table reads, all done by C2.
  val c3v = RegNext(c2v, false.B)
  val c3Slot = RegNext(cF.cur)
  val c3x = RegNext(c2x)
  val c3Entry = RegNext(cEntry)
  for ((m, b) <- fMaps.zipWithIndex) {
    val mine = c3v && c3Slot === b.U
    val c4v = RegNext(mine, false.B)
    val c4x = RegEnable(c3x, mine)
    val c4Entry = RegEnable(c3Entry, mine)
    when(c4v) { m.write(c4x, c4Entry) }
  }
  when(c2Last) { cNext := cNext + 1.U; cIncW := true.B; cFirst := false.B; cD.inc(); c2.inc(); c3.inc(); cF.inc() }

  // ===== D: output chain =====
  // A ring of NF units, unit u beside map slot u: a beat's lookup steps go from unit to unit (step i in unit
  // (row sequence + i) mod NF), so every map is read only by its own unit, from registers beside it, and a step hands
  // its beat to the next unit only. What a lookup does not change rides beside the ring in a shift line.
  /** What a beat carries beside the ring (the lookups do not change it). */
  class Beat extends Bundle {
    val value = SInt(vW.W)
    val sof = Bool(); val eol = Bool(); val eof = Bool(); val lastRow = Bool()
    val cols = UInt(p.colBits.W)
    val virt = Bool()
    // the unit of its last step (L), (row sequence + L) mod NF, one-hot: the ring's result multiplexer is then an
    // AND-OR from the shift line (decoded after it, it was 7 LUT levels at kitti-d127)
    val endUnit = UInt(NF.W)
  }
  /** What the lookups change: the node (the segment's size once closed) and how many maps are still to apply. */
  class Look extends Bundle {
    val closed = Bool()
    val ptr = UInt(fW.W)
    val left = UInt(log2Ceil(L + 2).W)
  }
  val stage0 = RegInit(0.U.asTypeOf(Valid(new Beat)))
  val look0 = Reg(new Look)
  val inject0 = RegInit(0.U(NF.W)) // one-hot: the unit of the beat's first step, (row sequence + 1) mod NF
  /** An output pixel with what goes with it. */
  class OutBeat extends Bundle {
    val pixel = new Framed(SInt(vW.W)); val lastRow = Bool(); val cols = UInt(p.colBits.W)
  }
  // The chain never stalls: a beat reaches the output register 3 L + 2 clocks after stage0 and goes on into a queue
  // with room for every beat issued and not yet taken (D issues only with a credit), so no chain or ring register has
  // an enable, and the consumer's ready reaches only the queue and the credit count, not thousands of enables.
  // Its size: at full rate a beat is owed for 3 L + 6 clocks (s1, stage0, 3 L, last, outReg, the queue), its credit
  // comes back a clock after the take, and one more: 3 L + 9 (fewer would leave bubbles, never lose a beat).
  private val outEntries = PostProcessSpeckle.outEntries(p)
  val outReg = RegInit(0.U.asTypeOf(Valid(new OutBeat)))
  outReg.valid := false.B
  val out = new CreditQueue(new OutBeat, outEntries, "speckle")
  out.enq(outReg.valid, outReg.bits)
  val creditOk = out.creditOk
  io.out.valid := out.deq.valid
  io.out.bits := out.deq.bits.pixel
  io.outLastRow := out.deq.bits.lastRow
  io.outWidth := out.deq.bits.cols
  out.deq.ready := io.out.ready

  val dNext = RegInit(0.U(seqW.W)) // row being issued
  val dCol = RegInit(0.U(p.colBits.W))
  val dColN = WireDefault(dCol); dCol := dColN
  val dD = new Slot(ND); val dF = new Slot(NF)
  val dSlot = dD.cur
  // (regRead2: the row change selects after the registers, so the issue does not drive a slot multiplexer; each
  // field from copies of D's slot registers of its own)
  private def dMeta[T <: Data](v: Vec[T], key: Int): T = new dD.Keyed(key).regRead2(v)
  val dVirt = dMeta(metaVirtual, 1); val dFirst = dMeta(metaFirst, 2); val dLast = dMeta(metaLast, 3)
  val dLen = dMeta(metaLen, 4); val dWd = dMeta(metaW, 5); val dWm1 = dMeta(metaWm1, 6)
  // aNext >= dNext + 1, cNext >= dNext + n + 1: a register formed a cycle early, so the issue (and the chain's map
  // read addresses after it) waits for no counter compare. Exact for D's own row change; A's and C's progress of
  // this cycle is seen a cycle late, which only delays a row's start. At a row end it takes the next row's test,
  // made a cycle earlier still (false in the cycle after a row change, when that test was of the row now current).
  // dRowEnd = dVirt || dCol === dWm1, as a register formed a cycle ahead (the issue's row change and the read
  // address wait for no column compare). Rows are at least 2 wide, so column 0 ends only the virtual row; a slot's
  // meta changes only while D waits at column 0 of it (A0 or the virtual row's start write it before D may issue).
  val dRowEnd = RegInit(false.B)
  val dColP1 = RegInit(1.U(p.colBits.W)) // dCol + 1
  val dCNm1 = RegInit(-1.S(9.W)) // dCN - 1, kept as a register (the test below then has no adder after the slot mux)
  dCNm1 := dCNm1 + cIncW.asUInt.zext - dNextIncW.asUInt.zext
  // The next row's meta one cycle old (the slot multiplexer then has a clock of its own, before the compare): written
  // at least two clocks before A counts that row as labelled (dAN >= 2 below, read now), so the old copy is the same.
  val dSuccVirt = dD.regReadSucc(metaVirtual); val dSuccLen = dD.regReadSucc(metaLen)
  val dReadyNextRow = RegNext(!dNextIncW && dAN >= 2.S && (dSuccVirt || dCNm1 > dSuccLen.zext), false.B)
  val dReady = RegInit(false.B)
  val issue = dReady && creditOk
  out.spend(issue && !dVirt) // a virtual row's beat never reaches the queue
  // Two beats meet in a ring register only if they are 3d clocks apart and d rows apart, d even, with the d - 1
  // rows between them in the 3d - 1 beats between: only d = 2 across a virtual row (one beat; real rows are at least
  // 32). C's map slots already keep a frame's first row from issuing while the row before the virtual row is in the
  // chain when that first row's n is L - 1 (cNext <= dDone + NF - 1); with frames of fewer than L - 1 rows it is
  // not. So after a virtual row, D issues again only once 5 more clocks have passed (6 or more from the virtual
  // beat, 7 or more from the last beat before it): at most 6 clocks per frame.
  val cool = RegInit(0.U(3.W))
  val coolNext = Mux(issue && dVirt, 5.U, Mux(cool =/= 0.U, cool - 1.U, cool))
  cool := coolNext
  dReady := Mux(issue && dRowEnd, dReadyNextRow && !dVirt,
    dAN >= 1.S && Mux(dVirt, true.B, dCN > dLen.zext) && coolNext === 0.U)
  // read one cycle ahead, at the row and column D holds next cycle. The three candidate addresses are registers
  // kept with D's position (slot x W + column needs a constant multiply and adds, and the delay line spans dozens
  // of block RAMs at full width): the issue decision picks one in a single LUT level before the RAMs' address pins.
  private val delayAddrW = log2Ceil(ND * W)
  private def rowBase(slot: Int): UInt = (slot * W).U(delayAddrW.W) // addr(slot, 0)
  val dAddrNow = RegInit(0.U(delayAddrW.W)) // addr(dD.cur, dCol)
  val dAddrP1 = RegInit(1.U(delayAddrW.W)) //  dAddrNow + 1
  val dSuccBase = RegInit(rowBase(1 % ND)) //  addr(dD.succ, 0)
  when(issue) {
    dAddrNow := Mux(dRowEnd, dSuccBase, dAddrP1)
    dAddrP1 := Mux(dRowEnd, dSuccBase, dAddrP1) + 1.U
  }
  when(dD.incW) { dSuccBase := VecInit((0 until ND).map(i => rowBase((i + 1) % ND)))(dD.succ) }
  assert(dAddrNow === addr(dD.cur, dCol) && dSuccBase === addr(dD.succ, 0.U), "speckle: D's read address registers")
  val dAddrOn = Mux(dRowEnd, dSuccBase, dAddrP1)
  // Each chunk reads at the low bits of the same address, from its own copies of dAddrNow, dAddrP1 and dSuccBase
  // (XOR-keyed with the chunk index, or Yosys would merge them back into one register); the word is taken from the
  // chunk the address's high bits name. Each chunk's word is registered once more before that select (so the select
  // and the beat's first decisions do not follow a block RAM's clock-to-out across the line's blocks: 87.9 MHz at
  // kitti), and the beat enters the chain a clock after its issue, with D's fields registered beside its word.
  private def delayCopy(init: UInt, k: Int): UInt = RegInit((init(delayLoW - 1, 0) ^ k.U(delayLoW.W)))
  val dChunkWords = delay.zipWithIndex.map { case (m, i) =>
    val k = (i & ((1 << delayLoW) - 1)).U(delayLoW.W)
    val nowK = delayCopy(0.U(delayAddrW.W), i); val p1K = delayCopy(1.U(delayAddrW.W), i)
    val succK = delayCopy(rowBase(1 % ND), i)
    val onK = Mux(dRowEnd, succK, p1K)
    when(issue) { nowK := onK; p1K := ((onK ^ k) + 1.U) ^ k }
    when(dD.incW) { succK := VecInit((0 until ND).map(j => rowBase((j + 1) % ND)(delayLoW - 1, 0) ^ k))(dD.succ) }
    val readAddr = Mux(issue, onK, nowK) ^ k
    // D reads rows A has finished (aNext >= dNext + 1) and A writes a later row: the word of the pixel D issues next
    // clock never meets a write; the other chunks' reads and D's early reads of the next row's column 0 do, unused
    CollisionFree.check(s"speckle: delay($i)", Seq(m),
      Seq(CollisionFree.Read(readAddr, issue && delayChunk(dAddrNow) === i.U)),
      Seq(CollisionFree.Write(inA0v && delayChunk(dwAddr) === i.U, dwAddr(delayLoW - 1, 0))))
    RegNext(RegNext(m.read(readAddr)))
  }
  val dChunkNow = RegNext(RegNext(delayChunk(Mux(issue, dAddrOn, dAddrNow))))
  val word = VecInit(dChunkWords)(dChunkNow) // the word of the pixel issued a clock ago
  val s0 = Wire(new Beat)
  s0.value := DontCare // from the word, a clock later
  s0.sof := !dVirt && dFirst && dCol === 0.U
  s0.eol := !dVirt && dRowEnd
  s0.eof := !dVirt && dRowEnd && dLast
  s0.lastRow := dLast
  s0.cols := dWd
  s0.virt := dVirt
  s0.endUnit := UIntToOH(if (NF > 2) Mux(dF.cur >= 2.U, dF.cur - 2.U, dF.cur + (NF - 2).U) else dF.cur, NF)
  val s1Valid = RegNext(issue, false.B)
  val s1 = RegNext(s0)
  val s1Len = RegNext(dLen)
  val s1Inject = RegNext(UIntToOH(dF.succ, NF))
  val s1Beat = WireDefault(s1)
  s1Beat.value := Mux(s1.virt, -1.S, word(vW + idW - 1, idW).asSInt)
  val s1Look = Wire(new Look)
  s1Look.closed := false.B
  s1Look.ptr := word(idW - 1, 0)
  s1Look.left := Mux(s1Beat.value >= 0.S, s1Len, 0.U) // stage i applies F_{seq + i} while i <= n
  when(issue) {
    when(dRowEnd) { dColN := 0.U; dNext := dNext + 1.U; dNextIncW := true.B; dD.inc(); dF.inc() }.otherwise { dColN := dColP1 }
  }
  when(issue) { dColP1 := Mux(dRowEnd, 1.U, dColP1 + 1.U) }
  // (the issue selects last: its three candidates come from registers. The slots' meta one cycle old: at a row change
  // D goes on at once only when dReadyNextRow saw the next row labelled, its meta written long before; else D waits at
  // column 0, where dRowEnd follows dVirt until D may issue, which is two clocks after the meta lands at the earliest.)
  dRowEnd := Mux(issue, Mux(dRowEnd, dSuccVirt, dColP1 === dWm1), Mux(dCol === 0.U, dVirt, dRowEnd))

  /** One lookup step of a lane: apply the map's entry while maps are left and the segment is open. */
  private def lookup(b: Look, e: UInt): Look = {
    val r = Wire(new Look)
    r := b
    when(b.left =/= 0.U) {
      r.left := b.left - 1.U
      when(!b.closed) { r.closed := e(fW); r.ptr := e(fW - 1, 0) }
    }
    r
  }
  // Each unit has two lanes, one per read port of its map: a beat's odd steps run in lane 1, its even steps in lane 0,
  // so the two beats that can use one map in one clock (adjacent steps of rows r and r + 1) never share a port. A
  // step takes three clocks, each in a register of the lane: the beat's address (aw: the map reads at aw's node),
  // the beat beside the word read (wt), the lookup's result (st), which the next unit's other lane takes. A beat
  // enters lane 1 of its first step's unit from stage0. The registers hold stale beats where no beat is (every
  // register moves at every clock; the output takes a beat's result from its last step's unit, not a valid bit).
  class Lane(u: Int, q: Int) {
    val aw = Reg(new Look).suggestName(s"unit${u}_lane${q}_aw")
    val wt = Reg(new Look).suggestName(s"unit${u}_lane${q}_wt")
    val st = Reg(new Look).suggestName(s"unit${u}_lane${q}_st")
    val word = Wire(UInt((1 + fW).W)).suggestName(s"unit${u}_lane${q}_word")
  }
  val units = Seq.tabulate(NF, 2)((u, q) => new Lane(u, q))
  stage0.valid := s1Valid
  stage0.bits := s1Beat
  look0 := s1Look
  inject0 := Mux(s1Valid, s1Inject, 0.U)
  for (u <- 0 until NF; q <- 0 until 2) {
    val lane = units(u)(q)
    val from = units((u + NF - 1) % NF)(1 - q).st
    lane.aw := (if (q == 1) Mux(inject0(u), look0, from) else from)
    lane.wt := lane.aw
    lane.st := lookup(lane.wt, lane.word)
  }
  for ((m, u) <- fMaps.zipWithIndex; q <- 0 until 2)
    units(u)(q).word := RegNext(m.read(units(u)(q).aw.ptr(idW - 1, 0)))
  // The beat's last step (L) ends in units(endUnit)(L % 2).st, 3 L clocks after stage0, with its shift-line part.
  val endValid = ShiftRegister(stage0.valid, 3 * L, false.B, true.B)
  val endBeat = ShiftRegister(stage0.bits, 3 * L)
  // one more register: the ring's NF:1 result multiplexer has a clock of its own
  val lastValid = RegNext(endValid, false.B)
  val lastBeat = RegNext(endBeat)
  val lastLook = RegNext(Mux1H(endBeat.endUnit, units.map(_(L % 2).st)))
  when(lastValid) {
    val b = lastBeat
    val remove = b.value >= 0.S && lastLook.closed && lastLook.ptr < cap.U
    when(!b.virt) {
      outReg.valid := true.B
      val o = outReg.bits
      o.pixel.data := Mux(remove, -1.S, b.value)
      o.pixel.sof := b.sof; o.pixel.eol := b.eol; o.pixel.eof := b.eof
      o.lastRow := b.lastRow
      o.cols := b.cols
    }
    when(b.virt || b.eol) { dDone := dDone + 1.U; dDoneIncW := true.B }
  }
}

object PostProcessSpeckle {
  def delayRows(p: ElasParams): Int = p.speckleWindowRows + 4
  /** Entries of a delay-line chunk (see the class): 4k, one DP16KD deep at 4 bits (the line is 20 bits wide at kitti). */
  val delayChunkRows = 4096
  def mapRows(p: ElasParams): Int = p.speckleWindowRows + 2
  /** The output queue's entries: 3 L + 9 (see `outEntries` in the class). */
  def outEntries(p: ElasParams): Int = 3 * p.speckleWindowRows + 9
  def idBits(p: ElasParams): Int = log2Ceil(p.maxWidth)
  def sizeBits(p: ElasParams): Int = log2Ceil(p.speckleSize + 1) max 1
  /** Clocks a row takes beyond W when the engines keep up (T waits for A's pipeline and for B, see the class). */
  val rowExtraClocks = 5
  /** Rows of latency (input row -> output row): L + 2 rows of W, plus the clocks per row the engines take beyond W,
    * which add up to rowExtraClocks x maxHeight clocks over a frame taken at full rate. */
  def latencyRows(p: ElasParams): Int =
    p.speckleWindowRows + 2 + (rowExtraClocks * p.maxHeight + p.maxWidth - 1) / p.maxWidth

  def memorySummary(p: ElasParams): Seq[MemoryUse] = {
    val (w, idW, sW) = (p.maxWidth, idBits(p), sizeBits(p))
    Seq(
      MemoryUse("Speckle", "delay", delayRows(p) * w, p.signedDispBits + idW,
        s"(L + 4) rows x maxWidth, value + node id; read-first Mem 1R1W (block RAM), read by D"),
      MemoryUse("Speckle", "upRows", 2 << p.colBits, p.signedDispBits + idW,
        "A's last 2^(colBits + 1) >= 2 maxWidth pixels (the row above); read-first Mem 1R1W (block RAM)"),
      MemoryUse("Speckle", "fmaps", mapRows(p) * w, 1 + math.max(idW, sW),
        "(L + 2) rows x maxWidth forward maps; one read-first Mem per row, 2 read ports (block RAM)"),
      MemoryUse("Speckle", "P", 2 * w, idW, "merge parents (2 rows); read-first Mem 1R1W (block RAM), read by B"),
      MemoryUse("Speckle", "K", 3 * 3 * w, idW,
        "flat classes, 3 rows; one read-first Mem 1R1W (block RAM, write forwarded) per reader (A0, B1, C0)"),
      MemoryUse("Speckle", "R", 2 * 2 * w, idW,
        "class -> node, 2 rows; one read-first Mem 1R1W (block RAM, write forwarded) per reader (AK, C1)"),
      MemoryUse("Speckle", "S", 3 * 3 * w, sW,
        "saturating segment sizes, 3 rows; one read-first Mem 1R1W (block RAM, write forwarded) per reader (AK, A1, C1)"),
      MemoryUse("Speckle", "Rvalid", 2, w, "touched-class flags (registers)"),
      MemoryUse("Speckle", "outQueue", outEntries(p), p.signedDispBits + 4 + p.colBits,
        "output queue, 3 L + 9 entries (the chain never stalls: D issues with a credit); Chisel Queue (LUT-RAM)"))
  }
}
