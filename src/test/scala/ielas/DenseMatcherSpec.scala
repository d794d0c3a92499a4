package ielas

import chisel3._
import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.Path
import scala.util.Random

/** Stage `dense` alone: the golden descriptor, planes (+ lattice corners) and grid dumps are fed as three
  * independent streams with their own seeded gaps; every pixel of dense_L and dense_R and the framing are compared
  * with the golden dump. One Verilator build at config `small`: real crops (KITTI 2012, KITTI 2015, Middlebury
  * tsukuba and cones), seeded random pairs (noise, shifted texture, bands of different shifts that fold the right
  * mesh, flat), side streams far ahead of and far behind the descriptors, back-to-back frames, a throughput bound
  * with no stalls, and a crafted frame for the right-view row without any covered pixel (expected by hand).
  */
class DenseMatcherSpec extends AnyFlatSpec {
  behavior of "DenseMatcher"

  it should "match the golden dense maps at config small" in {
    DenseMatcherSpec.runSuite("small")
  }
  it should "match the golden dense maps at config small-c4 (4 cycles per pixel: 7 lanes x 4 candidate groups)" in {
    DenseMatcherSpec.runSuite("small-c4")
  }
}

object DenseMatcherSpec {
  import StreamTester._
  import SupportMatcherSpec.{Case, shiftedPair}

  /** One frame's golden arrays. */
  case class Golden(w: Int, h: Int, desc: Seq[NpyArray], planes: Seq[NpyArray], lattice: NpyArray, grid: Seq[NpyArray],
      dense: Seq[NpyArray])

  def golden(p: ElasParams, c: Case, dir: Path): Golden = {
    GoldenModel.dump(p.name, c.left, c.right, dir)
    val (w, h) = (c.left.width, c.left.height)
    def read(name: String, dtype: String, shape: Seq[Int]): NpyArray = {
      val a = NpyArray.read(dir.resolve(s"$name.npy"))
      require(a.dtype == dtype && a.shape == shape,
        s"golden: $name.npy has ${a.dtype} ${a.shape}, expected $dtype $shape")
      a
    }
    val (lw, lh) = (p.latticeCount(w), p.latticeCount(h))
    val (gw, gh) = (p.gridCount(w), p.gridCount(h))
    Golden(w, h,
      Seq("L", "R").map(v => read(s"descriptor_$v", "|u1", Seq(h, w, 16))),
      Seq("L", "R").map(v => read(s"planes_$v", "<i4", Seq(lh - 1, lw - 1, 2, 6))),
      read("lattice_L", "<i2", Seq(lh, lw)),
      Seq("L", "R").map(v => read(s"grid_$v", "<i2", Seq(gh, gw, p.storedDisparities))),
      Seq("L", "R").map(v => read(s"dense_$v", "<i2", Seq(h, w))))
  }

  case class DenseBeat(left: Int, right: Int, sof: Boolean, eol: Boolean, eof: Boolean)

  /** Compares every pixel of both views and the framing of consecutive frames. */
  class DenseScoreboard(frames: Seq[Golden], label: String) {
    val board = new Scoreboard(s"dense $label")
    private val offsets = frames.scanLeft(0L)((acc, g) => acc + g.w.toLong * g.h)
    var valid = 0L
    def check(index: Long, beat: DenseBeat): Unit = {
      val f = offsets.lastIndexWhere(_ <= index)
      val g = frames(f)
      val pix = index - offsets(f)
      val (x, y) = ((pix % g.w).toInt, (pix / g.w).toInt)
      def at = s"frame $f (x=$x, y=$y)"
      val (el, er) = (g.dense(0)(pix), g.dense(1)(pix))
      if (el >= 0) valid += 1
      if (er >= 0) valid += 1
      board.check(s"$at view L", el, beat.left)
      board.check(s"$at view R", er, beat.right)
      board.check(s"$at sof", if (pix == 0) 1 else 0, if (beat.sof) 1 else 0)
      board.check(s"$at eol", if (x == g.w - 1) 1 else 0, if (beat.eol) 1 else 0)
      board.check(s"$at eof", if (pix == g.w.toLong * g.h - 1) 1 else 0, if (beat.eof) 1 else 0)
    }
  }

  def descBeats(g: Golden): Iterator[(BigInt, BigInt, Boolean, Boolean, Boolean)] =
    Iterator.range(0, g.w * g.h).map { i =>
      def word(a: NpyArray) = (0 until 16).foldLeft(BigInt(0))((acc, k) => acc | (BigInt(a(i.toLong * 16 + k)) << (8 * k)))
      (word(g.desc(0)), word(g.desc(1)), i == 0, i % g.w == g.w - 1, i == g.w * g.h - 1)
    }

  /** Plane cells: (planes of both views as (a, b, c, anchorU, anchorV, valid) x 2 triangles, corners TL TR BL BR). */
  case class CellBeat(planes: Seq[Seq[Seq[Int]]], corners: Seq[Int], sof: Boolean, eol: Boolean, eof: Boolean)
  def planeBeats(g: Golden): Iterator[CellBeat] = {
    val (rows, cols) = (g.planes(0).shape(0), g.planes(0).shape(1))
    Iterator.range(0, rows * cols).map { i =>
      val (cr, cc) = (i / cols, i % cols)
      val planes = g.planes.map(a => (0 until 2).map(t => (0 until 6).map(k => a(a.index(cr, cc, t, k)))))
      val lat = g.lattice
      val corners = Seq((cr, cc), (cr, cc + 1), (cr + 1, cc), (cr + 1, cc + 1)).map { case (j, i) => lat(lat.index(j, i)) }
      CellBeat(planes, corners, i == 0, cc == cols - 1, i == rows * cols - 1)
    }
  }
  case class GridBeat(left: Seq[Int], right: Seq[Int], sof: Boolean, eol: Boolean, eof: Boolean)
  def gridBeats(g: Golden): Iterator[GridBeat] = {
    val Seq(rows, cols, s) = g.grid(0).shape
    Iterator.range(0, rows * cols).map { i =>
      def cell(a: NpyArray) = (0 until s).map(k => a(i.toLong * s + k))
      GridBeat(cell(g.grid(0)), cell(g.grid(1)), i == 0, i % cols == cols - 1, i == rows * cols - 1)
    }
  }

  case class Traffic3(desc: Double, planes: Double, grid: Double, outputStall: Double) {
    override def toString: String =
      f"gaps desc $desc%.2f planes $planes%.2f grid $grid%.2f, output stalls $outputStall%.2f"
  }

  /** Streams `frames` through the stage (their sizes may differ: frameWidth / frameHeight change with each frame's
    * first descriptor beat, where the stage samples them); returns the cycles of [[StreamTester.runFeeds]].
    */
  def stream(dut: DenseMatcher, frames: Seq[Golden], traffic: Traffic3, rnd: Random, sink: (Long, DenseBeat) => Unit,
      maxCycles: Long, what: String): Long = {
    type DescBeat = ((BigInt, BigInt, Boolean, Boolean, Boolean), Golden)
    val desc = new Feed[Framed[DescriptorPair], DescBeat]("desc", dut.io.desc,
      frames.iterator.flatMap(g => descBeats(g).map((_, g))), (bits, bg) => {
        val (b, g) = bg
        if (b._3) { poke(dut.io.frameWidth, g.w); poke(dut.io.frameHeight, g.h) }
        poke(bits.data.left, b._1); poke(bits.data.right, b._2)
        poke(bits.sof, b._3); poke(bits.eol, b._4); poke(bits.eof, b._5)
      }, traffic.desc, new Random(rnd.nextLong()))
    val planes = new Feed[Framed[PlaneCell], CellBeat]("planes", dut.io.planes, frames.iterator.flatMap(planeBeats),
      (bits, b) => {
        for ((view, vi) <- Seq(bits.data.left, bits.data.right).zipWithIndex; t <- 0 until 2) {
          val q = b.planes(vi)(t)
          poke(view(t).a, q(0)); poke(view(t).b, q(1)); poke(view(t).c, q(2))
          poke(view(t).anchorU, q(3)); poke(view(t).anchorV, q(4)); poke(view(t).valid, (q(5) != 0))
        }
        for (k <- 0 until 4) poke(bits.data.corners(k), b.corners(k))
        poke(bits.sof, b.sof); poke(bits.eol, b.eol); poke(bits.eof, b.eof)
      }, traffic.planes, new Random(rnd.nextLong()))
    val grid = new Feed[Framed[GridCellPair], GridBeat]("grid", dut.io.grid, frames.iterator.flatMap(gridBeats),
      (bits, b) => {
        for (k <- b.left.indices) { poke(bits.data.left(k), b.left(k)); poke(bits.data.right(k), b.right(k)) }
        poke(bits.sof, b.sof); poke(bits.eol, b.eol); poke(bits.eof, b.eof)
      }, traffic.grid, new Random(rnd.nextLong()))
    runFeeds[Framed[DisparityPair], DenseBeat](dut.clock, Seq(desc, planes, grid), dut.io.out,
      frames.map(g => g.w.toLong * g.h).sum,
      o => DenseBeat(peek(o.data.left).toInt, peek(o.data.right).toInt, peek(o.sof), peek(o.eol), peek(o.eof)),
      sink, traffic.outputStall, rnd, maxCycles, what)
  }

  def choppyBound(frames: Seq[Golden]): Long = frames.map(g => 20L * g.w * g.h).sum + 20000

  /** No stalls: N descriptor transfers complete in cyclesPerPixel x (N + s) cycles (no latency rows: the stage
    * reads only its own descriptor stream; s = DenseMatcher.cycleSlack, the flush steps among them).
    */
  def throughputBound(p: ElasParams, w: Int, h: Int): (Long, String) = {
    val (c, s) = (p.cyclesPerPixel, DenseMatcher.cycleSlack(p))
    (c * (w.toLong * h + s), s"$c x (N + $s)")
  }

  /** A textured left view and a right view made of horizontal bands with different shifts (disparity jumps that
    * fold the right mesh) plus an occluded strip.
    */
  def bandsPair(w: Int, h: Int, rnd: Random): Case = {
    val shifts = Seq.fill(3)(rnd.nextInt(28))
    val wide = TestImages.smooth(w + 32, h, rnd)
    val grain = TestImages.noise(w + 32, h, rnd)
    def px(x: Int, y: Int) = ((wide(x, y) + grain(x, y) / 4) min 255).toByte
    val left = GrayImage(w, h, Array.tabulate(w * h)(i => px(i % w + 32, i / w)))
    val right = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      val s = shifts(((x / 24) + (y / 16)) % shifts.length)
      px(x + 32 - s, y)
    })
    Case(s"bands ${shifts.mkString("/")} ${w}x$h", left, right)
  }

  def cases(rnd: Random): Seq[Case] = {
    val (kl, kr) = TestImages.kitti2012
    val (tl, tr) = TestImages.middleburyTsukuba
    val (cl, cr) = TestImages.middleburyCones
    val (k15l, k15r) =
      TestImages.pair("kitti2015/training/image_2/000046_10.png", "kitti2015/training/image_3/000046_10.png")
    Seq(
      Case("KITTI 2012 000070 crop 128x64 at (600,150)", kl.crop(600, 150, 128, 64), kr.crop(600, 150, 128, 64)),
      Case("KITTI 2012 000070 crop 128x64 at (100,250)", kl.crop(100, 250, 128, 64), kr.crop(100, 250, 128, 64)),
      Case("KITTI 2015 000046 crop 120x60 at (500,200)", k15l.crop(500, 200, 120, 60), k15r.crop(500, 200, 120, 60)),
      Case("Middlebury tsukuba crop 128x64 at (120,110)", tl.crop(120, 110, 128, 64), tr.crop(120, 110, 128, 64)),
      Case("Middlebury cones crop 111x57 at (200,150)", cl.crop(200, 150, 111, 57), cr.crop(200, 150, 111, 57)),
      shiftedPair(128, 64, 9, rnd), shiftedPair(97, 41, 20, rnd), shiftedPair(32, 16, 3, rnd),
      bandsPair(128, 64, rnd), bandsPair(101, 50, rnd),
      Case("noise 128x64", TestImages.noise(128, 64, rnd), TestImages.noise(128, 64, rnd)),
      Case("flat 40x20", TestImages.flat(40, 20, 77), TestImages.flat(40, 20, 77)))
  }

  /** The "no pixel covered" right-view row. It needs dispMax >= frame width (kitti at widths 32..255); no image
    * reaches it (lattice disparities stay below their node's column), so the streams are crafted and the expected
    * map is computed by hand. To stay on the spec's one `small` build (dispMax 31), the frame is 24x16, narrower
    * than the top's legal minimum of 32 (the stage itself has no minimum and the same logic serves every width).
    * The lattice is dispMax everywhere: every right-view vertex lies left of column 0, so no right-view pixel is
    * covered and each takes triangle (last cell, t = 1) of its cell row. Every triangle has its own
    * constant plane (value = its index), all descriptors are equal (every SAD is 0) and the grid is empty, so the
    * expected value is, by hand: -1 outside the margins, else the d in d_p-R..d_p+R (within 0..dispMax, target column
    * legal) of the smallest prior P[|d - d_p|], the first in ascending d on ties, -1 if none; d_p = the owner's value,
    * the left owner by the left-view formula of docs/ALGORITHM.md.
    */
  def runUncovered(p: ElasParams, dut: DenseMatcher, rnd: Random): Unit = {
    val (w, h, m, step, r) = (24, 16, p.descriptorMargin, p.candidateStep, p.planeRadius)
    require(p.dispMax >= w, s"uncovered: needs dispMax >= $w")
    val (lw, lh) = (p.latticeCount(w), p.latticeCount(h))
    val (cols, rows) = (lw - 1, lh - 1)
    def value(view: Int, cr: Int, cc: Int, t: Int): Int = if (view == 0) 2 + 2 * cc + t + cr else 1 + 2 * cc + t + 3 * cr
    val word = (0 until 16).foldLeft(BigInt(0))((acc, k) => acc | (BigInt(200) << (8 * k)))
    val descs = Iterator.range(0, w * h).map(i => (word, word, i == 0, i % w == w - 1, i == w * h - 1))
    val cells = Iterator.range(0, rows * cols).map { i =>
      val (cr, cc) = (i / cols, i % cols)
      val planes = (0 until 2).map(v => (0 until 2).map(t => Seq(0, 0, value(v, cr, cc, t) << 16, 0, 0, 1)))
      CellBeat(planes, Seq.fill(4)(p.dispMax),
        i == 0, cc == cols - 1, i == rows * cols - 1)
    }
    val (gw, gh) = (p.gridCount(w), p.gridCount(h))
    val grids = Iterator.range(0, gw * gh).map(i =>
      GridBeat(Seq.fill(p.storedDisparities)(-1), Seq.fill(p.storedDisparities)(-1), i == 0, i % gw == gw - 1,
        i == gw * gh - 1))
    def coord(k: Int, n: Int) = math.min(k * step, n - 1)
    def expected(view: Int, u: Int, v: Int): Int = {
      if (u < m || u > w - 1 - m || v < m || v > h - 1 - m) return -1
      val cr = math.min(v / step, rows - 1)
      val (cc, t) = if (view == 1) (cols - 1, 1) else {
        val cc = math.min(u / step, cols - 1)
        val (x0, y0) = (coord(cc, w), coord(cr, h))
        val (cw, ch) = (coord(cc + 1, w) - x0, coord(cr + 1, h) - y0)
        (cc, if ((u - x0) * ch + (v - y0) * cw >= cw * ch) 1 else 0)
      }
      val dp = value(view, cr, cc, t)
      var (best, bestCost) = (-1, Int.MaxValue)
      for (d <- math.max(dp - r, 0) to math.min(dp + r, p.dispMax)) {
        val target = if (view == 0) u - d else u + d
        val cost = p.priorTable(math.abs(d - dp))
        if (target >= m && target <= w - 1 - m && cost < bestCost) { best = d; bestCost = cost }
      }
      best
    }
    val board = new Scoreboard("dense uncovered right view")
    locally {
      poke(dut.io.frameWidth, w)
      poke(dut.io.frameHeight, h)
      val feeds = Seq(
        new Feed[Framed[DescriptorPair], (BigInt, BigInt, Boolean, Boolean, Boolean)]("desc", dut.io.desc, descs,
          (bits, b) => {
            poke(bits.data.left, b._1); poke(bits.data.right, b._2)
            poke(bits.sof, b._3); poke(bits.eol, b._4); poke(bits.eof, b._5)
          }, 0.3, new Random(rnd.nextLong())),
        new Feed[Framed[PlaneCell], CellBeat]("planes", dut.io.planes, cells, (bits, b) => {
          for ((view, vi) <- Seq(bits.data.left, bits.data.right).zipWithIndex; t <- 0 until 2) {
            val q = b.planes(vi)(t)
            poke(view(t).a, q(0)); poke(view(t).b, q(1)); poke(view(t).c, q(2))
            poke(view(t).anchorU, q(3)); poke(view(t).anchorV, q(4)); poke(view(t).valid, q(5) != 0)
          }
          for (k <- 0 until 4) poke(bits.data.corners(k), b.corners(k))
          poke(bits.sof, b.sof); poke(bits.eol, b.eol); poke(bits.eof, b.eof)
        }, 0.5, new Random(rnd.nextLong())),
        new Feed[Framed[GridCellPair], GridBeat]("grid", dut.io.grid, grids, (bits, b) => {
          for (k <- b.left.indices) { poke(bits.data.left(k), b.left(k)); poke(bits.data.right(k), b.right(k)) }
          poke(bits.sof, b.sof); poke(bits.eol, b.eol); poke(bits.eof, b.eof)
        }, 0.5, new Random(rnd.nextLong())))
      var validRight = 0
      runFeeds[Framed[DisparityPair], DenseBeat](dut.clock, feeds, dut.io.out, w.toLong * h,
        o => DenseBeat(peek(o.data.left).toInt, peek(o.data.right).toInt, peek(o.sof), peek(o.eol), peek(o.eof)),
        (i, beat) => {
          val (u, v) = ((i % w).toInt, (i / w).toInt)
          if (beat.right >= 0) validRight += 1
          board.check(s"(x=$u, y=$v) view L", expected(0, u, v), beat.left)
          board.check(s"(x=$u, y=$v) view R", expected(1, u, v), beat.right)
          board.check(s"(x=$u, y=$v) sof", if (i == 0) 1 else 0, if (beat.sof) 1 else 0)
          board.check(s"(x=$u, y=$v) eol", if (u == w - 1) 1 else 0, if (beat.eol) 1 else 0)
          board.check(s"(x=$u, y=$v) eof", if (i == w * h - 1) 1 else 0, if (beat.eof) 1 else 0)
        }, 0.3, rnd, 200000, "uncovered")
      assert(board.ok, board.report)
      println(s"  ${p.name}: ${board.report} ($validRight valid right-view disparities)")
    }
  }

  def runSuite(config: String): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0xde)
    val all = cases(rnd)
    val tmp = tmpDir(s"dense-$config")
    val expected = all.zipWithIndex.map { case (c, i) => golden(p, c, tmp.resolve(f"golden$i%02d")) }
    simulate(new DenseMatcher(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      for ((c, g) <- all.zip(expected)) {
        val board = new DenseScoreboard(Seq(g), c.label)
        val traffic =
          Traffic3(rnd.nextDouble() * 0.6, rnd.nextDouble() * 0.9, rnd.nextDouble() * 0.9, rnd.nextDouble() * 0.6)
        stream(dut, Seq(g), traffic, rnd, board.check, choppyBound(Seq(g)), c.label)
        assert(board.board.ok, board.board.report)
        println(s"  ${p.name}: ${board.board.report} (${board.valid} valid disparities; $traffic)")
      }

      // planes and grid far ahead of / far behind the descriptors
      val sideCases = Seq((Traffic3(0.0, 0.0, 0.0, 0.5), "side streams early"),
        (Traffic3(0.0, 0.97, 0.97, 0.0), "side streams late"))
      for ((tr, name) <- sideCases) {
        val board = new DenseScoreboard(Seq(expected.head), s"${all.head.label}, $name")
        stream(dut, Seq(expected.head), tr, rnd, board.check, choppyBound(Seq(expected.head)) * 4, name)
        assert(board.board.ok, board.board.report)
        println(s"  ${p.name}: $name: ${board.board.report}")
      }

      val (w, h) = (p.maxWidth, p.maxHeight)
      val tputIdx = all.indexWhere(c => c.left.width == w && c.left.height == h && c.label.startsWith("bands"))
      val tput = new DenseScoreboard(Seq(expected(tputIdx)), all(tputIdx).label)
      val cycles = stream(dut, Seq(expected(tputIdx)), Traffic3(0, 0, 0, 0), rnd, tput.check,
        choppyBound(Seq(expected(tputIdx))), "throughput")
      assert(tput.board.ok, tput.board.report)
      val (bound, formula) = throughputBound(p, w, h)
      println(s"  ${p.name}: throughput ${w}x$h: $cycles cycles, bound $bound ($formula)")
      assert(cycles <= bound, s"throughput: $cycles cycles > bound $bound ($formula)")

      val b2bFrames = Seq(expected(0), expected(3), expected(0))
      val b2b = new DenseScoreboard(b2bFrames, "back to back KITTI/tsukuba/KITTI")
      val tr = Traffic3(0.1, 0.3, 0.3, 0.1)
      stream(dut, b2bFrames, tr, rnd, b2b.check, choppyBound(b2bFrames), "back to back")
      assert(b2b.board.ok, b2b.board.report)
      println(s"  ${p.name}: back to back: ${b2b.board.report} ($tr)")

      // back to back with a new size every frame (KITTI 128x64, cones 111x57, 32x16, bands 101x50)
      val sizes = Seq(0, 4, 7, 9).map(expected)
      val mixed = new DenseScoreboard(sizes, "back to back, sizes " + sizes.map(g => s"${g.w}x${g.h}").mkString(", "))
      stream(dut, sizes, tr, rnd, mixed.check, choppyBound(sizes), "back to back sizes")
      assert(mixed.board.ok, mixed.board.report)
      println(s"  ${p.name}: ${mixed.board.report}")

      runUncovered(p, dut, rnd)
    }
  }
}
