package ielas

import chisel3._
import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.Path
import scala.util.Random

/** Stage `interp` (Descriptor -> SupportMatcher -> SupportFilter -> LatticeFill) against the golden lattice_L.npy:
  * one Verilator build per fill rule (r7 at config `small`, paper at `small` with fillRule paper and sDelta 20),
  * real crops of KITTI 2012 and Middlebury, seeded pairs built to reach every branch of each rule, random input gaps
  * and output back-pressure, every lattice value and the framing compared, two frames back to back, a throughput
  * bound with no stalls. Which branch each node takes is counted from the golden filtered lattice and printed; the
  * spec fails when a branch is never reached.
  */
class LatticeFillSpec extends AnyFlatSpec {
  import LatticeFillSpec._

  behavior of "LatticeFill (Descriptor -> SupportMatcher -> SupportFilter -> LatticeFill chain)"

  it should "elaborate at every named frame size with both rules and keep up with 1 pixel per clock" in {
    // LatticeFill depends on the frame maxima, dispMax, step and the fill parameters only
    val distinct = ElasParams.named.groupBy(p => (p.maxWidth, p.maxHeight, p.dispMax, p.candidateStep, p.sDelta)).values.map(_.head)
    for (p0 <- distinct.toSeq.sortBy(_.name); rule <- FillRule.all) {
      val p = p0.copy(fillRule = rule)
      val dir = StreamTester.tmpDir(s"interp-elab/${p.name}-${rule.name}")
      VerilogEmitter.emit(LatticeFill(p), dir)
      // a lattice row arrives at most once per step pixel rows: step * W clocks at 1 pixel per clock
      val worst = (FrameSize.minWidth to p.maxWidth).map(w => (w, LatticeFill.rowCycles(p, p.latticeCount(w)), p.candidateStep * w))
      val (w, cycles, budget) = worst.maxBy { case (_, c, b) => c.toDouble / b }
      val bits = LatticeFill.memorySummary(p).map(_.bits).sum
      println(f"  ${p.name}%-18s ${rule.name}%-5s: ${LatticeFill.slots(p)}%2d slots, $bits%7d memory bits; worst row $cycles cycles of $budget at W = $w")
      assert(cycles <= budget, s"${p.name} ${rule.name}: a row of W = $w takes up to $cycles cycles > step * W = $budget")
    }
  }
  it should "match the golden filled lattice at config small (fill rule r7)" in {
    runSuite(ElasParams.byName("small"))
  }
  it should "match the golden filled lattice at config small with the paper's fill rule (sDelta 20 px)" in {
    runSuite(paperParams)
  }
  it should "forward a row's last support to the walk that starts on that row as it lands (fill rule r7, by hand)" in {
    // Rows arrive slowly (90 % input gaps), so the walk waits for each row and reads its first list entry in the
    // cycle the row's last write lands. Every row but row 0 has one support, its last node: that entry is the write.
    // Expected by hand from the r7 rule: a row with one support takes its value at every node.
    import StreamTester._
    val p = ElasParams.byName("small")
    val (w, h) = (32, 40)
    val (cols, rows) = (p.latticeCount(w), p.latticeCount(h))
    def support(j: Int): Int = if (j == 0) 7 else 10 + j
    val lattice = for (j <- 0 until rows; i <- 0 until cols)
      yield (if ((j == 0 && i == 0) || (j > 0 && i == cols - 1)) support(j) else -1, i == cols - 1, j == rows - 1)
    val expected = for (j <- 0 until rows; _ <- 0 until cols) yield BigInt(support(j))
    val rnd = new Random(seed)
    simulate(LatticeFill(p), tmpDir("interp-last-support")) { dut =>
      reset(dut)
      poke(dut.io.frameWidth, BigInt(w)); poke(dut.io.frameHeight, BigInt(h))
      for (frame <- 0 until 2) {
        val got = Array.fill[BigInt](expected.size)(-2)
        StreamTester.run[Framed[SInt], Framed[SInt], ((Int, Boolean, Boolean), Int), BigInt](dut.clock, dut.io.in,
          lattice.zipWithIndex.iterator, { case (b, ((v, eol, lastRow), k)) =>
            poke(b.data, BigInt(v)); poke(b.sof, k == 0); poke(b.eol, eol); poke(b.eof, eol && lastRow) },
          dut.io.out, expected.size, b => peek(b.data), (k, v) => got(k.toInt) = v, Traffic(0.9, 0.2), rnd,
          100L * expected.size, s"last support, frame $frame")
        val wrong = expected.indices.filter(k => got(k) != expected(k))
        assert(wrong.isEmpty, s"frame $frame: ${wrong.size} of ${expected.size} nodes wrong, first " +
          wrong.headOption.map(k => s"row ${k / cols} node ${k % cols}: ${got(k)}, expected ${expected(k)}").getOrElse(""))
      }
    }
  }
}

object LatticeFillSpec {
  import StreamTester._
  import SupportMatcherSpec.{Case, SupportScoreboard, streamFrames, choppyBound}

  /** `small` with the paper's rule. sDelta 20 px = 4 steps exactly (the inclusive bound is hit), 7 row slots, so
    * the ring wraps twice in a 14-row lattice; the golden model reads the same values from a JSON written here.
    */
  val paperParams: ElasParams = ElasParams.byName("small").copy(name = "small-paper", fillRule = FillRule.Paper, sDelta = 20)

  /** Two disparity regions split along a slanted line x = x0(y) (d1 left of it, d2 right; x0 moves by `slope` px per
    * pixel row and wraps within the middle half of the frame), a band of noise along the split (no supports there),
    * flat rows at the top (lattice rows 1, 2 without supports: row 0 from row 2 or all 0) and a flat band (lattice
    * rows without any support: copies of the row above). With |d1 - d2| > fillEpsilon the nodes in the noise band
    * take the jump rule; a steep positive slope puts d2 supports of the row above over the band of the row below,
    * so with d2 > d1 the jump picks hi.
    */
  def jumpPair(w: Int, h: Int, topFlat: Int, band: (Int, Int), d1: Int, d2: Int, rnd: Random, slope: Double = -0.5): Case = {
    val wide = TestImages.noise(w + 40, h, rnd)
    def flat(y: Int) = y < topFlat || (y >= band._1 && y < band._2)
    val left = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      (if (flat(y)) 128 else wide(x, y)).toByte
    })
    val right = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      val split = x - (w / 4 + Math.floorMod(w / 4 + (slope * y).floor.toInt, w / 2))
      if (flat(y)) 128.toByte
      else if (split >= -4 && split < 8) rnd.nextInt(256).toByte
      else wide(x + (if (split < 0) d1 else d2), y).toByte
    })
    Case(s"jump d $d1/$d2 slope $slope, flat rows 0..${topFlat - 1} and ${band._1}..${band._2 - 1}, ${w}x$h", left, right)
  }

  /** Disparity d1 above a flat band of rows and d2 below it: nodes in the band have no horizontal pair and, with the
    * band narrower than sDelta, a vertical pair of supports d1 / d2 (the paper's vertical mean or min).
    */
  def stackPair(w: Int, h: Int, band: (Int, Int), d1: Int, d2: Int, rnd: Random): Case = {
    val wide = TestImages.noise(w + 40, h, rnd)
    def flat(y: Int) = y >= band._1 && y < band._2
    val left = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      (if (flat(y)) 77 else wide(x, y)).toByte
    })
    val right = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      (if (flat(y)) 77 else wide(x + (if (y < band._1) d1 else d2), y)).toByte
    })
    Case(s"stacked d $d1/$d2 around flat rows ${band._1}..${band._2 - 1} ${w}x$h", left, right)
  }

  /** Textured blocks of one disparity on a flat background: long runs without supports in rows and columns. */
  def islandsPair(w: Int, h: Int, rnd: Random): Case = {
    val wide = TestImages.noise(w + 40, h, rnd)
    val blocks = Seq.fill(3)((rnd.nextInt(w - 24), rnd.nextInt(h - 20), 16 + rnd.nextInt(16)))
    def inBlock(x: Int, y: Int) = blocks.exists { case (bx, by, _) => x >= bx && x < bx + 24 && y >= by && y < by + 20 }
    def d(x: Int, y: Int) = blocks.find { case (bx, by, _) => x >= bx && x < bx + 24 && y >= by && y < by + 20 }.map(_._3).getOrElse(0)
    val left = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      (if (inBlock(x, y)) wide(x, y) else 90).toByte
    })
    val right = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      val xs = (x until (x + 40).min(w)).find(xx => inBlock(xx, y) && xx - d(xx, y) == x)
      (xs match { case Some(xx) => wide(xx, y); case None => 90 }).toByte
    })
    Case(s"textured islands ${blocks.map(b => s"${b._1},${b._2} d ${b._3}").mkString("; ")} ${w}x$h", left, right)
  }

  /** Which branch of the rule each node takes, from the golden filtered lattice (and, for r7's jumps, the golden
    * filled row above). For the coverage report only: the compared values all come from the golden dump.
    */
  def branches(p: ElasParams, f: NpyArray, filled: NpyArray, w: Int, h: Int): Map[String, Int] = {
    val (lh, lw) = (f.shape(0), f.shape(1))
    def s(j: Int, i: Int) = f(j.toLong * lw + i)
    def out(j: Int, i: Int) = filled(j.toLong * lw + i)
    val counts = scala.collection.mutable.Map[String, Int]().withDefaultValue(0)
    def hit(what: String): Unit = counts(what) += 1
    if (p.fillRule == FillRule.R7) {
      def rowBranches(r: Int, j: Int, above: Boolean): Unit = for (i <- 0 until lw) {
        val a = (i to 0 by -1).find(s(r, _) >= 0)
        val b = (i until lw).find(s(r, _) >= 0)
        (a, b) match {
          case (Some(x), _) if x == i => hit("support")
          case (Some(x), Some(y)) if (s(r, x) - s(r, y)).abs <= p.fillEpsilon => hit("interpolated")
          case (Some(x), Some(y)) if !above => hit("jump row 0 (lo)")
          case (Some(x), Some(y)) =>
            val (lo, hi) = (s(r, x).min(s(r, y)), s(r, x).max(s(r, y)))
            val u = out(j - 1, i)
            hit(if ((hi - u).abs < (lo - u).abs) "jump to hi (row above)" else if ((hi - u).abs == (lo - u).abs) "jump tie to lo" else "jump to lo (row above)")
          case _ => hit("one side only")
        }
      }
      for (j <- 0 until lh) {
        val has = (0 until lw).exists(s(j, _) >= 0)
        if (has) rowBranches(j, j, j > 0)
        else if (j > 0) hit("row copied from above")
        else (1 to 2).filter(_ < lh).find(r => (0 until lw).exists(s(r, _) >= 0)) match {
          case Some(r) => hit(s"row 0 from row $r"); rowBranches(r, 0, above = false)
          case None => hit("row 0 all zero")
        }
      }
    } else {
      def cx(i: Int) = (i * p.candidateStep).min(w - 1)
      def cy(j: Int) = (j * p.candidateStep).min(h - 1)
      def pairKind(da: Int, db: Int) = if ((da - db).abs <= p.epsilon) "mean" else "min"
      for (j <- 0 until lh; i <- 0 until lw) {
        if (s(j, i) >= 0) hit("support")
        else {
          val a = (i - 1 to 0 by -1).takeWhile(k => cx(i) - cx(k) <= p.sDelta).find(s(j, _) >= 0)
          val b = (i + 1 until lw).takeWhile(k => cx(k) - cx(i) <= p.sDelta).find(s(j, _) >= 0)
          val t = (j - 1 to 0 by -1).takeWhile(k => cy(j) - cy(k) <= p.sDelta).find(s(_, i) >= 0)
          val u = (j + 1 until lh).takeWhile(k => cy(k) - cy(j) <= p.sDelta).find(s(_, i) >= 0)
          if (a.nonEmpty && b.nonEmpty) hit(s"horizontal ${pairKind(s(j, a.get), s(j, b.get))}")
          else if (t.nonEmpty && u.nonEmpty) hit(s"vertical ${pairKind(s(t.get, i), s(u.get, i))}")
          else hit("constant")
          // the inclusive bound: a pair neighbour at exactly sDelta, and a nearest support just beyond it
          val hd = a.map(k => cx(i) - cx(k)).toSeq ++ b.map(k => cx(k) - cx(i))
          if (a.nonEmpty && b.nonEmpty && hd.contains(p.sDelta)) hit("horizontal pair at exactly sDelta")
          else if (t.nonEmpty && u.nonEmpty &&
            Seq(cy(j) - cy(t.get), cy(u.get) - cy(j)).contains(p.sDelta)) hit("vertical pair at exactly sDelta")
          val nearestLeft = (i - 1 to 0 by -1).find(s(j, _) >= 0).map(k => cx(i) - cx(k))
          val nearestRight = (i + 1 until lw).find(s(j, _) >= 0).map(k => cx(k) - cx(i))
          if ((nearestLeft ++ nearestRight).exists(d => d > p.sDelta && d <= p.sDelta + p.candidateStep) &&
            (a.isEmpty || b.isEmpty)) hit("no horizontal pair: a support just beyond sDelta")
        }
      }
    }
    counts.toMap
  }

  /** The branches the inputs must reach, per rule. */
  def required(p: ElasParams): Seq[String] =
    if (p.fillRule == FillRule.R7)
      Seq("interpolated", "jump to hi (row above)", "jump to lo (row above)", "jump row 0 (lo)", "one side only",
        "row copied from above", "row 0 from row 1", "row 0 from row 2", "row 0 all zero")
    else Seq("horizontal mean", "horizontal min", "vertical mean", "vertical min", "constant",
      "horizontal pair at exactly sDelta", "vertical pair at exactly sDelta", "no horizontal pair: a support just beyond sDelta")

  /** The golden model's configuration argument: a named configuration, or a JSON written from `p`. */
  def configArg(p: ElasParams, tmp: Path): String =
    if (ElasParams.named.contains(p)) p.name else ConfigJson.write(p, tmp).toString

  def golden(config: String, p: ElasParams, c: Case, dir: Path): (NpyArray, NpyArray) = {
    GoldenModel.dump(config, c.left, c.right, dir)
    val shape = Seq(p.latticeCount(c.left.height), p.latticeCount(c.left.width))
    def read(file: String) = {
      val a = NpyArray.read(dir.resolve(file))
      require(a.dtype == "<i2" && a.shape == shape, s"golden: $file has ${a.dtype} ${a.shape}, expected <i2 $shape")
      a
    }
    (read("lattice_L.npy"), read("support_filtered_L.npy"))
  }

  def runSuite(p: ElasParams): Unit = {
    val rnd = new Random(seed ^ p.name.hashCode ^ 0x1a77)
    val cases = SupportMatcherSpec.cases(rnd).filter(c => !c.label.startsWith("periodic")) ++ Seq(
      jumpPair(128, 64, 0, (25, 38), 5, 28, rnd), jumpPair(128, 64, 11, (30, 36), 28, 6, rnd),
      jumpPair(128, 64, 16, (40, 64), 4, 30, rnd), jumpPair(101, 50, 9, (20, 26), 3, 25, rnd),
      jumpPair(128, 64, 0, (64, 64), 5, 29, rnd, slope = 3), jumpPair(128, 64, 7, (64, 64), 30, 4, rnd, slope = -3),
      stackPair(128, 64, (24, 42), 6, 27, rnd), stackPair(128, 64, (22, 40), 12, 20, rnd),
      islandsPair(128, 64, rnd), islandsPair(90, 45, rnd),
      SupportFilterSpec.mixedPair(128, 64, rnd), SupportFilterSpec.sparsePair(128, 64, rnd))
    val tmp = tmpDir(s"interp-${p.name}")
    val config = configArg(p, tmp)
    println(s"  ${p.name}: fill rule ${p.fillRule.name}, golden --config $config")
    val expected = cases.zipWithIndex.map { case (c, i) => golden(config, p, c, tmp.resolve(f"golden$i%02d")) }
    val total = scala.collection.mutable.Map[String, Int]().withDefaultValue(0)
    simulate(new LatticeFillChain(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      for ((c, (exp, filtered)) <- cases.zip(expected)) {
        val board = new SupportScoreboard(exp, c.label, "interp")
        val traffic = Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5)
        streamFrames(dut, p, Seq((c.left, c.right)), traffic, rnd, board.check,
          choppyBound(p, c.left.width, c.left.height), c.label)
        assert(board.board.ok, board.board.report)
        val b = branches(p, filtered, exp, c.left.width, c.left.height)
        b.foreach { case (k, v) => total(k) += v }
        println(f"  ${p.name}: ${board.board.report} (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
        println(s"    branches: ${b.toSeq.sorted.map { case (k, v) => s"$k $v" }.mkString(", ")}")
      }
      println(s"  ${p.name}: branches over all cases: ${total.toSeq.sorted.map { case (k, v) => s"$k $v" }.mkString(", ")}")
      val missing = required(p).filter(total(_) == 0)
      assert(missing.isEmpty, s"the inputs never reach: ${missing.mkString(", ")}")

      val (w, h) = (p.maxWidth, p.maxHeight)
      val tputCase = cases.find(c => c.left.width == w && c.left.height == h && c.label.startsWith("mixed")).get
      val tput = new SupportScoreboard(expected(cases.indexOf(tputCase))._1, tputCase.label, "interp")
      val cycles = streamFrames(dut, p, Seq((tputCase.left, tputCase.right)), noStall, rnd, tput.check,
        choppyBound(p, w, h), "throughput")
      assert(tput.board.ok, tput.board.report)
      val (bound, formula) = throughputBound(p, w, h)
      println(s"  ${p.name}: throughput ${w}x$h: $cycles cycles, bound $bound ($formula)")
      assert(cycles <= bound, s"throughput: $cycles cycles > bound $bound ($formula)")

      // Two different frames of one size back to back: nothing of the first may leak into the second.
      val pairIdx = cases.indices.filter(i => cases(i).left.width == w && cases(i).left.height == h &&
        (cases(i).label.startsWith("jump") || cases(i).label.startsWith("stacked"))).take(2)
      val boards = pairIdx.map(i => new SupportScoreboard(expected(i)._1, cases(i).label + " (back to back)", "interp"))
      val frameNodes = p.latticeCount(w).toLong * p.latticeCount(h)
      streamFrames(dut, p, pairIdx.map(i => (cases(i).left, cases(i).right)), Traffic(0.1, 0.1), rnd,
        (index, beat) => boards((index / frameNodes).toInt).check(index % frameNodes, beat),
        choppyBound(p, w, h, 2), "back to back")
      boards.foreach(b => assert(b.board.ok, b.board.report))
      println(s"  ${p.name}: two different frames back to back: ${boards.map(_.board.report).mkString("; ")}")
    }
  }

  /** The filter's bound plus the rows the fill still holds when the filter's last node arrives. */
  def throughputBound(p: ElasParams, w: Int, h: Int): (Long, String) = {
    val (base, _) = SupportFilterSpec.throughputBound(p, w, h)
    val c = LatticeFill.slots(p) * LatticeFill.rowCycles(p, p.latticeCount(w))
    (base + c, s"filter bound + slots * rowCycles = filter bound + $c")
  }
}
