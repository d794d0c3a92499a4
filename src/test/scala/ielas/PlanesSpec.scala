package ielas

import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.Path
import scala.util.Random

/** Stage `planes` alone: the golden filled lattice (`lattice_L.npy`) of a pair is streamed straight into
  * [[Planes]] with the frame size ports set, and every coefficient of both triangles in both views, the four corners
  * and the framing of every cell are compared with the golden `planes_L.npy` / `planes_R.npy` (corners with the
  * lattice). A Verilator build at config `small`: real crops of KITTI 2012, KITTI 2015 and Middlebury, seeded
  * random pairs, frames whose W-1 and H-1 are and are not multiples of step, hand-built lattices for the cases
  * images rarely give (flat, full-range jumps, n = 0 collapses, n < 0) whose expected planes come from the
  * independent reference below, random gaps and back-pressure, frames of different sizes back to back, and a
  * throughput bound with no stalls. A second, shorter build at `small` with candidateStep 2 runs the multi-engine
  * round robin (5 engines, dispMax 127), which no named configuration (all step 5, one engine) uses.
  */
class PlanesSpec extends AnyFlatSpec {
  import PlanesSpec._

  behavior of "Planes"

  it should "accept a cell within step^2 cycles (1 pixel per clock) at every named configuration" in {
    for (p <- ElasParams.named) {
      val budget = p.candidateStep * p.candidateStep
      assert(Planes.cyclesPerCell(p) <= budget, s"${p.name}: ${Planes.cyclesPerCell(p)} cycles per cell > $budget")
      println(s"  ${p.name}: ${Planes.iterations(p)} radix-4 steps, ${Planes.engines(p)} engine(s), " +
        s"${Planes.cyclesPerCell(p)} cycles per cell (budget $budget)")
    }
  }

  it should "match the golden planes at config small (real, random and hand-built lattices)" in {
    runSuite(ElasParams.byName("small"), extensive = true)
  }

  it should "match the golden planes at small with candidateStep 2 and dispMax 127 (5 engines, 4 cycles per cell)" in {
    // The named configurations all have step 5 and one engine: this custom one runs the round robin over several
    // engines (5: not a power of two) at the tightest budget (step^2 = 4 cycles per cell), with wider dividers
    // (dispMax 127), the golden model reading its JSON.
    val p = ElasParams.byName("small").copy(name = "small-step2-d127", candidateStep = 2, dispMax = 127)
    assert(Planes.engines(p) == 5 && Planes.cyclesPerCell(p) == 4, s"${Planes.engines(p)} engines")
    runSuite(p, extensive = false)
  }
}

object PlanesSpec {
  import StreamTester._

  val fields: Seq[String] = Seq("a", "b", "c", "anchorU", "anchorV", "valid")

  /** One frame for the stage: its size, the input lattice (Lh x Lw, raster) and the expected planes of both views,
    * (Lh-1, Lw-1, 2, 6) raster as in planes_L/R.npy. `source` says where the expected values come from.
    */
  case class Frame(label: String, width: Int, height: Int, lw: Int, lh: Int, lattice: IndexedSeq[Int],
      left: IndexedSeq[Int], right: IndexedSeq[Int], source: String) {
    def cells: Int = (lw - 1) * (lh - 1)
    def nodes: Int = lw * lh
    def plane(view: Int, cr: Int, cc: Int, t: Int, k: Int): Int =
      (if (view == 0) left else right)((((cr * (lw - 1) + cc) * 2) + t) * 6 + k)
  }

  // ---------------------------------------------------------------------------------------------------------------
  // Independent reference (hand code from docs/ALGORITHM.md "planes", BigInt arithmetic, not the golden model): the
  // expected planes of hand-built lattices, which the golden CLI cannot take. It is checked against the golden
  // dumps of every image case before it is trusted.
  // ---------------------------------------------------------------------------------------------------------------
  def floorDiv(a: BigInt, b: BigInt): BigInt = { val q = a / b; if (a % b != 0 && ((a < 0) != (b < 0))) q - 1 else q }
  def roundDiv(n: BigInt, d: BigInt): BigInt = if (d < 0) roundDiv(-n, -d) else floorDiv(2 * n + d, 2 * d)

  def reference(p: ElasParams, width: Int, height: Int, lattice: IndexedSeq[Int]): (IndexedSeq[Int], IndexedSeq[Int]) = {
    val (lw, lh) = (p.latticeCount(width), p.latticeCount(height))
    def coord(i: Int, size: Int) = math.min(i * p.candidateStep, size - 1)
    val one = BigInt(1) << 16
    val left, right = IndexedSeq.newBuilder[Int]
    for (cr <- 0 until lh - 1; cc <- 0 until lw - 1) {
      val (x0, x1, y0, y1) = (coord(cc, width), coord(cc + 1, width), coord(cr, height), coord(cr + 1, height))
      val (w, h) = (x1 - x0, y1 - y0)
      def d(j: Int, i: Int) = lattice(j * lw + i)
      val (tl, tr, bl, br) = (d(cr, cc), d(cr, cc + 1), d(cr + 1, cc), d(cr + 1, cc + 1))
      for ((da, db) <- Seq((tr - tl, bl - tl), (br - bl, br - tr))) {
        val n = w - da
        val valid = 10 * da.abs < 7 * w && n != 0 && 10 * da.abs < 7 * n.abs
        val v = if (valid) 1 else 0
        left ++= Seq(roundDiv(da * one, w).toInt, roundDiv(db * one, h).toInt, bl << 16, x0, y1, v)
        val (ra, rb) = if (n == 0) (0, 0) else (roundDiv(da * one, n).toInt, roundDiv(BigInt(db) * w * one, BigInt(h) * n).toInt)
        right ++= Seq(ra, rb, bl << 16, x0 - bl, y1, v)
      }
    }
    (left.result(), right.result())
  }

  def handBuilt(p: ElasParams, label: String, width: Int, height: Int, node: (Int, Int) => Int): Frame = {
    val (lw, lh) = (p.latticeCount(width), p.latticeCount(height))
    val lattice = IndexedSeq.tabulate(lh * lw)(k => node(k / lw, k % lw))
    require(lattice.forall(v => v >= 0 && v <= p.dispMax), s"$label: lattice values outside 0..${p.dispMax}")
    val (l, r) = reference(p, width, height, lattice)
    Frame(label, width, height, lw, lh, lattice, l, r, "reference")
  }

  /** Rows that walk with horizontal steps chosen around the interesting slopes of each cell width w: n = 0
    * (dA = w), n < 0 (dA > w), the validity limits (10|dA| vs 7w) and full-range jumps; rows are independent, so
    * the vertical differences are arbitrary too.
    */
  def edgeWalk(p: ElasParams, width: Int, height: Int, rnd: Random): Frame = {
    val (lw, lh) = (p.latticeCount(width), p.latticeCount(height))
    def w(i: Int) = math.min((i + 1) * p.candidateStep, width - 1) - math.min(i * p.candidateStep, width - 1)
    val rows = IndexedSeq.fill(lh) {
      val row = new Array[Int](lw)
      row(0) = rnd.nextInt(p.dispMax + 1)
      for (i <- 1 until lw) {
        val wi = w(i - 1)
        val choices = Seq(wi, wi, wi, wi - 1, wi + 1, 2 * wi, 0, 1, (7 * wi) / 10, (7 * wi + 9) / 10, rnd.nextInt(p.dispMax + 1))
        val delta = choices(rnd.nextInt(choices.length)) * (if (rnd.nextBoolean()) 1 else -1)
        val next = row(i - 1) + delta
        row(i) = if (next >= 0 && next <= p.dispMax) next else if (row(i - 1) - delta >= 0 && row(i - 1) - delta <= p.dispMax) row(i - 1) - delta else rnd.nextInt(p.dispMax + 1)
      }
      row
    }
    handBuilt(p, s"hand-built edge walk ${width}x$height", width, height, (j, i) => rows(j)(i))
  }

  // ---- golden cases ----
  case class Pair(label: String, left: GrayImage, right: GrayImage)

  def golden(p: ElasParams, config: String, c: Pair, dir: Path): Frame = {
    GoldenModel.dump(config, c.left, c.right, dir)
    val (w, h) = (c.left.width, c.left.height)
    val (lw, lh) = (p.latticeCount(w), p.latticeCount(h))
    val lat = NpyArray.read(dir.resolve("lattice_L.npy"))
    require(lat.dtype == "<i2" && lat.shape == Seq(lh, lw), s"golden: lattice_L.npy has ${lat.dtype} ${lat.shape}")
    val Seq(l, r) = Seq("L", "R").map { v =>
      val a = NpyArray.read(dir.resolve(s"planes_$v.npy"))
      require(a.dtype == "<i4" && a.shape == Seq(lh - 1, lw - 1, 2, 6), s"golden: planes_$v.npy has ${a.dtype} ${a.shape}")
      IndexedSeq.tabulate(a.count.toInt)(i => a(i.toLong))
    }
    Frame(c.label, w, h, lw, lh, IndexedSeq.tabulate(lw * lh)(i => lat(i.toLong)), l, r, "golden")
  }

  def pairs(rnd: Random): Seq[Pair] = {
    val (kl, kr) = TestImages.kitti2012
    val (ql, qr) = TestImages.pair("kitti2015/training/image_2/000046_10.png", "kitti2015/training/image_3/000046_10.png")
    val (tl, tr) = TestImages.middleburyTsukuba
    val (cl, cr) = TestImages.middleburyCones
    def crop(name: String, l: GrayImage, r: GrayImage, x: Int, y: Int, w: Int, h: Int) =
      Pair(s"$name crop ${w}x$h at ($x,$y)", l.crop(x, y, w, h), r.crop(x, y, w, h))
    val shifted = SupportMatcherSpec.shiftedPair(97, 41, 20, rnd)
    val mixed = SupportFilterSpec.mixedPair(128, 64, rnd)
    Seq(
      crop("KITTI 2012 000070", kl, kr, 600, 150, 128, 64),
      crop("KITTI 2012 000070", kl, kr, 300, 200, 126, 61), // W-1, H-1 multiples of step: no narrow cells
      crop("KITTI 2015 000046", ql, qr, 500, 160, 128, 64),
      crop("KITTI 2015 000046", ql, qr, 900, 200, 101, 47),
      crop("Middlebury tsukuba", tl, tr, 120, 110, 128, 64),
      crop("Middlebury cones", cl, cr, 200, 150, 111, 57),
      crop("Middlebury cones", cl, cr, 40, 40, 32, 16), // the smallest frame
      Pair(shifted.label, shifted.left, shifted.right),
      Pair(mixed.label, mixed.left, mixed.right),
      Pair("smooth 77x23", TestImages.smooth(77, 23, rnd), TestImages.smooth(77, 23, rnd)),
      Pair("noise 37x17", TestImages.noise(37, 17, rnd), TestImages.noise(37, 17, rnd)))
  }

  // ---- driving and checking ----
  case class Node(value: Int, sof: Boolean, eol: Boolean, eof: Boolean, width: Int, height: Int)
  case class CellBeat(coeffs: IndexedSeq[Long], corners: IndexedSeq[Int], sof: Boolean, eol: Boolean, eof: Boolean)

  def nodes(f: Frame): Iterator[Node] = Iterator.range(0, f.nodes).map { k =>
    Node(f.lattice(k), k == 0, k % f.lw == f.lw - 1, k == f.nodes - 1, f.width, f.height)
  }

  /** Checks the cells of `frames`, streamed in this order: every coefficient, the corners and the framing. */
  class PlanesScoreboard(frames: Seq[Frame], label: String) {
    val board = new Scoreboard(s"planes [$label]")
    private val starts = frames.scanLeft(0L)(_ + _.cells)
    def total: Long = starts.last
    def check(index: Long, beat: CellBeat): Unit = {
      val fi = starts.lastIndexWhere(_ <= index)
      val f = frames(fi)
      val cell = (index - starts(fi)).toInt
      val (cr, cc) = (cell / (f.lw - 1), cell % (f.lw - 1))
      def at = s"frame $fi '${f.label}' cell (row $cr, col $cc)"
      for (view <- 0 until 2; t <- 0 until 2; k <- 0 until 6)
        board.check(s"$at ${if (view == 0) "L" else "R"} triangle $t ${fields(k)} (${f.source})",
          f.plane(view, cr, cc, t, k), beat.coeffs((view * 2 + t) * 6 + k))
      for ((corner, (j, i)) <- Seq("TL", "TR", "BL", "BR").zip(Seq((cr, cc), (cr, cc + 1), (cr + 1, cc), (cr + 1, cc + 1))))
        board.check(s"$at corner $corner", f.lattice(j * f.lw + i), beat.corners(Seq("TL", "TR", "BL", "BR").indexOf(corner)))
      board.check(s"$at sof", if (cell == 0) 1 else 0, if (beat.sof) 1 else 0)
      board.check(s"$at eol", if (cc == f.lw - 2) 1 else 0, if (beat.eol) 1 else 0)
      board.check(s"$at eof", if (cell == f.cells - 1) 1 else 0, if (beat.eof) 1 else 0)
    }
  }

  def peekCell(o: Framed[PlaneCell]): CellBeat = {
    val coeffs = for (view <- Seq(o.data.left, o.data.right); t <- 0 until 2) yield {
      val c = view(t)
      Seq(peek(c.a).toLong, peek(c.b).toLong, peek(c.c).toLong, peek(c.anchorU).toLong, peek(c.anchorV).toLong,
        if (peek(c.valid)) 1L else 0L)
    }
    CellBeat(coeffs.flatten.toIndexedSeq, o.data.corners.map(c => peek(c).toInt), peek(o.sof), peek(o.eol), peek(o.eof))
  }

  /** Streams the frames back to back (the frame size ports change with each sof); returns the cycles. */
  def streamFrames(dut: Planes, frames: Seq[Frame], traffic: Traffic, rnd: Random, board: PlanesScoreboard,
      maxCycles: Long, what: String): Long = {
    var last: Option[Node] = None
    run[Framed[chisel3.SInt], Framed[PlaneCell], Node, CellBeat](dut.clock, dut.io.in, frames.iterator.flatMap(nodes),
      (bits, n) => {
        if (!last.exists(_.width == n.width)) poke(dut.io.frameWidth, n.width)
        if (!last.exists(_.height == n.height)) poke(dut.io.frameHeight, n.height)
        if (!last.exists(_.value == n.value)) poke(bits.data, n.value)
        if (!last.exists(_.sof == n.sof)) poke(bits.sof, n.sof)
        if (!last.exists(_.eol == n.eol)) poke(bits.eol, n.eol)
        if (!last.exists(_.eof == n.eof)) poke(bits.eof, n.eof)
        last = Some(n)
      },
      dut.io.out, board.total, peekCell, board.check, traffic, rnd, maxCycles, what)
  }

  def choppyBound(p: ElasParams, frames: Seq[Frame]): Long =
    frames.map(f => 20L * (f.nodes + f.cells.toLong * Planes.engineCycles(p))).sum + 10000

  /** No stalls: every node in one cycle, except that a cell-closing node waits for an engine (cyclesPerCell), plus
    * the last cell's engine run and the output register.
    */
  def throughputBound(p: ElasParams, f: Frame): (Long, String) = {
    val cpc = Planes.cyclesPerCell(p)
    val c = Planes.engineCycles(p) + 2
    (f.nodes + f.cells.toLong * (cpc - 1) + c, s"nodes ${f.nodes} + cells ${f.cells} x ($cpc - 1) + $c")
  }

  /** Plane statistics of a frame for the report: triangles, invalid planes, right-view n = 0 collapses. */
  def stats(p: ElasParams, f: Frame): (Int, Int, Int) = {
    def x(i: Int) = math.min(i * p.candidateStep, f.width - 1)
    def d(j: Int, i: Int) = f.lattice(j * f.lw + i)
    val triangles = for (cr <- 0 until f.lh - 1; cc <- 0 until f.lw - 1; t <- 0 until 2) yield {
      val da = if (t == 0) d(cr, cc + 1) - d(cr, cc) else d(cr + 1, cc + 1) - d(cr + 1, cc)
      (f.plane(0, cr, cc, t, 5) == 0, x(cc + 1) - x(cc) == da)
    }
    (triangles.size, triangles.count(_._1), triangles.count(_._2))
  }

  /** The golden model reads named configurations from golden/configs and any other from a JSON file. */
  def configArg(p: ElasParams, dir: Path): String =
    if (ElasParams.named.contains(p)) p.name else ConfigJson.write(p, dir).toString

  def runSuite(p: ElasParams, extensive: Boolean): Unit = {
    val rnd = new Random(seed ^ p.name.hashCode ^ 0x91a)
    val tmp = tmpDir(s"planes-${p.name}")
    val config = configArg(p, tmp)
    val real = (if (extensive) pairs(rnd) else pairs(rnd).take(4)).zipWithIndex.map { case (c, i) =>
      golden(p, config, c, tmp.resolve(f"golden$i%02d"))
    }

    // The reference must agree with the golden model before it stands in for it.
    val refBoard = new Scoreboard("reference vs golden planes")
    for (f <- real) {
      val (l, r) = reference(p, f.width, f.height, f.lattice)
      for ((got, exp, view) <- Seq((l, f.left, "L"), (r, f.right, "R")); i <- exp.indices)
        refBoard.check(s"'${f.label}' planes_$view cell ${i / 12} triangle ${i / 6 % 2} ${fields(i % 6)}", exp(i), got(i))
    }
    assert(refBoard.ok, refBoard.report)
    println(s"  ${p.name}: ${refBoard.report} (${real.size} frames)")

    val hand = if (!extensive) Seq(edgeWalk(p, 128, 64, rnd), edgeWalk(p, 37, 17, rnd)) else Seq(
      handBuilt(p, "hand-built flat 128x64", 128, 64, { val v = rnd.nextInt(p.dispMax + 1); (_, _) => v }),
      handBuilt(p, "hand-built 0 / dispMax checkerboard 128x64", 128, 64, (j, i) => if ((i + j) % 2 == 0) 0 else p.dispMax),
      handBuilt(p, "hand-built random full range 126x61", 126, 61, { val a = IndexedSeq.fill(4000)(rnd.nextInt(p.dispMax + 1)); (j, i) => a(j * 100 + i) }),
      edgeWalk(p, 128, 64, rnd), edgeWalk(p, 37, 17, rnd), edgeWalk(p, 126, 61, rnd), edgeWalk(p, 33, 16, rnd))
    val all = real ++ hand

    simulate(new Planes(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      for (f <- all) {
        val board = new PlanesScoreboard(Seq(f), f.label)
        val traffic = if (f eq all.last) Traffic(0.0, 0.9) else Traffic(rnd.nextDouble() * 0.6, rnd.nextDouble() * 0.6)
        streamFrames(dut, Seq(f), traffic, rnd, board, choppyBound(p, Seq(f)), f.label)
        assert(board.board.ok, board.board.report)
        val (tri, invalid, collapsed) = stats(p, f)
        println(f"  ${p.name}: ${board.board.report} (${f.source}; $invalid of $tri triangles invalid, $collapsed right n = 0; input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
      }

      // Frames of different sizes back to back in one stream (the size ports change at each sof).
      val mixedSizes = rnd.shuffle(all).take(8)
      val b2b = new PlanesScoreboard(mixedSizes, "back to back")
      streamFrames(dut, mixedSizes, Traffic(0.2, 0.2), rnd, b2b, choppyBound(p, mixedSizes), "back to back")
      assert(b2b.board.ok, b2b.board.report)
      println(s"  ${p.name}: back to back ${mixedSizes.map(f => s"${f.width}x${f.height}").mkString(", ")}: ${b2b.board.report}")

      // Throughput with no stalls on the largest frame.
      val f = real.head
      val tput = new PlanesScoreboard(Seq(f), "throughput")
      val cycles = streamFrames(dut, Seq(f), noStall, rnd, tput, choppyBound(p, Seq(f)), "throughput")
      assert(tput.board.ok, tput.board.report)
      val (bound, formula) = throughputBound(p, f)
      println(s"  ${p.name}: throughput ${f.width}x${f.height}: $cycles cycles, bound $bound ($formula); " +
        s"${Planes.cyclesPerCell(p)} cycles per cell vs step^2 = ${p.candidateStep * p.candidateStep} pixel clocks")
      assert(cycles <= bound, s"throughput: $cycles cycles > bound $bound ($formula)")
    }
  }
}
