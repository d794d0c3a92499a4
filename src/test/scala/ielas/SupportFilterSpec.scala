package ielas

import org.scalatest.flatspec.AnyFlatSpec

import scala.util.Random

/** Stage `filter` (Descriptor -> SupportMatcher -> SupportFilter) against the golden support_filtered_L.npy: one
  * Verilator build at config `small`, real crops and seeded pairs with many (and mixed) supports, random input gaps
  * and output back-pressure, every lattice value and the framing compared, two frames back to back, a throughput
  * bound with no stalls.
  */
class SupportFilterSpec extends AnyFlatSpec {
  import SupportFilterSpec._

  behavior of "SupportFilter (Descriptor -> SupportMatcher -> SupportFilter chain)"

  it should "match the golden filtered support lattice at config small" in {
    runSuite("small")
  }
}

object SupportFilterSpec {
  import StreamTester._
  import SupportMatcherSpec.{Case, SupportScoreboard, shiftedPair, streamFrames, choppyBound}

  /** Bands of rows with different shifts plus noise blocks: supports that agree, disagree and stand alone. */
  def mixedPair(w: Int, h: Int, rnd: Random): Case = {
    val shifts = Seq.fill(4)(3 + rnd.nextInt(25))
    val wide = TestImages.noise(w + 32, h, rnd)
    val left = GrayImage(w, h, Array.tabulate(w * h)(i => wide(i % w, i / w).toByte))
    val right = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      val band = (y / 12 + x / 40) % shifts.length
      if ((x / 16 + y / 8) % 5 == 0) rnd.nextInt(256).toByte else wide(x + shifts(band), y).toByte
    })
    Case(s"mixed shifts ${shifts.mkString("/")} ${w}x$h", left, right)
  }

  /** Independent noise except in random 12x12 squares that match with a shift of 10, 15, 16 or 21: clusters of
    * supports whose neighbours agree (|15 - 10| = 5 = inconThreshold) or just do not (|16 - 10| = 6), with
    * agreeing counts around inconMinSupport.
    */
  def sparsePair(w: Int, h: Int, rnd: Random): Case = {
    val wide = TestImages.noise(w + 32, h, rnd)
    val left = GrayImage(w, h, Array.tabulate(w * h)(i => wide(i % w, i / w).toByte))
    val squares = Seq.fill(w * h / 700)((rnd.nextInt(w), rnd.nextInt(h), Seq(10, 15, 16, 21)(rnd.nextInt(4))))
    val right = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      squares.find { case (sx, sy, _) => x + 21 >= sx && x + 21 < sx + 12 && y >= sy && y < sy + 12 } match {
        case Some((_, _, d)) if x + d < wide.width => wide(x + d, y).toByte
        case _ => rnd.nextInt(256).toByte
      }
    })
    Case(s"sparse squares ${w}x$h", left, right)
  }

  def golden(p: ElasParams, c: Case, dir: java.nio.file.Path): NpyArray = {
    GoldenModel.dump(p.name, c.left, c.right, dir)
    val a = NpyArray.read(dir.resolve("support_filtered_L.npy"))
    val shape = Seq(p.latticeCount(c.left.height), p.latticeCount(c.left.width))
    require(a.dtype == "<i2" && a.shape == shape, s"golden: support_filtered_L.npy has ${a.dtype} ${a.shape}, expected <i2 $shape")
    a
  }

  def runSuite(config: String): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0xf1)
    val all = SupportMatcherSpec.cases(rnd) ++ Seq(mixedPair(128, 64, rnd), mixedPair(101, 50, rnd),
      shiftedPair(32, 16, 2, rnd), sparsePair(128, 64, rnd), sparsePair(128, 64, rnd), sparsePair(90, 60, rnd))
    val tmp = tmpDir(s"filter-$config")
    val expected = all.zipWithIndex.map { case (c, i) => golden(p, c, tmp.resolve(f"golden$i%02d")) }
    val unfiltered = all.indices.map { i => // supports before the filter, for the report only
      val a = NpyArray.read(tmp.resolve(f"golden$i%02d").resolve("support_L.npy"))
      (0L until a.count).count(a(_) >= 0)
    }
    simulate(new SupportFilterChain(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      for (((c, exp), before) <- all.zip(expected).zip(unfiltered)) {
        val board = new SupportScoreboard(exp, c.label, "filter")
        val traffic = Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5)
        streamFrames(dut, p, Seq((c.left, c.right)), traffic, rnd, board.check,
          choppyBound(p, c.left.width, c.left.height), c.label)
        assert(board.board.ok, board.board.report)
        println(f"  ${p.name}: ${board.board.report}, ${board.supports} of $before supports kept (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
      }

      val (w, h) = (p.maxWidth, p.maxHeight)
      val tputCase = all.find(c => c.left.width == w && c.left.height == h && c.label.startsWith("mixed")).get
      val tput = new SupportScoreboard(expected(all.indexOf(tputCase)), tputCase.label, "filter")
      val cycles = streamFrames(dut, p, Seq((tputCase.left, tputCase.right)), noStall, rnd, tput.check,
        choppyBound(p, w, h), "throughput")
      assert(tput.board.ok, tput.board.report)
      val (bound, formula) = throughputBound(p, w, h)
      println(s"  ${p.name}: throughput ${w}x$h: $cycles cycles, bound $bound ($formula)")
      assert(cycles <= bound, s"throughput: $cycles cycles > bound $bound ($formula)")

      val b2b = new SupportScoreboard(expected.head, all.head.label + " x2", "filter")
      streamFrames(dut, p, Seq.fill(2)((all.head.left, all.head.right)), Traffic(0.1, 0.1), rnd, b2b.check,
        choppyBound(p, all.head.left.width, all.head.left.height, 2), "back to back")
      assert(b2b.board.ok, b2b.board.report)
      println(s"  ${p.name}: back to back: ${b2b.board.report}")
    }
  }

  /** The filter emits lattice row j once row j + k has arrived; after the last support row it drains the rest. */
  def throughputBound(p: ElasParams, w: Int, h: Int): (Long, String) = {
    val (base, _) = SupportMatcherSpec.throughputBound(p, w, h)
    val c = SupportFilterSpec.drainSlack(p, w, h)
    (base + c, s"support bound + $c")
  }
  /** Draining the rows after the last input pixel: at most 2k + 5 cycles per node (a support node; the stage's
    * documented schedule) of the last k + 1 rows. */
  def drainSlack(p: ElasParams, w: Int, h: Int): Int =
    (p.inconWindowSize + 1) * p.latticeCount(w) * (2 * p.inconWindowSize + 5)
}
