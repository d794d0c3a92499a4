package ielas

import chisel3._
import chisel3.util.DecoupledIO
import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.{Files, Path}
import scala.util.Random

/** Stage `post` alone: the golden lrcheck_L.npy streamed in, every output pixel and the framing compared with the
  * golden disparity.npy. The speckle step is also checked by itself against the golden model run with the later
  * post steps switched off in its configuration JSON (ipolGapWidth 0, no corners, no mean, no median), so its
  * disparity.npy is exactly the speckle result * 16.
  */
class PostProcessSpec extends AnyFlatSpec {
  import PostProcessSpec._

  behavior of "PostProcessSpeckle (bounded small-segment removal)"

  it should "match the golden speckle result at config small" in {
    runSpeckle("small")
  }

  behavior of "PostProcess (stage post alone: lrcheck_L -> disparity)"

  it should "match the golden disparity at config small (robotics: gaps G = 3, adaptive mean)" in {
    runPost("small")
  }
  it should "match the golden disparity at config small-middlebury (corners, G = 32, median)" in {
    runPost("small-middlebury")
  }
}

object PostProcessSpec {
  import StreamTester._

  case class Case(label: String, left: GrayImage, right: GrayImage)

  def cases(rnd: Random): Seq[Case] = {
    val (kl, kr) = TestImages.kitti2012
    val (tl, tr) = TestImages.middleburyTsukuba
    val (cl, cr) = TestImages.middleburyCones
    val (k5l, k5r) = TestImages.pair("kitti2015/training/image_2/000046_10.png", "kitti2015/training/image_3/000046_10.png")
    def smoothPair(w: Int, h: Int, shift: Int) = {
      val wide = TestImages.smooth(w + shift, h, rnd)
      val noisy = GrayImage(wide.width, h, wide.pixels.map(b => ((b & 0xff) + rnd.nextInt(9) - 4).max(0).min(255).toByte))
      Case(s"smooth+noise ${w}x$h shift $shift", noisy.crop(shift, 0, w, h), noisy.crop(0, 0, w, h))
    }
    Seq(
      Case("KITTI 2012 000070 crop 128x64 at (600,150)", kl.crop(600, 150, 128, 64), kr.crop(600, 150, 128, 64)),
      Case("KITTI 2015 000046 crop 128x64 at (500,200)", k5l.crop(500, 200, 128, 64), k5r.crop(500, 200, 128, 64)),
      Case("Middlebury tsukuba crop 128x64 at (120,110)", tl.crop(120, 110, 128, 64), tr.crop(120, 110, 128, 64)),
      Case("Middlebury cones crop 111x57 at (200,150)", cl.crop(200, 150, 111, 57), cr.crop(200, 150, 111, 57)),
      Case(s"noise 128x64", TestImages.noise(128, 64, rnd), TestImages.noise(128, 64, rnd)),
      smoothPair(128, 64, 7), smoothPair(100, 40, 12), smoothPair(32, 16, 3))
  }

  /** golden/configs/<name>.json with some fields replaced, written to `dir`. */
  def configWith(name: String, dir: Path, overrides: Map[String, String]): Path = {
    val src = new String(Files.readAllBytes(java.nio.file.Paths.get("golden", "configs", s"$name.json")))
    val out = overrides.foldLeft(src) { case (s, (k, v)) =>
      val re = ("\"" + k + "\"\\s*:\\s*[^,\\n}]+").r
      require(re.findFirstIn(s).nonEmpty, s"config $name has no field $k")
      re.replaceAllIn(s, "\"" + k + "\": " + v)
    }
    Files.createDirectories(dir)
    Files.write(dir.resolve(s"$name-speckle.json"), out.getBytes)
  }
  val speckleOnly = Map("ipolGapWidth" -> "0", "addCorners" -> "0", "filterMedian" -> "0", "filterAdaptiveMean" -> "0")

  case class Golden(c: Case, lr: NpyArray, disp: NpyArray) {
    def w: Int = c.left.width
    def h: Int = c.left.height
  }

  def golden(config: String, c: Case, dir: Path): Golden = {
    GoldenModel.dump(config, c.left, c.right, dir)
    val lr = NpyArray.read(dir.resolve("lrcheck_L.npy"))
    val d = NpyArray.read(dir.resolve("disparity.npy"))
    val shape = Seq(c.left.height, c.left.width)
    require(lr.dtype == "<i2" && lr.shape == shape && d.dtype == "<i2" && d.shape == shape,
      s"golden: lrcheck_L/disparity have ${lr.dtype} ${lr.shape} / ${d.dtype} ${d.shape}, expected <i2 $shape")
    Golden(c, lr, d)
  }

  case class OutBeat(value: Int, sof: Boolean, eol: Boolean, eof: Boolean)

  /** Checks output beats of frames of one size against `expected(x, y)`. */
  class MapScoreboard(stage: String, w: Int, h: Int, expected: (Int, Int, Int) => Int) {
    def this(stage: String, w: Int, h: Int, one: (Int, Int) => Int) = this(stage, w, h, (_: Int, x: Int, y: Int) => one(x, y))
    val board = new Scoreboard(stage)
    def check(index: Long, b: OutBeat): Unit = {
      val pixel = index % (w.toLong * h)
      val (x, y) = ((pixel % w).toInt, (pixel / w).toInt)
      val frame = index / (w.toLong * h)
      def at = s"frame $frame (x=$x, y=$y)"
      board.check(s"$at value", expected(frame.toInt, x, y), b.value)
      board.check(s"$at sof", if (x == 0 && y == 0) 1 else 0, if (b.sof) 1 else 0)
      board.check(s"$at eol", if (x == w - 1) 1 else 0, if (b.eol) 1 else 0)
      board.check(s"$at eof", if (x == w - 1 && y == h - 1) 1 else 0, if (b.eof) 1 else 0)
    }
  }

  /** Streams lrcheck maps (frames of one size) into a post-processing module's ports. */
  def streamMaps(clock: Clock, in: DecoupledIO[Framed[SInt]], frameWidth: UInt, frameHeight: UInt,
      out: DecoupledIO[Framed[SInt]], maps: Seq[NpyArray], w: Int, h: Int, traffic: Traffic, rnd: Random,
      sink: (Long, OutBeat) => Unit, maxCycles: Long, what: String): Long = {
    poke(frameWidth, w)
    poke(frameHeight, h)
    val beats = maps.iterator.flatMap(m => Iterator.range(0, w * h).map(i => (m(i.toLong), i == 0, i % w == w - 1, i == w * h - 1)))
    run[Framed[SInt], Framed[SInt], (Int, Boolean, Boolean, Boolean), OutBeat](clock, in, beats,
      (bits, b) => { poke(bits.data, b._1); poke(bits.sof, b._2); poke(bits.eol, b._3); poke(bits.eof, b._4) },
      out, maps.length.toLong * w * h,
      o => OutBeat(peek(o.data).toInt, peek(o.sof), peek(o.eol), peek(o.eof)),
      sink, traffic, rnd, maxCycles, what)
  }

  def runSpeckle(config: String): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0x5bec)
    val tmp = tmpDir(s"post-speckle-$config")
    val json = configWith(config, tmp, speckleOnly)
    val all = cases(rnd)
    val gold = all.zipWithIndex.map { case (c, i) => golden(json.toString, c, tmp.resolve(f"golden$i%02d")) }
    simulate(new PostProcessSpeckle(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      for (g <- gold) {
        val exp = (x: Int, y: Int) => { val d = g.disp(y.toLong * g.w + x); if (d < 0) -1 else d / 16 }
        val board = new MapScoreboard(s"speckle ${g.c.label}", g.w, g.h, exp)
        val traffic = Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5)
        streamMaps(dut.clock, dut.io.in, dut.io.frameWidth, dut.io.frameHeight, dut.io.out, Seq(g.lr), g.w, g.h,
          traffic, rnd, board.check, 20L * g.w * g.h + 100000, g.c.label)
        val removed = (0L until g.lr.count).count(i => g.lr(i) >= 0 && g.disp(i) < 0)
        println(f"  ${p.name}: ${board.board.report}, $removed pixels removed (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
        assert(board.board.ok, board.board.report)
      }
    }
  }

  def runPost(config: String): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0x9057)
    val tmp = tmpDir(s"post-$config")
    val all = cases(rnd)
    val gold = all.zipWithIndex.map { case (c, i) => golden(config, c, tmp.resolve(f"golden$i%02d")) }
    val bound = (w: Int, h: Int, frames: Int) => 20L * w * h * frames + 200000
    simulate(new PostProcess(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      for (g <- gold) {
        val exp = (x: Int, y: Int) => g.disp(y.toLong * g.w + x)
        val board = new MapScoreboard(s"post ${g.c.label}", g.w, g.h, exp)
        val traffic = Traffic(rnd.nextDouble() * 0.5, rnd.nextDouble() * 0.5)
        streamMaps(dut.clock, dut.io.in, dut.io.frameWidth, dut.io.frameHeight, dut.io.out, Seq(g.lr), g.w, g.h,
          traffic, rnd, board.check, bound(g.w, g.h, 1), g.c.label)
        println(f"  ${p.name}: ${board.board.report} (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
        assert(board.board.ok, board.board.report)
      }
      // throughput: a full-size frame with no stalls
      val g = gold.find(g => g.w == p.maxWidth && g.h == p.maxHeight).get
      val tput = new MapScoreboard("post throughput", g.w, g.h, (x, y) => g.disp(y.toLong * g.w + x))
      val cycles = streamMaps(dut.clock, dut.io.in, dut.io.frameWidth, dut.io.frameHeight, dut.io.out, Seq(g.lr), g.w, g.h,
        noStall, rnd, tput.check, bound(g.w, g.h, 1), "throughput")
      assert(tput.board.ok, tput.board.report)
      val (limit, formula) = throughputBound(p, g.w, g.h)
      println(s"  ${p.name}: throughput ${g.w}x${g.h}: $cycles cycles, bound $limit ($formula)")
      assert(cycles <= limit, s"throughput: $cycles cycles > bound $limit ($formula)")
      // back to back: different frames of one size, with gaps and stalls
      val same = gold.filter(x => x.w == g.w && x.h == g.h).take(3)
      val b2b = new MapScoreboard(s"post back to back x${same.size}", g.w, g.h,
        (f: Int, x: Int, y: Int) => same(f).disp(y.toLong * g.w + x))
      streamMaps(dut.clock, dut.io.in, dut.io.frameWidth, dut.io.frameHeight, dut.io.out, same.map(_.lr), g.w, g.h,
        Traffic(0.1, 0.1), rnd, b2b.check, bound(g.w, g.h, same.size), "back to back")
      println(s"  ${p.name}: ${b2b.board.report}")
      assert(b2b.board.ok, b2b.board.report)
    }
  }

  /** INTERFACES.md §4: N pixels with no stalls complete within N + latencyRows * W + c cycles. */
  def throughputBound(p: ElasParams, w: Int, h: Int): (Long, String) = {
    val c = 4 * p.speckleWindowRows + 64
    val rows = PostProcess.latencyRows(p)
    (w.toLong * h + rows.toLong * w + c, s"N + $rows rows x W + c, c = 4 L + 64 = $c")
  }
}
