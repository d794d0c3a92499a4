package ielas

import org.scalatest.flatspec.AnyFlatSpec

import scala.util.Random

/** The top's input framing check on its own: one Verilator build at config `small` (frames 32x16..128x64).
  * Hand-built sequences of good and malformed frames (short and long lines, a SOF pixel that ends its line, SOF in
  * mid-frame and mid-line, too few lines, lines beyond frameHeight, illegal sizes, pixels before the first SOF) are
  * streamed in seeded random segments under random input gaps, output back-pressure and `aborted` back-pressure, with
  * the frame size ports garbage except on SOF beats. The expected clean stream, the aborted beats and the error bit
  * are computed here from the frames' description (not by a cycle model), and every output beat, every aborted beat
  * and the error bit after each segment (cleared with `clearError` before it) are compared. Good frames of different
  * sizes back to back, with no stalls, give the cycle bound.
  */
class FrameGuardSpec extends AnyFlatSpec {
  import FrameGuardSpec._

  behavior of "FrameGuard"

  it should "put out exactly W x H clean frames, abort beats and the sticky error for malformed input at config small" in {
    runSuite("small")
  }
}

object FrameGuardSpec {
  import StreamTester._

  /** An input line as sent: its pixels (left, right) and whether its last pixel carries eol. */
  case class Line(pixels: Seq[(Int, Int)], eol: Boolean = true)
  /** An input frame: the size on the ports at its SOF (the first pixel of its first line) and its lines as sent. */
  case class FrameIn(label: String, width: Int, height: Int, lines: Seq[Line])

  case class InBeat(left: Int, right: Int, sof: Boolean, eol: Boolean, portW: Int, portH: Int)
  case class OutBeat(left: Int, right: Int, sof: Boolean, eol: Boolean)

  def pixels(n: Int, rnd: Random): Seq[(Int, Int)] = Seq.fill(n)((rnd.nextInt(256), rnd.nextInt(256)))
  def line(n: Int, rnd: Random, eol: Boolean = true): Line = Line(pixels(n, rnd), eol)
  def goodLines(w: Int, h: Int, rnd: Random): Seq[Line] = Seq.fill(h)(line(w, rnd))

  /** Frames that end (the guard needs nothing after them to finish their output). */
  def closedFrames(rnd: Random): Seq[FrameIn] = {
    def size() = (32 + rnd.nextInt(40), 16 + rnd.nextInt(10))
    def withLine(label: String, make: (Int, Int) => Line) = {
      val (w, h) = size(); val row = rnd.nextInt(h)
      FrameIn(s"$label ${w}x$h row $row", w, h, goodLines(w, h, rnd).updated(row, make(w, h)))
    }
    Seq(
      { val (w, h) = size(); FrameIn(s"good ${w}x$h", w, h, goodLines(w, h, rnd)) },
      FrameIn("good 32x16 (smallest)", 32, 16, goodLines(32, 16, rnd)),
      FrameIn("good 128x64 (largest)", 128, 64, goodLines(128, 64, rnd)),
      withLine("short line", (w, _) => line(1 + rnd.nextInt(w - 1), rnd)),
      withLine("long line", (w, _) => line(w + 1 + rnd.nextInt(20), rnd)),
      { val (w, h) = size(); FrameIn(s"short last line ${w}x$h", w, h, goodLines(w, h - 1, rnd) :+ line(w - 1, rnd)) },
      { val (w, h) = size(); FrameIn(s"long last line ${w}x$h", w, h, goodLines(w, h - 1, rnd) :+ line(w + 3, rnd)) },
      { val (w, h) = size(); FrameIn(s"SOF pixel ends its line ${w}x$h", w, h, line(1, rnd) +: goodLines(w, h - 1, rnd)) },
      { val (w, h) = size()
        FrameIn(s"every line wrong ${w}x$h", w, h, Seq.tabulate(h)(i => line(if (i % 2 == 0) w - 1 - i % 7 else w + 1 + i % 5, rnd))) },
      { val (w, h) = size(); FrameIn(s"lines beyond frameHeight ${w}x$h +2", w, h, goodLines(w, h + 2, rnd)) },
      { val (w, h) = size()
        FrameIn(s"lines beyond frameHeight ${w}x$h + partial", w, h, goodLines(w, h, rnd) :+ line(5, rnd) :+ line(w + 9, rnd, eol = false)) },
      FrameIn("illegal width 31x16", 31, 16, goodLines(31, 16, rnd)),
      FrameIn("illegal height 40x15", 40, 15, goodLines(40, 15, rnd)),
      FrameIn("illegal width 129x20 (> maxWidth)", 129, 20, goodLines(40, 3, rnd)),
      FrameIn("illegal height 40x65 (> maxHeight)", 40, 65, goodLines(40, 3, rnd)),
      FrameIn("illegal size 0x0", 0, 0, goodLines(33, 2, rnd))
    )
  }

  /** Frames cut short by the next SOF (the guard pads them once that SOF arrives): never last in a segment. */
  def cutFrames(rnd: Random): Seq[FrameIn] = {
    def size() = (32 + rnd.nextInt(40), 16 + rnd.nextInt(10))
    Seq(
      { val (w, h) = size(); val k = 1 + rnd.nextInt(h - 1); FrameIn(s"too few lines ${w}x$h ($k)", w, h, goodLines(w, k, rnd)) },
      { val (w, h) = size(); val k = rnd.nextInt(h)
        FrameIn(s"SOF in mid-line ${w}x$h (row $k)", w, h, goodLines(w, k, rnd) :+ line(1 + rnd.nextInt(w - 1), rnd, eol = false)) },
      { val (w, h) = size()
        FrameIn(s"SOF in the last line ${w}x$h", w, h, goodLines(w, h - 1, rnd) :+ line(w - 2, rnd, eol = false)) },
      { val (w, h) = size(); val k = rnd.nextInt(h - 1)
        FrameIn(s"long line cut by SOF ${w}x$h (row $k)", w, h, goodLines(w, k, rnd) :+ line(w + 4, rnd, eol = false)) },
      { val (w, h) = size()
        FrameIn(s"last line W wide without eol, then SOF ${w}x$h", w, h, goodLines(w, h - 1, rnd) :+ line(w, rnd, eol = false)) },
      FrameIn("only the SOF pixel 40x16", 40, 16, Seq(line(1, rnd, eol = false)))
    )
  }

  /** `deadline`: for an aborted frame, the output count by which its beat must be out: the end of its first bad
    * (or missing) line.
    */
  case class Expected(beats: IndexedSeq[(OutBeat, String)], aborted: Seq[(Boolean, String)], error: Boolean,
      deadline: Seq[Long] = Nil)

  /** What the guard must put out, from the frames' description (docs/interfaces.md §4 and the FrameGuard rules). */
  def expected(p: ElasParams, frames: Seq[FrameIn]): Expected = {
    val beats = IndexedSeq.newBuilder[(OutBeat, String)]
    val aborted = Seq.newBuilder[(Boolean, String)]
    val deadline = Seq.newBuilder[Long]
    var start = 0L
    var error = false
    for ((f, k) <- frames.zipWithIndex) {
      val legal = f.width >= 32 && f.width <= p.maxWidth && f.height >= 16 && f.height <= p.maxHeight
      if (!legal) error = true
      else {
        val rows = f.lines.take(f.height)
        for (y <- 0 until f.height) {
          val sent = if (y < rows.length) rows(y).pixels.take(f.width) else Nil
          val row = sent ++ Seq.fill(f.width - sent.length)((0, 0))
          for ((px, x) <- row.zipWithIndex)
            beats += ((OutBeat(px._1, px._2, x == 0 && y == 0, x == f.width - 1), s"frame $k '${f.label}' (x=$x, y=$y)"))
        }
        val bad = rows.length < f.height || rows.exists(l => l.pixels.length != f.width || !l.eol)
        aborted += ((bad, s"frame $k '${f.label}'"))
        val firstBad = (0 until f.height).find(y => y >= rows.length || rows(y).pixels.length != f.width || !rows(y).eol)
        deadline += start + (firstBad.getOrElse(f.height - 1) + 1).toLong * f.width
        start += f.width.toLong * f.height
        if (bad || f.lines.length > f.height) error = true
      }
    }
    Expected(beats.result(), aborted.result(), error, deadline.result())
  }

  /** The input beats: sof on each frame's first pixel, the frame's size on the ports at SOF and garbage elsewhere. */
  def inputBeats(frames: Seq[FrameIn], junk: Seq[(Int, Int)], rnd: Random): Seq[InBeat] = {
    def garbage() = (rnd.nextInt(200), rnd.nextInt(100))
    val pre = junk.zipWithIndex.map { case ((l, r), i) =>
      val (gw, gh) = garbage(); InBeat(l, r, sof = false, eol = i % 7 == 6, gw, gh)
    }
    pre ++ frames.flatMap { f =>
      f.lines.zipWithIndex.flatMap { case (ln, y) =>
        ln.pixels.zipWithIndex.map { case ((l, r), x) =>
          val sof = x == 0 && y == 0
          val (gw, gh) = if (sof) (f.width, f.height) else garbage()
          InBeat(l, r, sof, ln.eol && x == ln.pixels.length - 1, gw, gh)
        }
      }
    }
  }

  /** Clears the error, streams one segment, checks every output beat, every aborted beat and the error bit. Returns
    * the cycles of [[run]].
    */
  def runSegment(dut: FrameGuard, p: ElasParams, frames: Seq[FrameIn], junk: Seq[(Int, Int)], traffic: Traffic,
      abortStall: Double, rnd: Random, label: String, cutAt: Option[Int] = None): Long = {
    poke(dut.io.clearError, true); step(dut.clock); poke(dut.io.clearError, false)
    assert(!peek(dut.io.error), s"$label: error still set after clearError")
    // cutAt: the stream stops inside the last frame, before the guard can know it is malformed
    val exp = cutAt.fold(expected(p, frames)) { n => val e = expected(p, frames); Expected(e.beats.take(n), Nil, false) }
    val board = new Scoreboard(s"frameguard [$label]")
    val abortedGot = scala.collection.mutable.ArrayBuffer[Boolean]()
    val takenAt = scala.collection.mutable.ArrayBuffer[Long]() // outputs received when each aborted beat was taken
    var received = 0L
    def takeAborted(ready: Boolean): Unit = {
      poke(dut.io.aborted.ready, ready)
      if (ready && peek(dut.io.aborted.valid)) { abortedGot += peek(dut.io.aborted.bits); takenAt += received }
    }
    val in = inputBeats(frames, junk, rnd)
    var last: Option[InBeat] = None
    val cycles = run[PixelPair, PixelPair, InBeat, OutBeat](dut.clock, dut.io.in, in.iterator,
      (bits, b) => {
        if (!last.exists(_.left == b.left)) poke(bits.left, b.left)
        if (!last.exists(_.right == b.right)) poke(bits.right, b.right)
        if (!last.exists(_.sof == b.sof)) poke(bits.sof, b.sof)
        if (!last.exists(_.eol == b.eol)) poke(bits.eol, b.eol)
        if (!last.exists(_.portW == b.portW)) poke(dut.io.frameWidth, b.portW)
        if (!last.exists(_.portH == b.portH)) poke(dut.io.frameHeight, b.portH)
        last = Some(b)
      },
      dut.io.out, exp.beats.length.toLong,
      o => OutBeat(peek(o.left).toInt, peek(o.right).toInt, peek(o.sof), peek(o.eol)),
      (i, got) => {
        val (e, at) = exp.beats(i.toInt)
        board.check(s"$at left", e.left, got.left)
        board.check(s"$at right", e.right, got.right)
        board.check(s"$at sof", if (e.sof) 1 else 0, if (got.sof) 1 else 0)
        board.check(s"$at eol", if (e.eol) 1 else 0, if (got.eol) 1 else 0)
        received = i + 1
      },
      traffic, rnd, 20L * (in.length + exp.beats.length) + 1000, label,
      onCycle = () => takeAborted(rnd.nextDouble() >= abortStall))
    for (_ <- 0 until 8) { takeAborted(true); step(dut.clock) } // the last frame's beat may still wait
    poke(dut.io.aborted.ready, false)
    val aborts = new Scoreboard(s"frameguard aborted [$label]")
    aborts.check("aborted beat count", exp.aborted.length, abortedGot.length)
    for (((e, at), got) <- exp.aborted.zip(abortedGot)) aborts.check(s"$at aborted", if (e) 1 else 0, if (got) 1 else 0)
    // With the aborted channel always ready, a malformed frame's beat is out by the end of its first bad line
    // (the output side cuts the frame after its current line).
    if (abortStall == 0.0)
      for ((((e, at), d), t) <- exp.aborted.zip(exp.deadline).zip(takenAt) if e)
        aborts.check(s"$at aborted beat taken after output (at the latest)", d, if (t > d) t else d)
    val errorBoard = new Scoreboard(s"frameguard error [$label]")
    errorBoard.check("error bit after the segment", if (exp.error) 1 else 0, if (peek(dut.io.error)) 1 else 0)
    for (b <- Seq(board, aborts, errorBoard)) assert(b.ok, b.report)
    println(f"  ${board.report}; ${aborts.report} (${exp.aborted.count(_._1)} aborted); error ${exp.error} " +
      f"(input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f, aborted stalls $abortStall%.2f, $cycles cycles)")
    cycles
  }

  /** A random segment: closed and cut frames in random order, never ending on a cut frame. */
  def segment(rnd: Random, n: Int): Seq[FrameIn] = {
    val pool = closedFrames(rnd) ++ cutFrames(rnd)
    val picked = rnd.shuffle(pool).take(n)
    val closed = closedFrames(rnd)
    picked :+ closed(rnd.nextInt(closed.length))
  }

  def runSuite(config: String): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0xf6)
    simulate(new FrameGuard(p), tmpDir(s"frameguard-$config").resolve("verilator")) { dut =>
      reset(dut)
      poke(dut.io.aborted.ready, false)
      poke(dut.io.clearError, false)
      // After reset, pixels before the first SOF are dropped without an error.
      val (w0, h0) = (48, 16)
      runSegment(dut, p, Seq(FrameIn(s"good ${w0}x$h0 after junk", w0, h0, goodLines(w0, h0, rnd))), pixels(20, rnd),
        Traffic(0.2, 0.2), 0.2, rnd, "junk before the first SOF after reset")

      // Every case once, in order (a cut frame with the frame whose SOF cuts it), then random segments.
      for (f <- closedFrames(rnd)) runSegment(dut, p, Seq(f), Nil, Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5), 0.0, rnd, f.label)
      // the cut frames with their following frame, as one segment each
      for (Seq(cut, next) <- cutFrames(rnd).map(c => Seq(c, closedFrames(rnd).head)))
        for (abortStall <- Seq(0.0, 0.5))
          runSegment(dut, p, Seq(cut, next), Nil, Traffic(0.3, 0.3), abortStall, rnd, s"${cut.label}, then ${next.label}")
      for (i <- 0 until 8)
        runSegment(dut, p, segment(rnd, 6), Nil, Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5),
          rnd.nextDouble() * 0.8, rnd, s"random segment $i")

      // A reset in the middle of a frame: the guard forgets it and drops pixels until the next SOF, silently.
      val (w1, h1) = (40, 16)
      runSegment(dut, p, Seq(FrameIn(s"good ${w1}x$h1, 5 lines sent", w1, h1, goodLines(w1, 5, rnd))), Nil, Traffic(0.2, 0.2),
        0.0, rnd, "a frame stopped by a reset after 5 lines", cutAt = Some(5 * w1))
      reset(dut)
      runSegment(dut, p, Seq(FrameIn("good 33x17 after reset", 33, 17, goodLines(33, 17, rnd))), pixels(45, rnd),
        Traffic(0.2, 0.2), 0.0, rnd, "after a reset: junk, then a frame")

      // Good frames of different sizes back to back with no stalls: N + c cycles.
      val good = Seq((128, 64), (32, 16), (77, 23), (128, 64), (40, 60)).map { case (w, h) =>
        FrameIn(s"good ${w}x$h", w, h, goodLines(w, h, rnd)) }
      val cycles = runSegment(dut, p, good, Nil, noStall, 0.0, rnd, "throughput, sizes " + good.map(f => s"${f.width}x${f.height}").mkString(" "))
      val n = good.map(f => f.width * f.height).sum
      val bound = n + FrameGuard.cycleSlack
      println(s"  throughput: $cycles cycles for $n pixels, bound $bound (N + ${FrameGuard.cycleSlack})")
      assert(cycles <= bound, s"throughput: $cycles cycles > bound $bound (N + ${FrameGuard.cycleSlack})")
    }
  }
}
