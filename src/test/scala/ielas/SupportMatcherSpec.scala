package ielas

import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.Path
import scala.util.Random

/** Stage `support` (Descriptor -> SupportMatcher) against the golden support_L.npy: one Verilator build at config
  * `small` streams real crops and seeded random pairs under random input gaps and output back-pressure, checks
  * every lattice value and the framing, then a throughput bound with no stalls and two frames back to back.
  */
class SupportMatcherSpec extends AnyFlatSpec {
  import SupportMatcherSpec._

  behavior of "SupportMatcher (Descriptor -> SupportMatcher chain)"

  it should "match the golden support lattice at config small, with the throughput bound" in {
    runSuite("small")
  }
  it should "schedule a node within ElasParams' per-point budget at every named configuration" in {
    for (p <- ElasParams.named) {
      val worst = SupportMatcher.nodeCycles(p, p.dispMax, p.dispMax) // node start, 2 x (blocks + decision)
      assert(worst <= p.supportCyclesPerPoint, s"${p.name}: $worst cycles per node > budget ${p.supportCyclesPerPoint}")
      // a lattice row's last searched node waits for its left result; the row's first node (never searched) pays it
      assert(ElasParams.supportDrainCycles + 1 <= p.supportCyclesPerPoint, s"${p.name}: no room for the row's drain")
      assert(p.supportMargin > 0, s"${p.name}: the row's first node would be searched")
    }
  }
  it should "match the golden support lattice at config small-w7 (windowSize 7: 3 row slots, 16 banks)" in {
    runSuite("small-w7", extensive = false)
  }
  it should "match the golden support lattice at config small-c4 (one pixel every 4 cycles: 8 lanes)" in {
    runSuite("small-c4", extensive = false)
  }
  it should "match the golden support lattice at kitti width (1242x16, dispMax 255), with the throughput bound" in {
    runKittiWidth()
  }
}

object SupportMatcherSpec {
  import StreamTester._

  case class Case(label: String, left: GrayImage, right: GrayImage)

  /** One output beat of the support stream. */
  case class SupportBeat(value: Int, sof: Boolean, eol: Boolean, eof: Boolean)

  /** Left texture; the right view is the left shifted by `shift` columns, so most nodes find support `shift`. */
  def shiftedPair(w: Int, h: Int, shift: Int, rnd: Random): Case = {
    val wide = TestImages.noise(w + shift, h, rnd)
    Case(s"shifted texture ${w}x$h by $shift", wide.crop(0, 0, w, h), wide.crop(shift, 0, w, h)) // R(x - d) = L(x)
  }

  /** Columns repeat with period 8 and the right view is shifted by 3: cost 0 at d = 3, 11, 19, ..., so E1 = E2 = 0
    * and every such node must be rejected (strict ratio test, E2 counting the tied minimum). With `jitter`, small
    * noise makes E1 and E2 close but not equal: ratios near the threshold.
    */
  def periodicPair(w: Int, h: Int, jitter: Int, rnd: Random): Case = {
    val tile = TestImages.noise(8, h, rnd)
    def view(shift: Int) = GrayImage(w, h, Array.tabulate(w * h) { i =>
      val (x, y) = (i % w, i / w)
      val n = if (jitter > 0) rnd.nextInt(2 * jitter + 1) - jitter else 0
      (tile((x + shift) % 8, y) + n).max(0).min(255).toByte
    })
    Case(s"periodic texture (period 8, jitter $jitter) ${w}x$h", view(0), view(3))
  }

  def cases(rnd: Random): Seq[Case] = {
    val (kl, kr) = TestImages.kitti2012
    val (tl, tr) = TestImages.middleburyTsukuba
    val (cl, cr) = TestImages.middleburyCones
    def flat(w: Int, h: Int) = { val v = rnd.nextInt(256); Case(s"flat $v ${w}x$h", TestImages.flat(w, h, v), TestImages.flat(w, h, v)) }
    def noise(w: Int, h: Int) = Case(s"noise ${w}x$h", TestImages.noise(w, h, rnd), TestImages.noise(w, h, rnd))
    Seq(
      Case("KITTI 2012 000070 crop 128x64 at (600,150)", kl.crop(600, 150, 128, 64), kr.crop(600, 150, 128, 64)),
      Case("Middlebury tsukuba crop 128x64 at (120,110)", tl.crop(120, 110, 128, 64), tr.crop(120, 110, 128, 64)),
      Case("Middlebury cones crop 111x57 at (200,150)", cl.crop(200, 150, 111, 57), cr.crop(200, 150, 111, 57)),
      shiftedPair(128, 64, 9, rnd), shiftedPair(97, 41, 20, rnd), shiftedPair(32, 16, 3, rnd),
      noise(128, 64), noise(33, 17), flat(40, 20), periodicPair(128, 64, 0, rnd), periodicPair(128, 64, 6, rnd))
  }

  /** Expected lattice of a pair from the golden model's dump. */
  def golden(p: ElasParams, c: Case, dir: Path): NpyArray = {
    GoldenModel.dump(p.name, c.left, c.right, dir)
    val a = NpyArray.read(dir.resolve("support_L.npy"))
    val shape = Seq(p.latticeCount(c.left.height), p.latticeCount(c.left.width))
    require(a.dtype == "<i2" && a.shape == shape, s"golden: support_L.npy has ${a.dtype} ${a.shape}, expected <i2 $shape")
    a
  }

  /** Checks lattice values and framing of frames of one size following each other. */
  class SupportScoreboard(expected: NpyArray, label: String, stage: String = "support") {
    val board = new Scoreboard(s"$stage [$label]")
    private val (lh, lw) = (expected.shape(0), expected.shape(1))
    def check(index: Long, beat: SupportBeat): Unit = {
      val node = index % (lh.toLong * lw)
      val (j, i) = ((node / lw).toInt, (node % lw).toInt)
      def at = s"frame ${index / (lh.toLong * lw)} lattice (row $j, col $i)"
      board.check(s"$at value", expected(node), beat.value)
      board.check(s"$at sof", if (node == 0) 1 else 0, if (beat.sof) 1 else 0)
      board.check(s"$at eol", if (i == lw - 1) 1 else 0, if (beat.eol) 1 else 0)
      board.check(s"$at eof", if (node == lh.toLong * lw - 1) 1 else 0, if (beat.eof) 1 else 0)
    }
    def supports: Long = (0L until expected.count).count(expected(_) >= 0).toLong
  }

  /** Streams same-size frames through the chain and hands every lattice output to `sink`; returns the cycles. */
  def streamFrames(dut: LatticeChain, p: ElasParams, frames: Seq[(GrayImage, GrayImage)], traffic: Traffic, rnd: Random,
      sink: (Long, SupportBeat) => Unit, maxCycles: Long, what: String): Long = {
    val (w, h) = (frames.head._1.width, frames.head._1.height)
    poke(dut.io.frameWidth, w)
    poke(dut.io.frameHeight, h)
    val outputs = frames.length.toLong * p.latticeCount(w) * p.latticeCount(h)
    run[PixelPair, Framed[chisel3.SInt], PixelBeat, SupportBeat](dut.clock, dut.io.in, pixelBeats(frames), pokePixel,
      dut.io.out, outputs,
      o => SupportBeat(peek(o.data).toInt, peek(o.sof), peek(o.eol), peek(o.eof)),
      sink, traffic, rnd, maxCycles, what)
  }

  /** Every transfer may wait on both a gap and a stall, and the search adds step rows. */
  def choppyBound(p: ElasParams, w: Int, h: Int, frames: Int = 1): Long =
    20L * (frames * (w * h + (p.descriptorMargin + p.candidateStep + 1) * w)) + 10000

  /** The no-stall bound: cyclesPerPixel x (N + latencyRows * W) + c, latencyRows = descriptor rows + search rows
    * (the search schedule keeps up with one pixel every cyclesPerPixel clocks).
    */
  def throughputBound(p: ElasParams, w: Int, h: Int): (Long, String) = {
    val rows = Descriptor.latencyRows(p) + SupportMatcher.latencyRows(p)
    val (cpp, c) = (p.cyclesPerPixel, Descriptor.cycleSlack(p) + cycleSlack)
    (cpp * (w.toLong * h + rows * w) + c, s"$cpp x (N + $rows*W) + $c")
  }
  /** Cycles beyond the rows: the search of the last active node and the output register. */
  val cycleSlack: Int = 8

  /** The one kitti-width build of `make test`: full 1242 columns and 256 disparities, 16 rows. */
  def runKittiWidth(): Unit = {
    val p = ElasParams.byName("kitti")
    val rnd = new Random(seed ^ 0x4b17)
    val (kl, kr) = TestImages.kitti2012
    val (w, h) = (p.maxWidth, 16)
    val all = Seq( // KITTI 2012 000070 is 1241 wide: the synthetic pairs are 1242
      Case(s"KITTI 2012 000070 ${kl.width}x$h rows 150..165", kl.crop(0, 150, kl.width, h), kr.crop(0, 150, kl.width, h)),
      shiftedPair(w, h, 37, rnd), shiftedPair(w, h, 230, rnd))
    val tmp = tmpDir("support-kitti")
    val expected = all.zipWithIndex.map { case (c, i) => golden(p, c, tmp.resolve(f"golden$i%02d")) }
    simulate(new SupportChain(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      for (((c, exp), i) <- all.zip(expected).zipWithIndex) {
        val board = new SupportScoreboard(exp, c.label)
        // the first pair with no stalls: the throughput bound at full width and the whole disparity range
        val traffic = if (i == 1) noStall else Traffic(rnd.nextDouble() * 0.3, rnd.nextDouble() * 0.3)
        val t0 = System.nanoTime()
        val cycles = streamFrames(dut, p, Seq((c.left, c.right)), traffic, rnd, board.check, choppyBound(p, c.left.width, h), c.label)
        assert(board.board.ok, board.board.report)
        println(f"  kitti: ${board.board.report}, ${board.supports} supports, $cycles cycles in ${(System.nanoTime() - t0) / 1e9}%.1f s (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
        if (traffic == noStall) {
          val (bound, formula) = throughputBound(p, w, h)
          println(s"  kitti: throughput ${w}x$h: $cycles cycles, bound $bound ($formula)")
          assert(cycles <= bound, s"throughput: $cycles cycles > bound $bound ($formula)")
        }
      }
    }
  }

  def runSuite(config: String, extensive: Boolean = true): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0x5a)
    val all = if (extensive) cases(rnd) else cases(rnd).filter(c => !c.label.startsWith("noise") && !c.label.startsWith("flat"))
    val tmp = tmpDir(s"support-$config")
    val expected = all.zipWithIndex.map { case (c, i) => golden(p, c, tmp.resolve(f"golden$i%02d")) }
    val (w, h) = (p.maxWidth, p.maxHeight)
    val tput = shiftedPair(w, h, 11, rnd)
    val tputExpected = golden(p, tput, tmp.resolve("golden-throughput"))
    simulate(new SupportChain(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      for ((c, exp) <- all.zip(expected)) {
        val board = new SupportScoreboard(exp, c.label)
        val traffic = Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5)
        streamFrames(dut, p, Seq((c.left, c.right)), traffic, rnd, board.check,
          choppyBound(p, c.left.width, c.left.height), c.label)
        assert(board.board.ok, board.board.report)
        println(f"  ${p.name}: ${board.board.report}, ${board.supports} supports (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
      }

      // Throughput with no stalls, on the pair with the most supports (every node searches both views).
      val board = new SupportScoreboard(tputExpected, tput.label)
      val cycles = streamFrames(dut, p, Seq((tput.left, tput.right)), noStall, rnd, board.check, choppyBound(p, w, h), "throughput")
      assert(board.board.ok, board.board.report)
      val (bound, formula) = throughputBound(p, w, h)
      println(s"  ${p.name}: throughput ${w}x$h (${board.supports} supports): $cycles cycles, bound $bound ($formula)")
      assert(cycles <= bound, s"throughput: $cycles cycles > bound $bound ($formula)")

      // Two frames back to back in one stream.
      val b2b = new SupportScoreboard(expected.head, all.head.label + " x2")
      streamFrames(dut, p, Seq.fill(2)((all.head.left, all.head.right)), Traffic(0.1, 0.1), rnd, b2b.check,
        choppyBound(p, all.head.left.width, all.head.left.height, 2), "back to back")
      assert(b2b.board.ok, b2b.board.report)
      println(s"  ${p.name}: back to back: ${b2b.board.report}")
    }
  }
}
