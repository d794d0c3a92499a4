package ielas

import org.scalatest.flatspec.AnyFlatSpec

import scala.util.Random

/** Stage `lrcheck` on its own: one Verilator build at config `small`. Inputs are the golden model's dense_L/R.npy
  * of real crops (KITTI 2012, KITTI 2015, Middlebury tsukuba and cones) and seeded random pairs, compared with its
  * lrcheck_L/R.npy; and hand-built dense maps aimed at the rule's edges (|dR - d| = threshold and threshold + 1,
  * u - d < 0, u + d >= W, -1 on the other side with d <= 1), compared with an independent computation here (which
  * is itself checked against the golden dumps). Every pixel of both views and the framing is compared, under random
  * input gaps and output back-pressure, with frames of different sizes back to back, and a no-stall cycle bound.
  */
class LrCheckSpec extends AnyFlatSpec {
  import LrCheckSpec._

  behavior of "LrCheck"

  it should "match the golden lrcheck maps and hand-built edge cases at config small, with the throughput bound" in {
    runSuite("small")
  }
}

object LrCheckSpec {
  import StreamTester._

  /** One frame of the dense stream and the expected lrcheck maps (row-major, -1 = invalid). */
  case class DenseFrame(label: String, width: Int, height: Int, denseL: Array[Int], denseR: Array[Int],
      expL: Array[Int], expR: Array[Int])

  /** docs/ALGORITHM.md "lrcheck", written out again for the hand-built maps. */
  def reference(w: Int, h: Int, l: Array[Int], r: Array[Int], threshold: Int): (Array[Int], Array[Int]) = {
    val outL = Array.tabulate(w * h) { i =>
      val (u, d) = (i % w, l(i))
      if (d < 0 || u - d < 0) -1
      else { val o = r(i - d); if (o >= 0 && math.abs(o - d) <= threshold) d else -1 }
    }
    val outR = Array.tabulate(w * h) { i =>
      val (u, d) = (i % w, r(i))
      if (d < 0 || u + d >= w) -1
      else { val o = l(i + d); if (o >= 0 && math.abs(o - d) <= threshold) d else -1 }
    }
    (outL, outR)
  }

  /** Edge-case counts of a frame, to show the hand-built maps reach every branch of the rule. */
  case class Coverage(atThreshold: Int, overThreshold: Int, leftOut: Int, rightOut: Int, otherInvalidSmallD: Int) {
    def +(o: Coverage) = Coverage(atThreshold + o.atThreshold, overThreshold + o.overThreshold, leftOut + o.leftOut,
      rightOut + o.rightOut, otherInvalidSmallD + o.otherInvalidSmallD)
    def complete: Boolean = Seq(atThreshold, overThreshold, leftOut, rightOut, otherInvalidSmallD).forall(_ > 0)
    override def toString = s"|dR-d| = thr: $atThreshold, thr+1: $overThreshold, u-d < 0: $leftOut, u+d >= W: $rightOut, " +
      s"other side -1 with d <= 1: $otherInvalidSmallD"
  }
  def coverage(f: DenseFrame, threshold: Int): Coverage = {
    var c = Coverage(0, 0, 0, 0, 0)
    for (i <- 0 until f.width * f.height) {
      val u = i % f.width
      for ((d, t, other) <- Seq((f.denseL(i), u - f.denseL(i), f.denseR), (f.denseR(i), u + f.denseR(i), f.denseL)) if d >= 0) {
        if (t < 0) c = c.copy(leftOut = c.leftOut + 1)
        else if (t >= f.width) c = c.copy(rightOut = c.rightOut + 1)
        else {
          val o = other(i - u + t)
          if (o < 0 && d <= 1) c = c.copy(otherInvalidSmallD = c.otherInvalidSmallD + 1)
          if (o >= 0 && math.abs(o - d) == threshold) c = c.copy(atThreshold = c.atThreshold + 1)
          if (o >= 0 && math.abs(o - d) == threshold + 1) c = c.copy(overThreshold = c.overThreshold + 1)
        }
      }
    }
    c
  }

  /** Random dense maps steered to the rule's edges: each pixel of each view picks a disparity that looks outside
    * the row, or one whose partner it then sets to d + delta (delta around +-threshold) or to -1 (d often 0 or 1).
    */
  def handFrame(p: ElasParams, w: Int, h: Int, rnd: Random): DenseFrame = {
    val t = p.lrThreshold
    val l = Array.fill(w * h)(-1)
    val r = Array.fill(w * h)(-1)
    val deltas = Seq(0, t, -t, t + 1, -t - 1, t - 1, 1 - t)
    def clip(d: Int) = d.max(0).min(p.dispMax)
    for (y <- 0 until h; u <- 0 until w; view <- 0 to 1) {
      val i = y * w + u
      val (mine, other, dir) = if (view == 0) (l, r, -1) else (r, l, 1)
      val room = if (dir < 0) u else w - 1 - u // the largest d that stays inside the row
      rnd.nextInt(10) match {
        case 0 => mine(i) = -1
        case 1 if room < p.dispMax => mine(i) = room + 1 + rnd.nextInt(p.dispMax - room) // looks outside the row
        case 2 => // d in {0, 1} whose partner is invalid
          val d = rnd.nextInt(2).min(room)
          mine(i) = d; other(i + dir * d) = -1
        case 3 => mine(i) = rnd.nextInt(p.dispMax + 1) // whatever the partner holds
        case _ =>
          val d = rnd.nextInt(room.min(p.dispMax) + 1)
          mine(i) = d
          other(i + dir * d) = clip(d + deltas(rnd.nextInt(deltas.length)))
      }
    }
    val (el, er) = reference(w, h, l, r, t)
    DenseFrame(s"hand-built ${w}x$h", w, h, l, r, el, er)
  }

  /** Constant disparity d in both views: every pixel is consistent except where u - d < 0 or u + d >= W. */
  def constantFrame(p: ElasParams, w: Int, h: Int, d: Int): DenseFrame = {
    val l = Array.fill(w * h)(d)
    val (el, er) = reference(w, h, l, l, p.lrThreshold)
    DenseFrame(s"constant $d ${w}x$h", w, h, l, l.clone, el, er)
  }

  /** The golden model's dense and lrcheck maps of an image pair. */
  def golden(p: ElasParams, label: String, left: GrayImage, right: GrayImage, dir: java.nio.file.Path): DenseFrame = {
    GoldenModel.dump(p.name, left, right, dir)
    val (w, h) = (left.width, left.height)
    val Seq(dl, dr, ll, lr) = Seq("dense_L", "dense_R", "lrcheck_L", "lrcheck_R").map { n =>
      val a = NpyArray.read(dir.resolve(s"$n.npy"))
      require(a.dtype == "<i2" && a.shape == Seq(h, w), s"golden: $n.npy has ${a.dtype} ${a.shape}, expected <i2 ($h, $w)")
      Array.tabulate(w * h)(a(_))
    }
    DenseFrame(label, w, h, dl, dr, ll, lr)
  }

  def goldenFrames(p: ElasParams, rnd: Random, tmp: java.nio.file.Path): Seq[DenseFrame] = {
    val (kl, kr) = TestImages.kitti2012
    val (ql, qr) = TestImages.pair("kitti2015/training/image_2/000046_10.png", "kitti2015/training/image_3/000046_10.png")
    val (tl, tr) = TestImages.middleburyTsukuba
    val (cl, cr) = TestImages.middleburyCones
    val shifted = SupportMatcherSpec.shiftedPair(128, 64, 9, rnd)
    val mixed = SupportFilterSpec.mixedPair(128, 64, rnd)
    val mixedOdd = SupportFilterSpec.mixedPair(101, 50, rnd)
    val pairs = Seq(
      ("KITTI 2012 000070 crop 128x64 at (600,150)", kl.crop(600, 150, 128, 64), kr.crop(600, 150, 128, 64)),
      ("KITTI 2015 000046 crop 128x64 at (700,200)", ql.crop(700, 200, 128, 64), qr.crop(700, 200, 128, 64)),
      ("Middlebury tsukuba crop 128x64 at (120,110)", tl.crop(120, 110, 128, 64), tr.crop(120, 110, 128, 64)),
      ("Middlebury cones crop 111x57 at (200,150)", cl.crop(200, 150, 111, 57), cr.crop(200, 150, 111, 57)),
      (shifted.label, shifted.left, shifted.right),
      (mixed.label, mixed.left, mixed.right),
      (mixedOdd.label, mixedOdd.left, mixedOdd.right),
      ("noise 33x17", TestImages.noise(33, 17, rnd), TestImages.noise(33, 17, rnd)))
    pairs.zipWithIndex.map { case ((label, l, r), i) => golden(p, label, l, r, tmp.resolve(f"golden$i%02d")) }
  }

  /** One output beat. */
  case class Beat(left: Int, right: Int, sof: Boolean, eol: Boolean, eof: Boolean)

  /** Checks the output stream of `frames` sent back to back: both views and the framing of every pixel. */
  class LrScoreboard(frames: Seq[DenseFrame], label: String) {
    val board = new Scoreboard(s"lrcheck [$label]")
    private val starts = frames.scanLeft(0L)((acc, f) => acc + f.width.toLong * f.height)
    val total: Long = starts.last
    private var k = 0
    def check(index: Long, beat: Beat): Unit = {
      while (index >= starts(k + 1)) k += 1
      val f = frames(k)
      val i = (index - starts(k)).toInt
      val (x, y) = (i % f.width, i / f.width)
      def at = s"frame $k '${f.label}' (x=$x, y=$y)"
      board.check(s"$at L", f.expL(i), beat.left)
      board.check(s"$at R", f.expR(i), beat.right)
      board.check(s"$at sof", if (i == 0) 1 else 0, if (beat.sof) 1 else 0)
      board.check(s"$at eol", if (x == f.width - 1) 1 else 0, if (beat.eol) 1 else 0)
      board.check(s"$at eof", if (i == f.width * f.height - 1) 1 else 0, if (beat.eof) 1 else 0)
    }
  }

  /** Streams `frames` back to back into the stage and checks every output; returns the cycles of [[run]]. */
  def streamFrames(dut: LrCheck, frames: Seq[DenseFrame], traffic: Traffic, rnd: Random, label: String): Long = {
    val board = new LrScoreboard(frames, label)
    val beats = frames.iterator.flatMap { f =>
      val n = f.width * f.height
      Iterator.range(0, n).map(i => Beat(f.denseL(i), f.denseR(i), i == 0, i % f.width == f.width - 1, i == n - 1))
    }
    var last: Option[Beat] = None
    val cycles = run[Framed[DisparityPair], Framed[DisparityPair], Beat, Beat](dut.clock, dut.io.in, beats,
      (bits, b) => { // pokes cost time: only what changed
        if (!last.exists(_.left == b.left)) poke(bits.data.left, b.left)
        if (!last.exists(_.right == b.right)) poke(bits.data.right, b.right)
        if (!last.exists(_.sof == b.sof)) poke(bits.sof, b.sof)
        if (!last.exists(_.eol == b.eol)) poke(bits.eol, b.eol)
        if (!last.exists(_.eof == b.eof)) poke(bits.eof, b.eof)
        last = Some(b)
      },
      dut.io.out, board.total,
      o => Beat(peek(o.data.left).toInt, peek(o.data.right).toInt, peek(o.sof), peek(o.eol), peek(o.eof)),
      board.check, traffic, rnd, 20L * (board.total + frames.map(_.width).max) + 1000, label)
    assert(board.board.ok, board.board.report)
    println(f"  ${board.board.report} (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f, $cycles cycles)")
    cycles
  }

  /** The no-stall bound: N + latencyRows * W + c, W the widest frame of the stream (the last row drains alone, and a
    * frame after a wider one keeps the wider row's lag: its first row starts only when the wide row has left, and at
    * one pixel per clock the lag is never made up), plus [[LrCheck.narrowingSlack]] at each change to a much
    * narrower frame (0 for same-size streams).
    */
  def throughputBound(frames: Seq[DenseFrame]): (Long, String) = {
    val n = frames.map(f => f.width.toLong * f.height).sum
    val w = frames.map(_.width).max
    val widths = frames.map(_.width)
    val narrowing = widths.zip(widths.drop(1)).map { case (a, b) => LrCheck.narrowingSlack(a, b) }.sum
    (n + LrCheck.latencyRows * w + LrCheck.cycleSlack + narrowing,
      s"N + ${LrCheck.latencyRows}*$w + ${LrCheck.cycleSlack}" + (if (narrowing > 0) s" + $narrowing at narrower frames" else ""))
  }

  def kept(a: Array[Int]): Int = a.count(_ >= 0)

  def runSuite(config: String): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0x1c)
    val tmp = tmpDir(s"lrcheck-$config")
    val real = goldenFrames(p, rnd, tmp)
    // The independent rule must agree with the golden model before it may judge the hand-built maps.
    for (f <- real) {
      val (el, er) = reference(f.width, f.height, f.denseL, f.denseR, p.lrThreshold)
      assert(el.sameElements(f.expL) && er.sameElements(f.expR), s"reference rule differs from the golden lrcheck on ${f.label}")
      println(s"  golden ${f.label}: dense L/R ${kept(f.denseL)}/${kept(f.denseR)} valid, lrcheck L/R ${kept(f.expL)}/${kept(f.expR)} kept")
    }
    val hand = Seq(handFrame(p, 128, 64, rnd), handFrame(p, 32, 16, rnd), handFrame(p, 97, 41, rnd),
      handFrame(p, 40, 20, rnd), constantFrame(p, 64, 16, 3), constantFrame(p, 33, 16, p.dispMax))
    val cover = hand.map(coverage(_, p.lrThreshold)).reduce(_ + _)
    println(s"  hand-built coverage: $cover")
    assert(cover.complete, s"hand-built maps miss a case: $cover")

    simulate(new LrCheck(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      for (f <- real ++ hand)
        streamFrames(dut, Seq(f), Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5), rnd, f.label)

      // Frames of different sizes back to back in one stream, choppy and then with no stalls.
      val mixedSizes = rnd.shuffle(Seq(real(3), hand(1), real(0), hand(2), real(7), hand(0)))
      streamFrames(dut, mixedSizes, choppy, rnd, "back to back, sizes " + mixedSizes.map(f => s"${f.width}x${f.height}").mkString(" "))
      for ((frames, what) <- Seq((Seq(real(0)), "throughput 128x64"), (Seq.fill(3)(real(1)), "throughput 3 x 128x64"),
          (Seq.fill(3)(hand(1)), "throughput 3 x 32x16"), (mixedSizes, "throughput back to back, mixed sizes"))) {
        val cycles = streamFrames(dut, frames, noStall, rnd, what)
        val (bound, formula) = throughputBound(frames)
        println(s"  $what: $cycles cycles, bound $bound ($formula)")
        assert(cycles <= bound, s"$what: $cycles cycles > bound $bound ($formula)")
      }
    }
  }
}
