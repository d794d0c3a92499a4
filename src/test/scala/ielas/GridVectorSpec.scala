package ielas

import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.Path
import scala.util.Random

/** Stage `grid` (Descriptor -> SupportMatcher -> SupportFilter -> GridVector) against the golden grid_L.npy and
  * grid_R.npy: one Verilator build at config `small`, real crops (KITTI 2012, Middlebury) and seeded pairs, frame
  * sizes that are and are not multiples of gridSize, pairs whose cells overflow the storedDisparities cap, random
  * input gaps and output back-pressure, every slot of every cell of both views and the framing compared, frames back
  * to back, a throughput bound with no stalls.
  */
class GridVectorSpec extends AnyFlatSpec {
  import GridVectorSpec._

  behavior of "GridVector (Descriptor -> SupportMatcher -> SupportFilter -> GridVector chain)"

  it should "size its buffers by maxWidth only and keep up with 1 pixel per clock at every named configuration" in {
    for (p <- ElasParams.named) {
      val tall = p.copy(maxHeight = 8192)
      assert(GridVector.memorySummary(p) == GridVector.memorySummary(tall), s"${p.name}: memory grows with maxHeight")
      // one grid row is emitted while the next grid row of pixels arrives: gridSize rows of at least
      // (Gw - 1) gridSize + 1 pixels
      val w = p.maxWidth
      val pixels = p.gridSize.toLong * ((p.gridCount(w) - 1) * p.gridSize + 1)
      assert(GridVector.rowCycles(p, w) <= pixels, s"${p.name}: ${GridVector.rowCycles(p, w)} cycles per grid row > $pixels")
      println(s"  ${p.name}: ${GridVector.lanes(p)} lane(s), ${GridVector.cellCycles(p)} cycles per cell, " +
        s"${GridVector.rowCycles(p, w)} per grid row of $pixels pixel clocks; ${GridVector.memorySummary(p).head}")
    }
  }

  it should "elaborate at the edges of the legal parameters (one grid column, dispMax + 1 not a power of two, several lanes)" in {
    val edges = Seq(
      ElasParams(name = "one-column", maxWidth = 200, maxHeight = 16, dispMax = 15, gridSize = 256, storedDisparities = 16,
        fillC = 15),
      ElasParams(name = "odd-range", maxWidth = 333, maxHeight = 100, dispMax = 100, storedDisparities = 101, gridSize = 7),
      ElasParams(name = "lanes", maxWidth = 64, maxHeight = 32, dispMax = 31, candidateStep = 2, gridSize = 2,
        storedDisparities = 32, fillC = 31))
    for (p <- edges) {
      val sv = circt.stage.ChiselStage.emitSystemVerilog(new GridVector(p), Array.empty[String],
        VerilogEmitter.firtoolOptions.filterNot(_ == "--split-verilog"))
      assert(sv.contains("module GridVector"), s"${p.name}: no GridVector module")
      println(s"  ${p.name}: ${GridVector.lanes(p)} lane(s), ${GridVector.cellCycles(p)} cycles per cell, ${GridVector.memorySummary(p).head}")
    }
    assert(GridVector.lanes(edges(2)) > 1)
  }

  it should "match the golden grid vectors of both views at config small" in {
    runSuite("small")
  }
}

object GridVectorSpec {
  import StreamTester._
  import SupportMatcherSpec.{Case, shiftedPair}
  import SupportFilterSpec.{mixedPair, sparsePair}

  /** One output beat: both views' slots and the framing. */
  case class GridBeat(left: Seq[Int], right: Seq[Int], sof: Boolean, eol: Boolean, eof: Boolean)

  /** Blocks of 15x10 pixels (right-view coordinates), each with its own shift from 3, 5, .., 29: many different
    * supports within one 3x3 grid neighbourhood, so at config small (storedDisparities 20) most cells overflow the
    * cap and the "smallest first" rule decides.
    */
  def blockPair(w: Int, h: Int, rnd: Random): Case = {
    val wide = TestImages.noise(w + 32, h, rnd)
    val shifts = Array.fill((w + 14) / 15 * ((h + 9) / 10))(3 + 2 * rnd.nextInt(14))
    val left = GrayImage(w, h, Array.tabulate(w * h)(i => wide(i % w, i / w).toByte))
    val right = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      wide(x + shifts(y / 10 * ((w + 14) / 15) + x / 15), y).toByte
    })
    Case(s"blocks of 14 shifts ${w}x$h", left, right)
  }

  def golden(p: ElasParams, c: Case, dir: Path): (NpyArray, NpyArray) = {
    GoldenModel.dump(p.name, c.left, c.right, dir)
    val shape = Seq(p.gridCount(c.left.height), p.gridCount(c.left.width), p.storedDisparities)
    val Seq(l, r) = Seq("L", "R").map { v =>
      val a = NpyArray.read(dir.resolve(s"grid_$v.npy"))
      require(a.dtype == "<i2" && a.shape == shape, s"golden: grid_$v.npy has ${a.dtype} ${a.shape}, expected <i2 $shape")
      a
    }
    (l, r)
  }

  /** Checks every slot of both views and the framing of frames of one size following each other (frame f of the
    * stream against expected(f mod expected.length)).
    */
  class GridScoreboard(expected: Seq[(NpyArray, NpyArray)], label: String) {
    val board = new Scoreboard(s"grid [$label]")
    private val Seq(gh, gw, sd) = expected.head._1.shape
    private val cells = gh.toLong * gw
    def check(index: Long, beat: GridBeat): Unit = {
      val frame = index / cells
      val cell = index % cells
      val (gy, gx) = ((cell / gw).toInt, (cell % gw).toInt)
      val (expL, expR) = expected((frame % expected.length).toInt)
      def at = s"frame $frame grid cell (row $gy, col $gx)"
      for ((exp, got, view) <- Seq((expL, beat.left, "L"), (expR, beat.right, "R")); k <- 0 until sd)
        board.check(s"$at view $view slot $k", exp(cell * sd + k), got(k))
      board.check(s"$at sof", if (cell == 0) 1 else 0, if (beat.sof) 1 else 0)
      board.check(s"$at eol", if (gx == gw - 1) 1 else 0, if (beat.eol) 1 else 0)
      board.check(s"$at eof", if (cell == cells - 1) 1 else 0, if (beat.eof) 1 else 0)
    }
  }

  /** Cells whose last slot is used (the cap reached, or exceeded) in the left and right grids. */
  def fullCells(g: (NpyArray, NpyArray)): (Int, Int) = {
    val sd = g._1.shape(2)
    def count(a: NpyArray) = (0L until a.count / sd).count(c => a(c * sd + sd - 1) >= 0)
    (count(g._1), count(g._2))
  }

  private def gridBeat(o: Framed[GridCellPair]): GridBeat =
    GridBeat(o.data.left.map(peek(_).toInt), o.data.right.map(peek(_).toInt), peek(o.sof), peek(o.eol), peek(o.eof))

  /** Streams same-size frames through the chain and hands every grid cell to `sink`; returns the cycles. */
  def streamFrames(clock: chisel3.Clock, io: GridVectorChainIO, p: ElasParams, frames: Seq[(GrayImage, GrayImage)],
      traffic: Traffic, rnd: Random, sink: (Long, GridBeat) => Unit, maxCycles: Long, what: String): Long = {
    val (w, h) = (frames.head._1.width, frames.head._1.height)
    require(frames.forall { case (l, r) => l.width == w && r.width == w && l.height == h && r.height == h },
      s"$what: all frames of one run need the same size")
    poke(io.frameWidth, w)
    poke(io.frameHeight, h)
    val outputs = frames.length.toLong * p.gridCount(w) * p.gridCount(h)
    run[PixelPair, Framed[GridCellPair], PixelBeat, GridBeat](clock, io.in, pixelBeats(frames), pokePixel,
      io.out, outputs, gridBeat, sink, traffic, rnd, maxCycles, what)
  }

  /** Streams golden filtered lattices (support_filtered_L.npy of frames of size w x h) straight into the stand-alone
    * GridVector of [[GridVectorTestTop]]: with no input gaps, one node per clock, faster than the filter ever sends
    * them (it needs at least 2 cycles per node), so the mark pipeline's forwarding and the input stall are exercised.
    */
  def streamLattice(dut: GridVectorTestTop, p: ElasParams, w: Int, h: Int, frames: Seq[NpyArray], traffic: Traffic,
      rnd: Random, sink: (Long, GridBeat) => Unit, what: String): Long = {
    val (lh, lw) = (p.latticeCount(h), p.latticeCount(w))
    require(frames.forall(_.shape == Seq(lh, lw)), s"$what: lattices of one run need the shape ($lh, $lw)")
    poke(dut.io.chain.frameWidth, w)
    poke(dut.io.chain.frameHeight, h)
    val nodes = lh * lw
    val beats = frames.iterator.flatMap(a => Iterator.range(0, nodes).map(i =>
      (a(i.toLong), i == 0, i % lw == lw - 1, i == nodes - 1)))
    val mask = (BigInt(1) << p.signedDispBits) - 1
    run[Framed[chisel3.UInt], Framed[GridCellPair], (Int, Boolean, Boolean, Boolean), GridBeat](dut.clock,
      dut.io.lattice, beats,
      (bits, b) => { poke(bits.data, BigInt(b._1) & mask); poke(bits.sof, b._2); poke(bits.eol, b._3); poke(bits.eof, b._4) },
      dut.io.grid, frames.length.toLong * p.gridCount(w) * p.gridCount(h), gridBeat, sink, traffic, rnd,
      20L * frames.length * (nodes + p.gridCount(h) * GridVector.rowCycles(p, w)) + 1000, what)
  }

  /** Every transfer may wait on a gap and a stall; the grid adds its grid rows after the lattice. */
  def choppyBound(p: ElasParams, w: Int, h: Int, frames: Int = 1): Long =
    SupportMatcherSpec.choppyBound(p, w, h, frames) + 20L * frames * p.gridCount(h) * GridVector.rowCycles(p, w)

  /** The no-stall bound: the filter's bound, then up to three grid rows (gy = Gh - 3 is released by the first node
    * of the last grid row, which may come in the filter's final burst) plus the mark pipeline.
    */
  def throughputBound(p: ElasParams, w: Int, h: Int): (Long, String) = {
    val (base, formula) = SupportFilterSpec.throughputBound(p, w, h)
    val c = 3 * GridVector.rowCycles(p, w) + cycleSlack
    (base + c, s"$formula + 3 grid rows ${3 * GridVector.rowCycles(p, w)} + $cycleSlack")
  }
  /** The mark pipeline (2 stages) and the output register. */
  val cycleSlack: Int = 4

  def runSuite(config: String): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0x9d)
    val (w, h) = (p.maxWidth, p.maxHeight)
    val (k15l, k15r) = TestImages.pair("kitti2015/training/image_2/000046_10.png", "kitti2015/training/image_3/000046_10.png")
    val all = SupportMatcherSpec.cases(rnd).filter(!_.label.startsWith("periodic")) ++ Seq(
      Case("KITTI 2015 000046 crop 128x64 at (700,200)", k15l.crop(700, 200, 128, 64), k15r.crop(700, 200, 128, 64)),
      mixedPair(128, 64, rnd), mixedPair(101, 50, rnd), sparsePair(90, 60, rnd),
      blockPair(w, h, rnd), blockPair(w, h, rnd), blockPair(107, 47, rnd), blockPair(60, 21, rnd),
      shiftedPair(32, 16, 2, rnd))
    val tmp = tmpDir(s"grid-$config")
    val expected = all.zipWithIndex.map { case (c, i) => golden(p, c, tmp.resolve(f"golden$i%02d")) }
    val lattices = all.indices.map(i => NpyArray.read(tmp.resolve(f"golden$i%02d").resolve("support_filtered_L.npy")))
    var totalCells = 0L
    var totalFull = 0L
    var blockCells = 0L
    var blockFull = 0L
    simulate(new GridVectorTestTop(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      poke(dut.io.chain.in.valid, false)
      poke(dut.io.lattice.valid, false)
      val chain = dut.io.chain
      for ((c, exp) <- all.zip(expected)) {
        val board = new GridScoreboard(Seq(exp), c.label)
        val traffic = Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5)
        streamFrames(dut.clock, chain, p, Seq((c.left, c.right)), traffic, rnd, board.check,
          choppyBound(p, c.left.width, c.left.height), c.label)
        assert(board.board.ok, board.board.report)
        val (fullL, fullR) = fullCells(exp)
        val cells = exp._1.shape(0) * exp._1.shape(1)
        totalCells += 2 * cells
        totalFull += fullL + fullR
        if (c.label.startsWith("blocks")) { blockCells += 2 * cells; blockFull += fullL + fullR }
        println(f"  ${p.name}: ${board.board.report}; full cells (storedDisparities ${p.storedDisparities}) L $fullL R $fullR of $cells (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
      }
      println(s"  ${p.name}: $totalFull of $totalCells cells (both views) at the storedDisparities cap, $blockFull of $blockCells in the block pairs")
      assert(blockFull * 5 >= blockCells, "fewer than 20 % of the block pairs' cells reach the cap: the cap rule is not exercised")

      // Throughput with no stalls on a pair whose cells overflow (every cell takes the longest extraction).
      val tputIndex = all.indexWhere(c => c.left.width == w && c.left.height == h && c.label.startsWith("blocks"))
      val tput = new GridScoreboard(Seq(expected(tputIndex)), all(tputIndex).label)
      val cycles = streamFrames(dut.clock, chain, p, Seq((all(tputIndex).left, all(tputIndex).right)), noStall, rnd,
        tput.check, choppyBound(p, w, h), "throughput")
      assert(tput.board.ok, tput.board.report)
      val (bound, formula) = throughputBound(p, w, h)
      println(s"  ${p.name}: throughput ${w}x$h: $cycles cycles, bound $bound ($formula)")
      assert(cycles <= bound, s"throughput: $cycles cycles > bound $bound ($formula)")

      // Different frames back to back in one stream, overflowing cells among them.
      val full = all.indices.filter(i => all(i).left.width == w && all(i).left.height == h)
      val b2bIdx = full.filter(i => !all(i).label.startsWith("blocks")).take(2) :+ tputIndex
      val b2b = new GridScoreboard(b2bIdx.map(expected), "back to back " + b2bIdx.map(all(_).label).mkString(" + "))
      streamFrames(dut.clock, chain, p, b2bIdx.map(i => (all(i).left, all(i).right)), Traffic(0.1, 0.1), rnd, b2b.check,
        choppyBound(p, w, h, b2bIdx.length), "back to back")
      assert(b2b.board.ok, b2b.board.report)
      println(s"  ${p.name}: ${b2b.board.report}")

      // The stand-alone GridVector fed the same golden lattices at up to one node per clock: no gaps and no stalls,
      // heavy output back-pressure, or random traffic; then every full-size lattice back to back with no gaps.
      var stalled = 0L
      def stalls: Long = peek(dut.io.latticeStalls).toLong
      for (((c, exp), i) <- all.zip(expected).zipWithIndex) {
        val traffic = i % 3 match {
          case 0 => noStall
          case 1 => Traffic(0.0, 0.9)
          case _ => Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5)
        }
        val board = new GridScoreboard(Seq(exp), c.label + " (lattice input)")
        val before = stalls
        val cycles = streamLattice(dut, p, c.left.width, c.left.height, Seq(lattices(i)), traffic, rnd, board.check, c.label)
        assert(board.board.ok, board.board.report)
        stalled += stalls - before
        println(f"  ${p.name}: ${board.board.report}, ${lattices(i).count} nodes in $cycles cycles, input stalled ${stalls - before} (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
      }
      val b2bLattice = new GridScoreboard(full.map(expected), s"${full.length} lattices back to back (lattice input)")
      val before = stalls
      val b2bCycles = streamLattice(dut, p, w, h, full.map(lattices), Traffic(0.0, 0.3), rnd, b2bLattice.check,
        "lattices back to back")
      assert(b2bLattice.board.ok, b2bLattice.board.report)
      stalled += stalls - before
      println(s"  ${p.name}: ${b2bLattice.board.report}, $b2bCycles cycles, input stalled ${stalls - before}")
      assert(stalled > 0, "the lattice input never stalled: the slot-reuse stall is not exercised")
    }
  }
}

/** The spec's one Verilator build: the [[GridVectorChain]] (the early path up to the grid stage), plus a stand-alone [[GridVector]]
  * fed with lattice values directly (two's complement bits on the port, -1 = none) sharing the frame size ports, and
  * a count of the cycles its input was offered but not taken.
  */
class GridVectorTestTop(p: ElasParams) extends chisel3.Module {
  import chisel3._
  import chisel3.util.Decoupled
  val io = IO(new Bundle {
    val chain = new GridVectorChainIO(p)
    val lattice = Flipped(Decoupled(new Framed(UInt(p.signedDispBits.W))))
    val grid = Decoupled(new Framed(new GridCellPair(p)))
    val latticeStalls = Output(UInt(32.W))
  })
  val chain = Module(new GridVectorChain(p))
  chain.io <> io.chain
  val unit = Module(new GridVector(p))
  unit.io.in.valid := io.lattice.valid
  unit.io.in.bits.data := io.lattice.bits.data.asSInt
  unit.io.in.bits.sof := io.lattice.bits.sof
  unit.io.in.bits.eol := io.lattice.bits.eol
  unit.io.in.bits.eof := io.lattice.bits.eof
  io.lattice.ready := unit.io.in.ready
  unit.io.frameWidth := io.chain.frameWidth
  unit.io.frameHeight := io.chain.frameHeight
  io.grid <> unit.io.out
  val stalls = RegInit(0.U(32.W))
  when(io.lattice.valid && !unit.io.in.ready) { stalls := stalls + 1.U }
  io.latticeStalls := stalls
}
