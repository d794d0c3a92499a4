package ielas

import chisel3._
import chisel3.util.DecoupledIO
import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.{Files, Path}
import scala.util.Random

/** Stage `post` alone: the golden lrcheck_L.npy streamed in, every output pixel and the framing compared with the
  * golden disparity.npy, at `small` (robotics) and `small-middlebury`, one Verilator build each. Inputs: real crops
  * (KITTI 2012, KITTI 2015, Middlebury tsukuba and cones) and seeded image pairs through the golden pipeline, plus
  * seeded synthetic lrcheck maps through the golden `ielas-post` tool (segments taller than the speckle window,
  * merge-heavy combs and nested U shapes, a node per pixel, gaps at the frame edges and around G); random input gaps
  * and output back-pressure; two frames back to back; the throughput bound with no stalls. What the cases cover
  * (window-kept speckle pixels, border fills) is counted from the golden data and must be non-zero.
  * With -Dielas.postSpeckle=1 the speckle step is also checked alone, against the golden model with the later post
  * steps switched off in its configuration JSON (ipolGapWidth 0, no corners, no mean, no median).
  */
class PostProcessSpec extends AnyFlatSpec {
  import PostProcessSpec._

  behavior of "PostProcessSpeckle (bounded small-segment removal)"

  // A development check of the speckle step alone (its own Verilator build): -Dielas.postSpeckle=1
  if (sys.props.get("ielas.postSpeckle").contains("1")) it should "match the golden speckle result at config small" in {
    runSpeckle("small")
  }

  it should "match the golden speckle result on frames shorter than its window, back to back, output stalled" in {
    runSpeckleShortFrames()
  }

  behavior of "PostProcess (stage post alone: lrcheck_L -> disparity)"

  it should "match the golden disparity at config small (robotics: gaps G = 3, adaptive mean)" in {
    runPost("small")
  }
  it should "match the golden disparity at config small-middlebury (corners, G = 32, median)" in {
    runPost("small-middlebury")
  }
  it should "elaborate to SystemVerilog at kitti and kitti-middlebury (memory summary)" in {
    for (name <- Seq("kitti", "kitti-middlebury")) {
      val p = ElasParams.byName(name)
      VerilogEmitter.emit(new PostProcess(p), StreamTester.tmpDir(s"post-verilog-$name"))
      val mem = PostProcess.memorySummary(p)
      println(s"  $name: PostProcess latency ${PostProcess.latencyRows(p)} rows; memories:")
      mem.foreach(m => println("    " + m))
      println(f"    total ${mem.map(_.bits).sum}%d bits")
    }
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
      smoothPair(128, 64, 7), smoothPair(32, 16, 3))
  }

  /** golden/configs/<name>.json with some parameters replaced, written to `dir`. */
  def configWith(name: String, dir: Path, overrides: Map[String, String]): Path = {
    val src = new String(Files.readAllBytes(java.nio.file.Paths.get("golden", "configs", s"$name.json")))
    val out = overrides.foldLeft(src) { case (s, (k, v)) =>
      val re = ("\"" + k + "\"\\s*:\\s*[^,\\n}]+").r
      require(re.findFirstIn(s).nonEmpty, s"config $name has no field $k")
      re.replaceFirstIn(s, "\"" + k + "\": " + v) // the parameter, not its entry in the legal ranges after it
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

  /** What a case exercises, from its golden input and output only (never from the hardware): pixels of small
    * segments that the window rule keeps (the segment reaches row v + L - 1), segments taller than L rows, filled
    * pixels, and filled pixels on the frame border.
    */
  case class Coverage(windowKept: Long, tallSegments: Long, filled: Long, borderFilled: Long) {
    def +(o: Coverage): Coverage = Coverage(windowKept + o.windowKept, tallSegments + o.tallSegments,
      filled + o.filled, borderFilled + o.borderFilled)
    override def toString: String = s"$windowKept small-segment pixels kept by the $L-row window, $tallSegments " +
      s"segments taller than L, $filled filled pixels ($borderFilled on the border)"
    private def L = "L"
  }
  def coverage(p: ElasParams, g: Golden): Coverage = {
    val (w, h) = (g.w, g.h)
    val lr = Array.tabulate(w * h)(i => g.lr(i.toLong))
    val label = Array.fill(w * h)(-1)
    val sizes = scala.collection.mutable.ArrayBuffer[Int]()
    val spans = scala.collection.mutable.ArrayBuffer[(Int, Int)]()
    for (seed <- 0 until w * h if label(seed) < 0 && lr(seed) >= 0) {
      val id = sizes.size
      val queue = scala.collection.mutable.ArrayBuffer(seed)
      label(seed) = id
      var q = 0
      var (minRow, maxRow) = (h, 0)
      while (q < queue.size) {
        val i = queue(q); q += 1
        val (x, y) = (i % w, i / w)
        minRow = minRow.min(y); maxRow = maxRow.max(y)
        for ((nx, ny) <- Seq((x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)) if nx >= 0 && nx < w && ny >= 0 && ny < h) {
          val j = ny * w + nx
          if (label(j) < 0 && lr(j) >= 0 && math.abs(lr(j) - lr(i)) <= p.speckleSimThreshold) { label(j) = id; queue += j }
        }
      }
      sizes += queue.size
      spans += ((minRow, maxRow))
    }
    val L = p.speckleWindowRows
    val kept = (0 until w * h).count { i =>
      val (v, id) = (i / w, label(i))
      id >= 0 && sizes(id) < p.speckleSize && v + L - 1 < h - 1 && spans(id)._2 >= v + L - 1
    }
    val tall = spans.count { case (a, b) => b - a + 1 > L }
    val filled = (0 until w * h).filter(i => lr(i) < 0 && g.disp(i.toLong) >= 0)
    val border = filled.count { i => val (x, y) = (i % w, i / w); x == 0 || y == 0 || x == w - 1 || y == h - 1 }
    Coverage(kept, tall, filled.size, border)
  }

  /** Seeded lrcheck maps no image pair gives on demand (values 0..dispMax, -1 invalid), for the golden `ielas-post`
    * tool: thin vertical segments taller than the L-row window, combs and nested U shapes (many merges in one row),
    * gaps of every length around the row gap, G and the frame edges, random speckle, and classes first touched by
    * their row's last pixel.
    */
  def syntheticMaps(p: ElasParams, rnd: Random): Seq[(String, Int, Int, Array[Int])] = {
    val dm = p.dispMax
    def blank(w: Int, h: Int, v: Int) = Array.fill(w * h)(v)
    def rect(m: Array[Int], w: Int, x0: Int, y0: Int, x1: Int, y1: Int, v: Int): Unit =
      for (y <- y0 until y1; x <- x0 until x1 if x >= 0 && y >= 0 && x < w && y * w + x < m.length) m(y * w + x) = v
    // 1: thin tall segments (sizes below speckleSize, heights around L), small blobs, on an invalid background
    val (w1, h1) = (128, 64)
    val m1 = blank(w1, h1, -1)
    for (k <- 0 until 24) {
      val (x, y, tall, thick) = (rnd.nextInt(w1), rnd.nextInt(h1), 5 + rnd.nextInt(40), 1 + rnd.nextInt(3))
      rect(m1, w1, x, y, x + thick, y + tall, 5 + rnd.nextInt(dm - 5))
    }
    for (k <- 0 until 30) { val (x, y) = (rnd.nextInt(w1), rnd.nextInt(h1)); rect(m1, w1, x, y, x + 1 + rnd.nextInt(4), y + 1 + rnd.nextInt(4), rnd.nextInt(dm + 1)) }
    // 2: combs and nested U shapes: teeth joined lower down, a value step of 1 (similar) or 2 (not) between parts
    val (w2, h2) = (128, 64)
    val m2 = blank(w2, h2, -1)
    for (c <- 0 until 4) {
      val (x0, y0, d) = (c * 32, rnd.nextInt(10), 3 + rnd.nextInt(dm - 6))
      for (t <- 0 until 7) rect(m2, w2, x0 + 4 * t, y0, x0 + 4 * t + 1 + (t % 2), y0 + 20 + 3 * t, d + (t % 3) - 1)
      rect(m2, w2, x0, y0 + 20 + 3 * 6, x0 + 28, y0 + 21 + 3 * 6, d + rnd.nextInt(3) - 1)
      for (r <- 0 until 3) { // nested U shapes opening upwards, closed at different rows
        val (a, b, bottom) = (x0 + 2 + 4 * r, x0 + 26 - 4 * r, 58 - 5 * r)
        rect(m2, w2, a, 44, a + 1, bottom, d + r); rect(m2, w2, b, 44, b + 1, bottom, d + r)
        rect(m2, w2, a, bottom - 1, b + 1, bottom, d + r)
      }
    }
    // 3: gaps: a smooth valid field with invalid runs of lengths 1..6 and around G, at the edges and inside
    val (w3, h3) = (128, 64)
    val g = math.min(p.ipolGapWidth, p.ipolColumnWindow)
    val m3 = Array.tabulate(w3 * h3)(i => (8 + (i % w3) / 16 + (i / w3) / 16).min(dm))
    for (y <- 0 until h3 by 3) { val len = 1 + (y / 3) % 6; rect(m3, w3, 0, y, len, y + 1, -1); rect(m3, w3, w3 - len, y + 1, w3, y + 2, -1) }
    for (x <- 8 until w3 - 8 by 5) {
      val len = Seq(1, 2, 3, 4, g - 1, g, g + 1, 5, 6)((x / 5) % 9).max(1)
      val mode = (x / 5) % 3
      if (mode == 0) rect(m3, w3, x, 0, x + 1, len, -1) // top run
      else if (mode == 1) rect(m3, w3, x, h3 - len, x + 1, h3, -1) // bottom run
      else rect(m3, w3, x, 20, x + 1, 20 + len, -1) // interior run
    }
    for (k <- 0 until 40) { val (x, y) = (rnd.nextInt(w3), rnd.nextInt(h3)); rect(m3, w3, x, y, x + 1 + rnd.nextInt(5), y + 1, -1) }
    for (k <- 0 until 10) { val (x, y) = (rnd.nextInt(w3), rnd.nextInt(h3)); rect(m3, w3, x, y, x + 1, y + 1 + rnd.nextInt(8), if (k % 2 == 0) -1 else dm) }
    // 4: random speckle: a piecewise field with 25 % invalid pixels and random outliers, odd size
    val (w4, h4) = (117, 50)
    val m4 = Array.tabulate(w4 * h4) { i =>
      val (x, y) = (i % w4, i / w4)
      val r = rnd.nextInt(100)
      if (r < 25) -1 else if (r < 35) rnd.nextInt(dm + 1) else (4 + x / 20 + y / 10 + (x / 30 + y / 25) % 3).min(dm)
    }
    // 5: every pixel its own run (columns alternate by 2): N = W nodes per row, the labeller reads each class at
    // the flattening sweep's own position; 2-pixel-wide bands of rows merge and split the columns
    val (w5, h5) = (128, 64)
    val m5 = Array.tabulate(w5 * h5) { i =>
      val (x, y) = (i % w5, i / w5)
      if ((y / 8) % 4 == 3 && x % 16 < 2) -1 else (10 + 2 * (x % 2) + (if ((y / 8) % 4 == 1) x % 2 else 0)).min(dm)
    }
    // 6: a class first touched by its row's last pixel: a full row, then a row whose only valid pixel is its last
    // (joined to the row above), then a full row, then an invalid row. The forward map of the sparse row is built
    // from the cycle after that pixel's decision, so its touch must be forwarded (128 + 1 + 128 pixels, kept, but
    // the first row alone is below speckleSize 200)
    val (w6, h6) = (128, 64)
    val m6 = Array.tabulate(w6 * h6) { i =>
      val (x, y) = (i % w6, i / w6)
      val d = (7 + y / 4).min(dm)
      y % 4 match { case 0 | 2 => d; case 1 => if (x == w6 - 1) d else -1; case _ => -1 }
    }
    Seq(("one run per pixel 128x64", w5, h5, m5), ("a class first touched by the row's last pixel 128x64", w6, h6, m6),
      ("thin tall segments 128x64", w1, h1, m1), ("combs and nested U shapes 128x64", w2, h2, m2),
      ("gaps at edges and around G 128x64", w3, h3, m3), ("random speckle 117x50", w4, h4, m4))
  }

  /** The golden post step on a given map (ielas-post, next to ielas-golden). */
  def goldenPost(config: String, label: String, w: Int, h: Int, map: Array[Int], dir: Path): Golden = {
    Files.createDirectories(dir)
    val raw = new Array[Byte](2 * w * h)
    for (i <- 0 until w * h) { raw(2 * i) = (map(i) & 0xff).toByte; raw(2 * i + 1) = ((map(i) >> 8) & 0xff).toByte }
    NpyArray.write(dir.resolve("lrcheck_L.npy"), "<i2", Seq(h, w), raw)
    val tool = GoldenModel.binary.resolveSibling("ielas-post")
    val cmd = Seq(tool.toString, "--config", config, "--in", dir.resolve("lrcheck_L.npy").toString,
      "--out", dir.resolve("disparity.npy").toString)
    import scala.sys.process._
    val rc = cmd.!
    if (rc != 0) throw new IllegalStateException(s"golden: '${cmd.mkString(" ")}' failed ($rc) (make golden builds ielas-post)")
    val img = GrayImage(w, h, new Array[Byte](w * h))
    Golden(Case(label, img, img), NpyArray.read(dir.resolve("lrcheck_L.npy")), NpyArray.read(dir.resolve("disparity.npy")))
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

  /** Frames of 16 rows at a speckle window of L = 24 rows (`small` otherwise), back to back with the output 80 %
    * stalled: the labeller runs a whole frame ahead, so each frame's first row is ready the moment the last one's
    * virtual row has been issued, and its chain length (16) is below L - 1. The case where the speckle chain's ring
    * would take a register from a live beat without its wait after a virtual row (`cool`). */
  def runSpeckleShortFrames(): Unit = {
    val L = 24
    val p = ElasParams.byName("small").copy(speckleWindowRows = L)
    val rnd = new Random(seed ^ 0x5b0f)
    val tmp = tmpDir("post-speckle-short")
    val json = configWith("small", tmp, speckleOnly + ("speckleWindowRows" -> L.toString))
    val (w, h, dm) = (64, 16, p.dispMax)
    val gold = (0 until 4).map { f =>
      val m = Array.tabulate(w * h) { i =>
        val (x, y) = (i % w, i / w)
        val r = rnd.nextInt(100)
        if (r < 30) -1 else if (r < 40) rnd.nextInt(dm + 1) else (4 + x / 12 + y / 5 + f).min(dm)
      }
      goldenPost(json.toString, s"short frame $f", w, h, m, tmp.resolve(f"frame$f%02d"))
    }
    val exp = (f: Int, x: Int, y: Int) => { val d = gold(f).disp(y.toLong * w + x); if (d < 0) -1 else d / 16 }
    val removed = gold.map(g => (0L until g.lr.count).count(i => g.lr(i) >= 0 && g.disp(i) < 0)).sum
    assert(removed > 0, "the short frames remove no pixel: the case would not show a lost result")
    simulate(new PostProcessSpeckle(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      val board = new MapScoreboard(s"speckle L = $L, ${gold.size} frames ${w}x$h back to back, output stalled 80 %", w, h, exp)
      streamMaps(dut.clock, dut.io.in, dut.io.frameWidth, dut.io.frameHeight, dut.io.out, gold.map(_.lr), w, h,
        Traffic(0.0, 0.8), rnd, board.check, 20L * w * h * gold.size + 100000, "short frames")
      println(s"  ${board.board.report}, $removed pixels removed")
      assert(board.board.ok, board.board.report)
    }
  }

  def runPost(config: String): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0x9057)
    val tmp = tmpDir(s"post-$config")
    val all = cases(rnd)
    val synth = syntheticMaps(p, rnd)
    val gold = all.zipWithIndex.map { case (c, i) => golden(config, c, tmp.resolve(f"golden$i%02d")) } ++
      synth.zipWithIndex.map { case ((label, w, h, m), i) => goldenPost(config, label, w, h, m, tmp.resolve(f"synth$i%02d")) }
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
        println(s"    covers ${coverage(p, g)}")
        assert(board.board.ok, board.board.report)
      }
      val total = gold.map(coverage(p, _)).reduce(_ + _)
      assert(total.windowKept > 0 && total.tallSegments > 0 && total.borderFilled > 0, s"cases do not cover: $total")
      // throughput: a full-size real frame and the worst labelling case (a node per pixel), with no stalls
      for (g <- Seq(gold.find(g => g.w == p.maxWidth && g.h == p.maxHeight).get, gold.find(_.c.label.startsWith("one run")).get)) {
      val tput = new MapScoreboard("post throughput", g.w, g.h, (x, y) => g.disp(y.toLong * g.w + x))
      val cycles = streamMaps(dut.clock, dut.io.in, dut.io.frameWidth, dut.io.frameHeight, dut.io.out, Seq(g.lr), g.w, g.h,
        noStall, rnd, tput.check, bound(g.w, g.h, 1), "throughput")
      assert(tput.board.ok, tput.board.report)
      val (limit, formula) = throughputBound(p, g.w, g.h)
      println(s"  ${p.name}: throughput ${g.c.label}: $cycles cycles, bound $limit ($formula)")
      assert(cycles <= limit, s"throughput: $cycles cycles > bound $limit ($formula)")
      }
      val g = gold.find(g => g.w == p.maxWidth && g.h == p.maxHeight).get
      // back to back: different frames of one size, with gaps and stalls; then with the output mostly stalled, so the
      // input runs rows ahead and each next frame is ready the moment the last one's rows have been issued
      val same = gold.filter(x => x.w == g.w && x.h == g.h).take(2)
      for ((traffic, what) <- Seq((Traffic(0.1, 0.1), "back to back"), (Traffic(0.0, 0.8), "back to back, output stalled 80 %"))) {
        val b2b = new MapScoreboard(s"post $what x${same.size}", g.w, g.h,
          (f: Int, x: Int, y: Int) => same(f).disp(y.toLong * g.w + x))
        streamMaps(dut.clock, dut.io.in, dut.io.frameWidth, dut.io.frameHeight, dut.io.out, same.map(_.lr), g.w, g.h,
          traffic, rnd, b2b.check, bound(g.w, g.h, same.size), what)
        println(s"  ${p.name}: ${b2b.board.report}")
        assert(b2b.board.ok, b2b.board.report)
      }
      // back to back with the frame size changing at every start of frame
      val mixed = Seq(gold.find(_.w == 117).get, gold.find(_.w == 32).get, gold.find(_.c.label.startsWith("Middlebury cones")).get, g)
      val starts = mixed.scanLeft(0L)((acc, f) => acc + f.w.toLong * f.h)
      val mixedBoard = new Scoreboard(s"post back to back, sizes ${mixed.map(f => s"${f.w}x${f.h}").mkString(" ")}")
      val beats = mixed.iterator.flatMap { f =>
        Iterator.range(0, f.w * f.h).map(i => (f.lr(i.toLong), i == 0, i % f.w == f.w - 1, i == f.w * f.h - 1, f.w, f.h))
      }
      run[Framed[SInt], Framed[SInt], (Int, Boolean, Boolean, Boolean, Int, Int), OutBeat](dut.clock, dut.io.in, beats,
        (bits, b) => {
          if (b._2) { poke(dut.io.frameWidth, b._5); poke(dut.io.frameHeight, b._6) } // the size of the frame at its sof
          poke(bits.data, b._1); poke(bits.sof, b._2); poke(bits.eol, b._3); poke(bits.eof, b._4)
        },
        dut.io.out, starts.last, o => OutBeat(peek(o.data).toInt, peek(o.sof), peek(o.eol), peek(o.eof)),
        (i, b) => {
          val k = starts.lastIndexWhere(_ <= i)
          val f = mixed(k)
          val pix = (i - starts(k)).toInt
          val (x, y) = (pix % f.w, pix / f.w)
          val at = s"frame $k ${f.w}x${f.h} (x=$x, y=$y)"
          mixedBoard.check(s"$at value", f.disp(pix.toLong), b.value)
          mixedBoard.check(s"$at sof", if (pix == 0) 1 else 0, if (b.sof) 1 else 0)
          mixedBoard.check(s"$at eol", if (x == f.w - 1) 1 else 0, if (b.eol) 1 else 0)
          mixedBoard.check(s"$at eof", if (pix == f.w * f.h - 1) 1 else 0, if (b.eof) 1 else 0)
        }, Traffic(0.2, 0.2), rnd, bound(128, 64, mixed.size), "back to back, mixed sizes")
      println(s"  ${p.name}: ${mixedBoard.report}")
      assert(mixedBoard.ok, mixedBoard.report)
    }
  }

  /** docs/interfaces.md §4: N pixels with no stalls complete within N + latencyRows * W + c cycles. */
  def throughputBound(p: ElasParams, w: Int, h: Int): (Long, String) = {
    val c = 4 * p.speckleWindowRows + 64
    val rows = PostProcess.latencyRows(p)
    (w.toLong * h + rows.toLong * w + c, s"N + $rows rows x W + c, c = 4 L + 64 = $c")
  }
}
