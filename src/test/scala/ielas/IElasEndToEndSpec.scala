package ielas

import org.scalatest.flatspec.AnyFlatSpec

import scala.collection.mutable.ArrayBuffer
import scala.util.Random

/** The whole accelerator (`IElas`, stage `top`) against the golden model's disparity.npy, every pixel and the
  * framing: one Verilator build at config mb-tsukuba (384x288, dispMax 63) streams real crops, seeded random pairs
  * and the full Middlebury tsukuba frame under random input gaps and output back-pressure; frames of different
  * sizes back to back; a truncated frame followed by a good one; the no-stall throughput bound.
  */
class IElasEndToEndSpec extends AnyFlatSpec {
  import IElasEndToEndSpec._

  behavior of "IElas (the whole accelerator)"

  it should "match the golden disparity map end to end at config mb-tsukuba" in {
    runSuite("mb-tsukuba")
  }
  it should "match the golden disparity map end to end at config small-c4 (one pixel every 4 cycles)" in {
    runRate("small-c4")
  }
}

object IElasEndToEndSpec {
  import StreamTester._

  /** A frame to send: `rows` < height sends a truncated frame (its declared size stays left.width x left.height). */
  case class Frame(label: String, left: GrayImage, right: GrayImage, rows: Int) {
    def width: Int = left.width
    def height: Int = left.height
  }
  object Frame {
    def apply(label: String, left: GrayImage, right: GrayImage): Frame = Frame(label, left, right, left.height)
  }

  /** One output beat of the top. */
  case class OutBeat(value: Int, sof: Boolean, eol: Boolean, eof: Boolean)

  /** Streams `frames` back to back (frameWidth/frameHeight set with each start of frame) and returns the cycles and
    * the output split into frames at each start of frame. Stops after `expectedOutputs` beats, or when `stopWhen`
    * (given the output so far and the number of input beats offered so far).
    */
  def stream(dut: IElas, frames: Seq[Frame], traffic: Traffic, rnd: Random, maxCycles: Long, what: String,
      expectedOutputs: Long, stopWhen: (Seq[Seq[OutBeat]], Long) => Boolean = (_, _) => false): (Long, Seq[Seq[OutBeat]]) = {
    poke(dut.io.clearError, false)
    var taken = 0L
    val beats = frames.iterator.flatMap { f =>
      Iterator.range(0, f.width * f.rows).map(i => (f, i))
    }.map { b => taken += 1; b }
    val out = ArrayBuffer.empty[ArrayBuffer[OutBeat]]
    def outFrames: Seq[Seq[OutBeat]] = out.map(_.toSeq).toSeq
    val cycles = run[PixelPair, Framed[chisel3.SInt], (Frame, Int), OutBeat](dut.clock, dut.io.in, beats,
      (bits, b) => {
        val (f, i) = b
        if (i == 0) { poke(dut.io.frameWidth, f.width); poke(dut.io.frameHeight, f.height) }
        poke(bits.left, f.left.pixels(i) & 0xff); poke(bits.right, f.right.pixels(i) & 0xff)
        poke(bits.sof, i == 0); poke(bits.eol, i % f.width == f.width - 1)
      },
      dut.io.out, expectedOutputs,
      o => OutBeat(peek(o.data).toInt, peek(o.sof), peek(o.eol), peek(o.eof)),
      (_, beat) => { if (beat.sof || out.isEmpty) out += ArrayBuffer.empty[OutBeat]; out.last += beat },
      traffic, rnd, maxCycles, what, stopWhen = () => stopWhen(outFrames, taken))
    (cycles, outFrames)
  }

  def golden(p: ElasParams, f: Frame, dir: java.nio.file.Path): NpyArray = {
    GoldenModel.dump(p.name, f.left, f.right, dir)
    val a = NpyArray.read(dir.resolve("disparity.npy"))
    require(a.dtype == "<i2" && a.shape == Seq(f.height, f.width), s"golden: disparity.npy has ${a.dtype} ${a.shape}")
    a
  }

  /** Compares the first `rows` rows (all by default) of an output frame with the golden map, framing included;
    * a complete frame must end with eof, a cut one (`complete` false) must not carry it.
    */
  def check(board: Scoreboard, f: Frame, got: Seq[OutBeat], expected: NpyArray, frameIndex: Int, complete: Boolean = true): Unit = {
    val (w, h) = (f.width, f.height)
    val n = if (complete) w * h else got.length
    board.check(s"frame $frameIndex [${f.label}] output beats", n, got.length)
    for (k <- 0 until math.min(n, got.length)) {
      val (x, y) = (k % w, k / w)
      def at = s"frame $frameIndex [${f.label}] (x=$x, y=$y)"
      val b = got(k)
      board.check(s"$at disparity", expected(k), b.value)
      board.check(s"$at sof", if (k == 0) 1 else 0, if (b.sof) 1 else 0)
      board.check(s"$at eol", if (x == w - 1) 1 else 0, if (b.eol) 1 else 0)
      board.check(s"$at eof", if (complete && k == w * h - 1) 1 else 0, if (b.eof) 1 else 0)
    }
  }

  def choppyBound(frames: Seq[Frame], p: ElasParams): Long =
    p.cyclesPerPixel * (frames.map(f => 12L * f.width * f.rows).sum + 12L * IElas.latencyRows(p) * p.maxWidth + 100000)

  /** The no-stall bound: cyclesPerPixel x (N + latencyRows * W + c). */
  def throughputBound(p: ElasParams, f: Frame): (Long, String) = {
    val (cpp, rows, c) = (p.cyclesPerPixel, IElas.latencyRows(p), IElas.cycleSlack(p))
    (cpp * (f.width.toLong * f.height + rows.toLong * f.width + c), s"$cpp x (N + $rows*W + $c)")
  }

  /** Each frame alone under random gaps and back-pressure: every value and the framing, and no error raised. */
  def eachAlone(dut: IElas, p: ElasParams, frames: Seq[Frame], expected: Seq[NpyArray], rnd: Random): Unit =
    for ((f, exp) <- frames.zip(expected)) {
      val traffic = Traffic(rnd.nextDouble() * 0.4, rnd.nextDouble() * 0.4)
      val (_, got) = stream(dut, Seq(f), traffic, rnd, choppyBound(Seq(f), p), f.label, f.width.toLong * f.height)
      val board = new Scoreboard(s"top [${f.label}]")
      check(board, f, got.head, exp, 0)
      assert(board.ok, board.report)
      assert(!peek(dut.io.error), s"${f.label}: error raised by a legal frame")
      println(f"  ${p.name}: ${board.report} (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
    }

  /** One frame with no stalls: exact, within the no-stall bound and not faster than the configuration's rate. */
  def throughput(dut: IElas, p: ElasParams, full: Frame, expected: NpyArray, rnd: Random): Unit = {
    val (cycles, got) = stream(dut, Seq(full), noStall, rnd, choppyBound(Seq(full), p), "throughput", full.width.toLong * full.height)
    val tput = new Scoreboard("top [throughput]")
    check(tput, full, got.head, expected, 0)
    assert(tput.ok, tput.report)
    val (bound, formula) = throughputBound(p, full)
    println(s"  ${p.name}: throughput ${full.width}x${full.height}: $cycles cycles, bound $bound ($formula)")
    assert(cycles <= bound, s"throughput: $cycles cycles > bound $bound ($formula)")
    assert(cycles >= p.cyclesPerPixel.toLong * full.width * full.height, s"throughput: $cycles cycles, faster than the rate")
  }

  /** Frames of different sizes back to back: `order` indexes `frames` and `expected`. */
  def backToBack(dut: IElas, p: ElasParams, frames: Seq[Frame], expected: Seq[NpyArray], order: Seq[Int], rnd: Random): Unit = {
    val seq = order.map(frames(_))
    val (_, b2b) = stream(dut, seq, Traffic(0.1, 0.1), rnd, choppyBound(seq, p), "back to back", seq.map(f => f.width.toLong * f.height).sum)
    val board = new Scoreboard("top [back to back]")
    assert(b2b.length == seq.length, s"back to back: ${b2b.length} output frames for ${seq.length}")
    for (((k, f), i) <- order.zip(seq).zipWithIndex) check(board, f, b2b(i), expected(k), i)
    assert(board.ok, board.report)
    println(s"  ${p.name}: back to back ${seq.map(f => s"${f.width}x${f.height}").mkString(", ")}: ${board.report}")
  }

  /** A configuration with cyclesPerPixel > 1 (small frames): real crops and noise under gaps and back-pressure,
    * frames of two sizes back to back, and the no-stall bound at the configuration's rate.
    */
  def runRate(config: String): Unit = {
    val p = ElasParams.byName(config)
    require(p.cyclesPerPixel > 1, s"$config: runRate is for cyclesPerPixel > 1")
    val rnd = new Random(seed ^ config.hashCode ^ 0x3a7e)
    val (kl, kr) = TestImages.kitti2012
    val (tl, tr) = TestImages.middleburyTsukuba
    val all = Seq(
      Frame("KITTI 2012 000070 crop 128x64 at (560,170)", kl.crop(560, 170, 128, 64), kr.crop(560, 170, 128, 64)),
      Frame("Middlebury tsukuba crop 128x64 at (120,110)", tl.crop(120, 110, 128, 64), tr.crop(120, 110, 128, 64)),
      Frame("noise 64x32", TestImages.noise(64, 32, rnd), TestImages.noise(64, 32, rnd)))
    val tmp = tmpDir(s"top-$config")
    val expected = all.zipWithIndex.map { case (f, i) => golden(p, f, tmp.resolve(f"golden$i%02d")) }
    simulate(new IElas(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      eachAlone(dut, p, all, expected, rnd)
      throughput(dut, p, all.head, expected.head, rnd)
      backToBack(dut, p, all, expected, Seq(2, 1), rnd)
    }
  }

  def cases(rnd: Random): Seq[Frame] = {
    val (kl, kr) = TestImages.kitti2012
    val (tl, tr) = TestImages.middleburyTsukuba
    val (cl, cr) = TestImages.middleburyCones
    val (k5l, k5r) = TestImages.pair("kitti2015/training/image_2/000046_10.png", "kitti2015/training/image_3/000046_10.png")
    def shifted(w: Int, h: Int, d: Int) = {
      val wide = TestImages.smooth(w + d, h, rnd)
      Frame(s"smooth texture ${w}x$h shifted by $d", wide.crop(d, 0, w, h), wide.crop(0, 0, w, h))
    }
    Seq(
      Frame("KITTI 2012 000070 crop 200x100 at (500,180)", kl.crop(500, 180, 200, 100), kr.crop(500, 180, 200, 100)),
      Frame("KITTI 2015 000046 crop 160x96 at (600,150)", k5l.crop(600, 150, 160, 96), k5r.crop(600, 150, 160, 96)),
      Frame("Middlebury cones crop 150x90 at (100,120)", cl.crop(100, 120, 150, 90), cr.crop(100, 120, 150, 90)),
      shifted(120, 64, 17),
      Frame("noise 64x32", TestImages.noise(64, 32, rnd), TestImages.noise(64, 32, rnd)),
      Frame("Middlebury tsukuba 384x288 (full frame)", tl, tr))
  }

  def runSuite(config: String): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0x70b)
    val all = cases(rnd)
    val tmp = tmpDir(s"top-$config")
    val expected = all.zipWithIndex.map { case (f, i) => golden(p, f, tmp.resolve(f"golden$i%02d")) }
    simulate(new IElas(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      eachAlone(dut, p, all, expected, rnd) // each case alone, random gaps and back-pressure
      throughput(dut, p, all.last, expected.last, rnd) // no stalls on the full frame
      backToBack(dut, p, all, expected, Seq(2, 0, 4, 1), rnd) // frames of different sizes

      // A truncated frame (its last rows never come), then a good frame: the error is raised, the truncated frame's
      // output ends after a whole line without eof and equals the golden map of the frame as the guard completes it
      // (zero pixels), and the good frame is bit-exact.
      val cut = 200
      val t = all.last.copy(label = s"tsukuba truncated at row $cut", rows = cut)
      def padded(img: GrayImage) = GrayImage(img.width, img.height, Array.tabulate(img.width * img.height)(i => if (i < img.width * cut) img.pixels(i) else 0.toByte))
      val padExp = golden(p, Frame("padded", padded(t.left), padded(t.right)), tmp.resolve("golden-padded"))
      val good = all.head
      val (_, trunc) = stream(dut, Seq(t, good), Traffic(0.1, 0.1), rnd, choppyBound(Seq(t, good), p), "truncated frame",
        Long.MaxValue, (outs, _) => outs.nonEmpty && outs.last.lastOption.exists(_.eof))
      assert(peek(dut.io.error), "truncated frame: error not raised")
      poke(dut.io.clearError, true); step(dut.clock); poke(dut.io.clearError, false)
      assert(!peek(dut.io.error), "clearError did not clear the error")
      val truncBoard = new Scoreboard("top [truncated frame]")
      val goodOut = trunc.last
      val cutOut = trunc.dropRight(1)
      assert(cutOut.length <= 1, s"truncated frame: ${cutOut.length} partial output frames")
      cutOut.headOption.foreach { o =>
        assert(o.length % t.width == 0, s"truncated frame: output ends mid-line (${o.length} beats, width ${t.width})")
        check(truncBoard, t, o, padExp, 0, complete = false)
      }
      check(truncBoard, good, goodOut, expected.head, 1)
      assert(truncBoard.ok, truncBoard.report)
      println(s"  ${p.name}: truncated frame flagged, ${cutOut.headOption.map(_.length / t.width).getOrElse(0)} rows of it sent before the cut; the next frame: ${truncBoard.report}")
    }
  }
}
