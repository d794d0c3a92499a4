package ielas

import org.scalatest.flatspec.AnyFlatSpec

import scala.util.Random

/** The descriptor stage through its [[DescriptorChain]]: one Verilator build per configuration, many images and seeds
  * through it, random input gaps and output back-pressure, every byte compared with hand values or the golden dump.
  */
class DescriptorSpec extends AnyFlatSpec {
  import DescriptorSpec._

  behavior of "Descriptor (DescriptorChain)"

  it should "match hand values and the golden model at config small (windowSize 5), with the throughput bound" in {
    runSuite("small", extensive = true)
  }
  it should "match hand values and the golden model at config small-w3 (windowSize 3)" in {
    runSuite("small-w3", extensive = false)
  }
  it should "match hand values and the golden model at config small-w7 (windowSize 7)" in {
    runSuite("small-w7", extensive = false)
  }
}

object DescriptorSpec {
  import StreamTester._

  /** An image pair and where its expected descriptors come from. */
  case class Case(label: String, left: GrayImage, right: GrayImage, hand: Option[(Int, Int, Int, Int) => Int] = None)

  /** The byte layout of docs/ALGORITHM.md §2, written out again here: (is du, dx, dy). */
  def layout(r: Int): Seq[(Boolean, Int, Int)] = Seq(
    (true, 0, -r), (true, -r, -1), (true, 0, -1), (true, r, -1), (true, -1, 0), (true, 0, 0), (true, 0, 0), (true, 1, 0),
    (true, -r, 1), (true, 0, 1), (true, r, 1), (true, 0, r), (false, 0, -1), (false, -1, 0), (false, 1, 0), (false, 0, 1))

  /** Expected bytes from hand-computed gradient maps, with the zero border of docs/ALGORITHM.md §2. */
  def fromGradients(p: ElasParams, w: Int, h: Int, du: (Int, Int) => Int, dv: (Int, Int) => Int)(view: Int, x: Int, y: Int, k: Int): Int = {
    val m = p.descriptorMargin
    if (x < m || x > w - 1 - m || y < m || y > h - 1 - m) 0
    else {
      val (isDu, dx, dy) = layout(p.windowRadius)(k)
      if (isDu) du(x + dx, y + dy) else dv(x + dx, y + dy)
    }
  }

  /** A single 255 pixel at (x0, y0) on black. Gradients by hand (docs/ALGORITHM.md, descriptor step 1):
    * S(y0,x0) = 510, S(y0+-1,x0) = 255, so du(x0+1, y0) = (510 >> 2) + 128 = 255,
    * du(x0-1, y0) = (-510 >> 2) + 128 = -128 + 128 = 0, du(x0+1, y0+-1) = (255 >> 2) + 128 = 191,
    * du(x0-1, y0+-1) = (-255 >> 2) + 128 = -64 + 128 = 64;
    * T(y0+1, x0) = 255, T(y0-1, x0) = -255, so dv(x0, y0+1) = 255, dv(x0+-1, y0+1) = 191, dv(x0, y0-1) = 0,
    * dv(x0+-1, y0-1) = 64; every other gradient is 128.
    */
  def impulse(p: ElasParams, w: Int, h: Int, x0: Int, y0: Int): Case = {
    val img = GrayImage(w, h, Array.tabulate(w * h)(i => (if (i == y0 * w + x0) 255 else 0).toByte))
    val du = (x: Int, y: Int) => (x - x0, y - y0) match {
      case (1, 0) => 255; case (-1, 0) => 0; case (1, 1) | (1, -1) => 191; case (-1, 1) | (-1, -1) => 64; case _ => 128
    }
    val dv = (x: Int, y: Int) => (x - x0, y - y0) match {
      case (0, 1) => 255; case (1, 1) | (-1, 1) => 191; case (0, -1) => 0; case (1, -1) | (-1, -1) => 64; case _ => 128
    }
    Case(s"impulse ${w}x$h at ($x0,$y0)", img, img, Some(fromGradients(p, w, h, du, dv)))
  }

  /** I = 4x + 3y: S = 16x + 12y, T = -6, so du = (-32 >> 2) + 128 = 120 and dv = (-24 >> 2) + 128 = 122 inside.
    * The right view is the same ramp, which must give the same bytes.
    */
  def ramp(p: ElasParams, w: Int, h: Int): Case = {
    require(4 * (w - 1) + 3 * (h - 1) <= 255)
    val img = GrayImage(w, h, Array.tabulate(w * h)(i => (4 * (i % w) + 3 * (i / w)).toByte))
    Case(s"ramp ${w}x$h", img, img, Some(fromGradients(p, w, h, (_, _) => 120, (_, _) => 122)))
  }

  def cases(p: ElasParams, rnd: Random, extensive: Boolean): Seq[Case] = {
    val (kl, kr) = TestImages.kitti2012
    val (tl, tr) = TestImages.middleburyTsukuba
    val (cl, cr) = TestImages.middleburyCones
    val hand = Seq(impulse(p, 40, 20, 20, 10), impulse(p, 33, 16, 5, 7), ramp(p, 40, 20))
    val real = Seq(
      Case("KITTI 2012 000070 crop 128x64 at (600,150)", kl.crop(600, 150, 128, 64), kr.crop(600, 150, 128, 64)),
      Case("Middlebury tsukuba crop 128x64 at (120,110)", tl.crop(120, 110, 128, 64), tr.crop(120, 110, 128, 64)))
    def rand(label: String, w: Int, h: Int, gen: (Int, Int, Random) => GrayImage) =
      Case(s"$label ${w}x$h", gen(w, h, rnd), gen(w, h, rnd))
    val flat = (w: Int, h: Int, r: Random) => TestImages.flat(w, h, r.nextInt(256))
    val randoms = Seq(
      rand("noise", 32, 16, TestImages.noise), rand("saturated 0/255", 33, 17, TestImages.saturated),
      rand("noise", 97, 41, TestImages.noise))
    val more = if (!extensive) Nil else Seq(
      Case("KITTI 2012 000070 crop 97x41 at (301,203)", kl.crop(301, 203, 97, 41), kr.crop(301, 203, 97, 41)),
      Case("Middlebury cones crop 111x64 at (200,150)", cl.crop(200, 150, 111, 64), cr.crop(200, 150, 111, 64)),
      rand("flat", 32, 16, flat), rand("flat", 128, 64, flat), rand("noise", 128, 64, TestImages.noise),
      rand("saturated 0/255", 128, 64, TestImages.saturated), rand("smooth", 77, 50, TestImages.smooth),
      rand("noise", 127, 63, TestImages.noise))
    hand ++ real ++ randoms ++ more
  }

  /** The expected-byte function of a case: its hand values, or the golden dump of the pair. */
  def expectation(p: ElasParams, c: Case, index: Int): DescriptorScoreboard = c.hand match {
    case Some(f) => new DescriptorScoreboard(c.left.width, c.left.height, f, s" [${c.label}]")
    case None =>
      val dir = tmpDir(s"descriptor-${p.name}-golden").resolve(f"case$index%02d")
      GoldenModel.dump(p.name, c.left, c.right, dir)
      DescriptorScoreboard.fromDump(dir, c.left.width, c.left.height, s" [${c.label}]")
  }

  /** Generous bound for choppy traffic: every transfer may wait on both a gap and a stall. */
  def choppyBound(p: ElasParams, w: Int, h: Int, frames: Int = 1): Long =
    20L * (frames * w * h + Descriptor.latencySteps(p, w)) + 1000

  def runSuite(config: String, extensive: Boolean): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode)
    val all = cases(p, rnd, extensive)
    val boards = all.zipWithIndex.map { case (c, i) => expectation(p, c, i) } // golden runs before the build
    simulate(new DescriptorChain(p), tmpDir(s"descriptor-$config")) { dut =>
      reset(dut)
      for ((c, board) <- all.zip(boards)) {
        val traffic = Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5)
        streamDescriptorFrames(dut, Seq((c.left, c.right)), traffic, rnd, board.check,
          choppyBound(p, c.left.width, c.left.height), c.label)
        assert(board.board.ok, board.board.report)
        println(f"  ${p.name}: ${board.board.report} (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
      }

      // Throughput with no stalls: N transfers complete in N + latencyRows * W + c cycles.
      val (w, h) = (p.maxWidth, p.maxHeight)
      val tput = Case("noise max size", TestImages.noise(w, h, rnd), TestImages.noise(w, h, rnd))
      val tputBoard = expectation(p, tput, 90)
      val cycles = streamDescriptorFrames(dut, Seq((tput.left, tput.right)), noStall, rnd, tputBoard.check,
        choppyBound(p, w, h), "throughput")
      assert(tputBoard.board.ok, tputBoard.board.report)
      val bound = w.toLong * h + Descriptor.latencyRows(p) * w + Descriptor.cycleSlack(p)
      println(s"  ${p.name}: throughput ${w}x$h: $cycles cycles, bound $bound (N + ${Descriptor.latencyRows(p)}*W + ${Descriptor.cycleSlack(p)})")
      assert(cycles <= bound, s"throughput: $cycles cycles > bound $bound")

      // Two frames back to back in one stream, and an illegal frame size that must be flagged and dropped.
      val a = all.find(_.hand.isEmpty).get
      val b2b = expectation(p, a, 91)
      streamDescriptorFrames(dut, Seq((a.left, a.right), (a.left, a.right)), Traffic(0.1, 0.1), rnd, b2b.check,
        choppyBound(p, a.left.width, a.left.height, 2), "back to back")
      assert(b2b.board.ok, b2b.board.report)
      assert(!peek(dut.io.error), "error raised by legal frames")
      if (extensive) {
        illegalSizes(p, dut, a, rnd)
        shortFrameResync(p, dut, a, rnd)
      }
    }
  }

  /** A frame cut short by 3 rows, then a whole frame: the stage must not hang. It completes the short frame with
    * the next frame's pixels (this stage does not check framing yet), drops the rest up to the next start of frame,
    * and the frame after that comes out bit-exact.
    */
  def shortFrameResync(p: ElasParams, dut: DescriptorChain, good: Case, rnd: Random): Unit = {
    val (w, h) = (good.left.width, good.left.height)
    val short = w * (h - 3)
    val beats = Iterator.range(0, short).map(i => (i, i == 0)) ++ Iterator.range(0, w * h).map(i => (i, i == 0))
    run[PixelPair, Framed[DescriptorPair], (Int, Boolean), Int](dut.clock, dut.io.in, beats,
      (bits, b) => { poke(bits.left, good.left.pixels(b._1) & 0xff); poke(bits.right, good.right.pixels(b._1) & 0xff)
        poke(bits.sof, b._2); poke(bits.eol, b._1 % w == w - 1) },
      dut.io.out, w.toLong * h, _ => 0, (_, _) => (), Traffic(0.2, 0.2), rnd, choppyBound(p, w, h, 2), "short frame")
    val board = expectation(p, good, 93)
    streamDescriptorFrames(dut, Seq((good.left, good.right)), Traffic(0.2, 0.2), rnd, board.check,
      choppyBound(p, w, h), "after a short frame")
    assert(board.board.ok, board.board.report)
    println(s"  ${p.name}: a short frame is completed, the next frame dropped, the one after it is bit-exact")
  }

  /** A frame narrower than 32 or wider than maxWidth is flagged and dropped; the next legal frame is intact. */
  def illegalSizes(p: ElasParams, dut: DescriptorChain, good: Case, rnd: Random): Unit = {
    for ((w, h) <- Seq((31, 16), (32, 15), (p.maxWidth + 1, 16), (32, p.maxHeight + 1))) {
      val img = TestImages.noise(w, h, rnd)
      poke(dut.io.frameWidth, w); poke(dut.io.frameHeight, h)
      val beats = Iterator.range(0, w * h).map(i => i)
      run[PixelPair, Framed[DescriptorPair], Int, Int](dut.clock, dut.io.in, beats,
        (bits, i) => { poke(bits.left, img.pixels(i) & 0xff); poke(bits.right, 0); poke(bits.sof, i == 0); poke(bits.eol, i % w == w - 1) },
        dut.io.out, 0, _ => 0, (_, _) => (), Traffic(0.2, 0.2), rnd, 20L * w * h + 1000, s"illegal ${w}x$h")
      step(dut.clock, 20)
      assert(!peek(dut.io.out.valid), s"illegal ${w}x$h: frame not dropped")
      assert(peek(dut.io.error), s"illegal ${w}x$h: error not raised")
      poke(dut.io.clearError, true); step(dut.clock); poke(dut.io.clearError, false)
      assert(!peek(dut.io.error), s"illegal ${w}x$h: clearError did not clear")
      val board = expectation(p, good, 92)
      streamDescriptorFrames(dut, Seq((good.left, good.right)), Traffic(0.2, 0.2), rnd, board.check,
        choppyBound(p, good.left.width, good.left.height), s"after illegal ${w}x$h")
      assert(board.board.ok, board.board.report)
    }
    println(s"  ${p.name}: illegal sizes flagged, dropped and cleared")
  }
}
