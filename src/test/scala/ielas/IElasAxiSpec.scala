package ielas

import chisel3._
import chisel3.util.Decoupled
import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.Files
import scala.collection.mutable.ArrayBuffer
import scala.util.Random

/** One AXI4-Stream video beat as the test drives and sees it: tdata, tuser (start of frame), tlast (end of line). */
class AxisBeat extends Bundle {
  val tdata = UInt(16.W)
  val tuser = Bool()
  val tlast = Bool()
}

/** The IElasAxi top as emitted, under a Module so chiseltest can clock it: `clock` drives aclk and the test's
  * active-high reset drives aresetn low. The video ports are regrouped as Decoupled for the stream driver; the
  * AXI4-Lite port passes through unchanged.
  */
class IElasAxiHarness(p: ElasParams) extends Module {
  val in = IO(Flipped(Decoupled(new AxisBeat)))
  val out = IO(Decoupled(new AxisBeat))
  val ctrl = IO(Flipped(new AxiLite(IElasAxi.addrBits)))
  val dut = Module(new IElasAxi(p))
  dut.aclk := clock
  dut.aresetn := !reset.asBool
  dut.s_axis_video.tvalid := in.valid
  dut.s_axis_video.tdata := in.bits.tdata
  dut.s_axis_video.tuser := in.bits.tuser
  dut.s_axis_video.tlast := in.bits.tlast
  in.ready := dut.s_axis_video.tready
  out.valid := dut.m_axis_video.tvalid
  out.bits.tdata := dut.m_axis_video.tdata
  out.bits.tuser := dut.m_axis_video.tuser
  out.bits.tlast := dut.m_axis_video.tlast
  dut.m_axis_video.tready := out.ready
  dut.s_axi_ctrl <> ctrl
}

/** IElasAxi (the drop-in IP) at config `small`: real image crops over AXI4-Stream with random tvalid gaps and tready
  * back-pressure against the golden model, and every register driven over AXI4-Lite at the offsets parsed from the
  * C header the generator writes, illegal accesses included, with the counters checked against what the test itself
  * sent, received and counted.
  */
class IElasAxiSpec extends AnyFlatSpec {
  import IElasAxiSpec._

  behavior of "IElasAxi"

  it should "stream real images over AXI4-Stream under gaps and back-pressure, bit-exact to the golden model" in {
    val p = ElasParams.byName(config)
    val rnd = new Random(StreamTester.seed ^ 0xa71)
    val (kl, kr) = TestImages.kitti2012
    val (tl, tr) = TestImages.middleburyTsukuba
    import IElasEndToEndSpec.Frame
    val frames = Seq(
      Frame("KITTI 2012 000070 crop 128x64 at (560,170)", kl.crop(560, 170, 128, 64), kr.crop(560, 170, 128, 64)),
      Frame("Middlebury tsukuba crop 128x64 at (120,110)", tl.crop(120, 110, 128, 64), tr.crop(120, 110, 128, 64)),
      Frame("noise 64x32", TestImages.noise(64, 32, rnd), TestImages.noise(64, 32, rnd)))
    val tmp = StreamTester.tmpDir(s"axi-$config")
    val expected = frames.zipWithIndex.map { case (f, i) => IElasEndToEndSpec.golden(p, f, tmp.resolve(f"golden$i%02d")) }
    val regs = RegisterHeader.generated(p, tmp.resolve("header"))
    StreamTester.simulate(new IElasAxiHarness(p), tmp.resolve("verilator"), cache = true) { dut =>
      val bench = new Bench(dut, regs)
      StreamTester.reset(dut)
      var compared = 0L
      // each frame alone (its size written first), then the two 128x64 frames back to back
      val runs = frames.indices.map(Seq(_)) :+ Seq(0, 1)
      for (run <- runs) {
        val fs = run.map(frames(_))
        bench.write("FRAME_WIDTH", fs.head.width)
        bench.write("FRAME_HEIGHT", fs.head.height)
        val traffic = StreamTester.Traffic(0.1 + rnd.nextDouble() * 0.3, 0.1 + rnd.nextDouble() * 0.3)
        val got = bench.stream(fs.map(f => (f.left, f.right, f.height)), traffic, rnd, fs.map(f => f.width * f.height).sum)
        val outFrames = splitFrames(got)
        assert(outFrames.length == fs.length, s"${fs.map(_.label)}: ${outFrames.length} output frames for ${fs.length}")
        for (((k, f), o) <- run.zip(fs).zip(outFrames)) {
          val board = new Scoreboard(s"IElasAxi [${f.label}]")
          board.check(s"${f.label} output beats", f.width * f.height, o.length)
          for ((b, i) <- o.zipWithIndex.take(f.width * f.height)) {
            val (x, y) = (i % f.width, i / f.width)
            board.check(s"${f.label} (x=$x, y=$y) disparity", expected(k)(i), b.disparity)
            board.check(s"${f.label} (x=$x, y=$y) tuser", if (i == 0) 1 else 0, if (b.tuser) 1 else 0)
            board.check(s"${f.label} (x=$x, y=$y) tlast", if (x == f.width - 1) 1 else 0, if (b.tlast) 1 else 0)
          }
          assert(board.ok, board.report)
          compared += board.compared
          println(f"  ${board.report} (tvalid gaps ${traffic.inputGap}%.2f, tready stalls ${traffic.outputStall}%.2f)")
        }
      }
      // the counters against what the test sent, received and counted itself
      val sent = runs.map(_.length).sum
      assert(bench.read("STATUS") == 0, "STATUS after legal frames: no error, not busy")
      assert(bench.read("FRAMES_IN") == sent)
      assert(bench.read("FRAMES_OUT") == sent)
      assert(bench.read("FRAMES_ABORTED") == 0)
      assert(bench.read("OUTPUT_STALL_CYCLES") == bench.stalls, "output stall cycles")
      assert(bench.read("LAST_FRAME_CYCLES") == bench.lastFrameCycles, "cycles of the last output frame")
      println(s"  $sent frames, $compared values compared; ${bench.stalls} stall cycles and last frame " +
        s"${bench.lastFrameCycles} cycles as counted by the test")
    }
  }

  it should "drive every register over AXI4-Lite at the header's offsets, illegal accesses included" in {
    val p = ElasParams.byName(config)
    val rnd = new Random(StreamTester.seed ^ 0xa72)
    val tmp = StreamTester.tmpDir(s"axi-$config")
    val regs = RegisterHeader.generated(p, tmp.resolve("header"))
    // The register names are the documented interface (README); every offset and mask comes from the header.
    val rw = Seq("CONTROL", "FRAME_WIDTH", "FRAME_HEIGHT")
    val counters = Seq("FRAMES_IN", "FRAMES_OUT", "FRAMES_ABORTED", "LAST_FRAME_CYCLES", "OUTPUT_STALL_CYCLES")
    val params = Map("VERSION" -> 0x00010000L, "MAX_WIDTH" -> p.maxWidth.toLong, "MAX_HEIGHT" -> p.maxHeight.toLong,
      "DISP_MAX" -> p.dispMax.toLong, "WINDOW_SIZE" -> p.windowSize.toLong,
      "STORED_DISPARITIES" -> p.storedDisparities.toLong, "CYCLES_PER_PIXEL" -> p.cyclesPerPixel.toLong)
    val all = rw ++ Seq("STATUS") ++ counters ++ params.keys
    assert(regs.offsets.keySet == all.toSet, s"header registers ${regs.offsets.keySet} differ from the documented $all")
    for ((n, v) <- params) assert(regs.values(n) == v, s"header ${n}_VALUE")
    val tiny = Seq.tabulate(8)(_ => (TestImages.noise(32, 16, rnd), TestImages.noise(32, 16, rnd)))
    val goldens = tiny.zipWithIndex.map { case ((l, r), i) =>
      IElasEndToEndSpec.golden(p, IElasEndToEndSpec.Frame(s"noise $i", l, r), tmp.resolve(f"tiny$i%02d"))
    }
    StreamTester.simulate(new IElasAxiHarness(p), tmp.resolve("verilator"), cache = true) { dut =>
      val b = new Bench(dut, regs)
      StreamTester.reset(dut)
      val enable = regs.mask("CONTROL", "ENABLE")
      def status(field: String) = regs.mask("STATUS", field)

      // reset values and the generator parameters
      for ((n, v) <- params) assert(b.read(n) == v, s"$n")
      assert(b.read("CONTROL") == enable, "CONTROL resets to ENABLE")
      assert(b.read("STATUS") == 0)
      assert(b.read("FRAME_WIDTH") == p.maxWidth && b.read("FRAME_HEIGHT") == p.maxHeight)
      for (c <- counters) assert(b.read(c) == 0, c)

      // read/write registers, AW and W in every order, byte strobes, a slow B
      assert(b.writeResp(regs.offsets("FRAME_WIDTH"), 100, order = AwFirst) == Resp.okay)
      assert(b.read("FRAME_WIDTH") == 100)
      assert(b.writeResp(regs.offsets("FRAME_HEIGHT"), 40, order = WFirst) == Resp.okay)
      assert(b.read("FRAME_HEIGHT") == 40)
      assert(b.writeResp(regs.offsets("FRAME_WIDTH"), 0xabcd0060L, strb = 0x1, order = Together, bDelay = 5) == Resp.okay)
      assert(b.read("FRAME_WIDTH") == 0x60, "only byte 0 written")
      // a size that does not fit its register is refused
      assert(b.writeResp(regs.offsets("FRAME_WIDTH"), 1L << 12, order = WFirst) == Resp.slvErr)
      assert(b.writeResp(regs.offsets("FRAME_WIDTH"), 0x100, strb = 0x2) == Resp.slvErr)
      assert(b.read("FRAME_WIDTH") == 0x60, "a refused write leaves the register unchanged")

      // every read-only register: SLVERR, unchanged
      for (n <- all.filterNot(rw.contains)) {
        val before = b.read(n) & ~status("BUSY")
        for (order <- Seq(AwFirst, WFirst, Together))
          assert(b.writeResp(regs.offsets(n), 0xffffffffL, order = order) == Resp.slvErr, s"write to RO $n")
        assert((b.read(n) & ~status("BUSY")) == before, s"$n changed by a refused write")
      }
      // every unmapped word of the window: DECERR for reads and writes, data 0
      val mapped = regs.offsets.values.toSet
      val unmapped = (0 until (1 << regs.addrBits) by 4).filterNot(a => mapped.contains(a.toLong))
      for (a <- unmapped) {
        assert(b.writeResp(a, 0x12345678L, order = Seq(AwFirst, WFirst, Together)(a / 4 % 3)) == Resp.decErr, f"write 0x$a%02x")
        assert(b.readResp(a) == ((0L, Resp.decErr)), f"read 0x$a%02x")
      }
      // a write whose B is held back while the next AW and W already arrive: both answered in order
      assert(b.pipelinedWrites(regs.offsets("FRAME_WIDTH"), 32, regs.offsets("STATUS"), 1) == Seq(Resp.okay, Resp.slvErr))
      assert(b.read("FRAME_WIDTH") == 32)
      b.write("FRAME_WIDTH", 32) // the bench learns the frame size from its own writes
      b.write("FRAME_HEIGHT", 16)
      b.write("CONTROL", enable | regs.mask("CONTROL", "CLEAR_COUNTERS"))
      b.stalls = 0
      for (c <- counters) assert(b.read(c) == 0, s"$c after CLEAR_COUNTERS")
      println(s"  ${b.reads} reads, ${b.writes} writes (${unmapped.length} unmapped words, ${all.length - rw.length} read-only registers)")

      // expected counters: frames the test sent, saw complete, and knows were cut or dropped
      var (in, out, aborted) = (0L, 0L, 0L)
      def counted(what: String): Unit = {
        b.waitIdle()
        assert(b.read("FRAMES_IN") == in, s"$what: FRAMES_IN")
        assert(b.read("FRAMES_OUT") == out, s"$what: FRAMES_OUT")
        assert(b.read("FRAMES_ABORTED") == aborted, s"$what: FRAMES_ABORTED")
        assert(b.read("OUTPUT_STALL_CYCLES") == b.stalls, s"$what: OUTPUT_STALL_CYCLES")
      }
      def goodFrame(k: Int, what: String): Unit = {
        val (l, r) = tiny(k)
        val got = splitFrames(b.stream(Seq((l, r, 16)), StreamTester.Traffic(0.2, 0.2), rnd, 32 * 16))
        assert(got.length == 1, s"$what: ${got.length} output frames")
        val board = new Scoreboard(s"IElasAxi [$what]")
        for ((o, i) <- got.head.zipWithIndex) {
          board.check(s"$what (x=${i % 32}, y=${i / 32}) disparity", goldens(k)(i), o.disparity)
          board.check(s"$what (x=${i % 32}, y=${i / 32}) tuser", if (i == 0) 1 else 0, if (o.tuser) 1 else 0)
          board.check(s"$what (x=${i % 32}, y=${i / 32}) tlast", if (i % 32 == 31) 1 else 0, if (o.tlast) 1 else 0)
        }
        assert(board.ok, board.report)
        in += 1; out += 1
      }
      goodFrame(0, "first frame")
      counted("one good frame")
      assert(b.read("LAST_FRAME_CYCLES") == b.lastFrameCycles)

      // each malformed input raises its own sticky cause bit; CLEAR_ERROR clears them
      def malformed(cause: String, beats: Seq[Beat], frames: Int, cut: Int, complete: Int): Unit = {
        b.send(beats)
        in += frames; aborted += cut; out += complete
        counted(cause)
        assert(b.read("STATUS") == (status("ERROR") | status(cause)), s"$cause: STATUS")
        b.write("CONTROL", enable | regs.mask("CONTROL", "CLEAR_ERROR"))
        assert(b.read("STATUS") == 0, s"$cause: STATUS after CLEAR_ERROR")
      }
      val (l0, r0) = tiny(1)
      val frame = beats(l0, r0, 16)
      malformed("ERR_SHORT_LINE", frame.take(32 * 3 + 19) ++ Seq(frame(32 * 3 + 19).copy(tlast = true)) ++ frame.drop(32 * 4), 1, 1, 0)
      malformed("ERR_LONG_LINE", frame.take(32 * 2) ++ frame.slice(32 * 2, 32 * 3 - 1) ++ frame.slice(32 * 2, 32 * 3) ++ frame.drop(32 * 3), 1, 1, 0)
      malformed("ERR_EARLY_SOF", frame.take(32 * 8) ++ frame, 2, 1, 1)
      malformed("ERR_EXTRA_LINES", frame ++ frame.slice(32, 64), 1, 0, 1)
      b.write("FRAME_WIDTH", 16)
      malformed("ERR_SIZE", beats(TestImages.noise(16, 16, rnd), TestImages.noise(16, 16, rnd), 16), 1, 1, 0)
      b.write("FRAME_WIDTH", 32)
      goodFrame(2, "after the malformed frames")
      counted("good frame after the malformed ones")

      // ENABLE = 0 holds tready low; the frame goes through once enabled again
      b.write("CONTROL", 0)
      assert(b.read("CONTROL") == 0)
      assert(!b.offerFor(beats(tiny(3)._1, tiny(3)._2, 16).head, 40), "a beat was taken while disabled")
      b.write("CONTROL", enable)
      goodFrame(3, "after re-enabling")
      counted("re-enabled")

      // SOFT_RESET in mid-frame drops that frame (counted as aborted); the next frame is bit-exact
      b.send(beats(tiny(4)._1, tiny(4)._2, 16).take(32 * 6))
      in += 1
      assert((b.read("STATUS") & status("BUSY")) != 0, "BUSY with a frame in flight")
      b.write("CONTROL", enable | regs.mask("CONTROL", "SOFT_RESET"))
      aborted += 1
      counted("soft reset in mid-frame")
      assert(b.read("CONTROL") == enable && b.read("FRAME_WIDTH") == 32, "SOFT_RESET keeps the registers")
      goodFrame(5, "after the soft reset")
      counted("after the soft reset")
      assert(b.read("STATUS") == 0)
      println(s"  counters: $in frames in, $out out, $aborted aborted, ${b.stalls} stall cycles; ${b.reads} reads, ${b.writes} writes in all")
    }
  }
}

object IElasAxiSpec {
  val config = "small"

  object Resp {
    val okay = 0
    val slvErr = 2
    val decErr = 3
  }

  sealed trait Order
  case object AwFirst extends Order
  case object WFirst extends Order
  case object Together extends Order

  /** One input beat: the left pixel in tdata[15:8], the right one in tdata[7:0] (the documented packing). */
  case class Beat(left: Int, right: Int, tuser: Boolean, tlast: Boolean) {
    def tdata: Int = (left << 8) | right
  }
  case class OutBeat(tdata: Int, tuser: Boolean, tlast: Boolean) {
    /** tdata as signed disparity·16; 0xFFFF = −1 = invalid. */
    def disparity: Int = if (tdata >= 0x8000) tdata - 0x10000 else tdata
  }

  def beats(l: GrayImage, r: GrayImage, rows: Int): Seq[Beat] =
    Seq.tabulate(l.width * rows)(i => Beat(l.pixels(i) & 0xff, r.pixels(i) & 0xff, i == 0, i % l.width == l.width - 1))

  /** Output beats split at each tuser. */
  def splitFrames(beats: Seq[OutBeat]): Seq[Seq[OutBeat]] = {
    val frames = ArrayBuffer.empty[ArrayBuffer[OutBeat]]
    for (b <- beats) { if (b.tuser || frames.isEmpty) frames += ArrayBuffer.empty[OutBeat]; frames.last += b }
    frames.map(_.toSeq).toSeq
  }

  /** The register map as the generated C header states it. */
  case class RegisterHeader(addrBits: Int, offsets: Map[String, Long], values: Map[String, Long], masks: Map[String, Long]) {
    def mask(reg: String, field: String): Long = masks.getOrElse(s"${reg}_$field", throw new NoSuchElementException(s"no ${reg}_${field}_MASK"))
  }
  object RegisterHeader {
    /** Writes the header with the generator's own writer (as `make verilog` does) and parses the file. */
    def generated(p: ElasParams, dir: java.nio.file.Path): RegisterHeader = {
      val files = IElasAxi.writeRegisterMap(p, dir)
      parse(new String(Files.readAllBytes(files.find(_.getFileName.toString == "IElasAxi_regs.h").get), "UTF-8"))
    }
    def parse(text: String): RegisterHeader = {
      val define = """#define IELAS_AXI_(\w+) (0x[0-9A-Fa-f]+|\d+)u?\b.*""".r
      val defs = text.linesIterator.collect { case define(n, v) =>
        n -> (if (v.startsWith("0x")) java.lang.Long.parseLong(v.drop(2), 16) else v.toLong)
      }.toMap
      def suffixed(s: String) = defs.collect { case (n, v) if n.endsWith(s) => n.stripSuffix(s) -> v }
      RegisterHeader(defs("ADDR_BITS").toInt, suffixed("_OFFSET"), suffixed("_VALUE"), suffixed("_MASK"))
    }
  }

  /** The test bench around the harness: every clock step goes through [[tick]] (or the stream driver's onCycle),
    * which counts output stall cycles and the cycle of each output transfer, as the hardware's counters should.
    */
  class Bench(dut: IElasAxiHarness, regs: RegisterHeader) {
    import StreamTester.{peek, poke}
    private val c = dut.ctrl
    var cycle = 0L
    var stalls = 0L
    var lastFrameCycles = 0L
    private var frameStart = -1L
    private var outX = 0
    var reads = 0
    var writes = 0
    private val drained = ArrayBuffer.empty[OutBeat]

    private def observe(b: OutBeat): Unit = {
      // eof is not a port: the test knows the frame size (FRAME_WIDTH x FRAME_HEIGHT) of its own frames
      if (b.tuser) { frameStart = cycle; outX = 0 }
      outX += 1
      if (outX == width * height && frameStart >= 0) lastFrameCycles = cycle - frameStart + 1
    }
    private var width = 0
    private var height = 0

    /** Bookkeeping of one cycle, before its clock edge; with `drain` the output is taken (ready high). */
    private def account(): Unit = if (peek(dut.out.valid) && !peek(dut.out.ready)) stalls += 1
    def tick(drain: Boolean = true): Unit = {
      poke(dut.out.ready, drain)
      if (drain && peek(dut.out.valid)) {
        val o = OutBeat(peek(dut.out.bits.tdata).toInt, peek(dut.out.bits.tuser), peek(dut.out.bits.tlast))
        observe(o); drained += o
      }
      account()
      StreamTester.step(dut.clock)
      cycle += 1
    }

    private def until(what: String, limit: Int = 64)(cond: => Boolean): Unit = {
      var n = 0
      while (!cond) {
        if (n >= limit) throw new AssertionError(s"AXI4-Lite: $what not answered in $limit cycles (seed ${StreamTester.seed})")
        tick(); n += 1
      }
    }

    /** One write; returns BRESP. AW and W in the given order (a few idle cycles between them), B taken after
      * `bDelay` cycles of bready low.
      */
    def writeResp(addr: Long, data: Long, strb: Int = 0xf, order: Order = Together, bDelay: Int = 0): Int = {
      writes += 1
      def aw(): Unit = {
        poke(c.awaddr, addr); poke(c.awprot, 0); poke(c.awvalid, true)
        until("AW")(peek(c.awready)); tick(); poke(c.awvalid, false)
      }
      def w(): Unit = {
        poke(c.wdata, data); poke(c.wstrb, strb); poke(c.wvalid, true)
        until("W")(peek(c.wready)); tick(); poke(c.wvalid, false)
      }
      order match {
        case AwFirst => aw(); tick(); tick(); w()
        case WFirst => w(); tick(); tick(); aw()
        case Together =>
          poke(c.awaddr, addr); poke(c.awprot, 0); poke(c.wdata, data); poke(c.wstrb, strb)
          poke(c.awvalid, true); poke(c.wvalid, true)
          var (awDone, wDone, n) = (false, false, 0)
          while (!(awDone && wDone)) {
            if (n > 64) throw new AssertionError("AXI4-Lite: AW/W not taken")
            val a = peek(c.awready); val ww = peek(c.wready)
            tick(); n += 1
            if (a && !awDone) { awDone = true; poke(c.awvalid, false) }
            if (ww && !wDone) { wDone = true; poke(c.wvalid, false) }
          }
      }
      poke(c.bready, false)
      for (_ <- 0 until bDelay) tick()
      poke(c.bready, true)
      until("B")(peek(c.bvalid))
      val resp = peek(c.bresp).toInt
      tick()
      poke(c.bready, false)
      resp
    }

    /** Two writes: the second AW and W are offered while the first B is held back; returns both BRESPs in order. */
    def pipelinedWrites(addr1: Long, data1: Long, addr2: Long, data2: Long): Seq[Int] = {
      writes += 2
      poke(c.bready, false)
      for ((a, d) <- Seq((addr1, data1), (addr2, data2))) {
        poke(c.awaddr, a); poke(c.wdata, d); poke(c.wstrb, 0xf); poke(c.awvalid, true); poke(c.wvalid, true)
        var (awDone, wDone, n) = (false, false, 0)
        while (!(awDone && wDone)) {
          if (n > 64) throw new AssertionError("AXI4-Lite: AW/W of a pipelined write not taken")
          val aR = peek(c.awready); val wR = peek(c.wready)
          tick(); n += 1
          if (aR && !awDone) { awDone = true; poke(c.awvalid, false) }
          if (wR && !wDone) { wDone = true; poke(c.wvalid, false) }
        }
      }
      Seq.fill(2) {
        poke(c.bready, true)
        until("B")(peek(c.bvalid))
        val r = peek(c.bresp).toInt
        tick(); poke(c.bready, false); tick()
        r
      }
    }

    def readResp(addr: Long): (Long, Int) = {
      reads += 1
      poke(c.araddr, addr); poke(c.arprot, 0); poke(c.arvalid, true)
      until("AR")(peek(c.arready)); tick(); poke(c.arvalid, false)
      poke(c.rready, true)
      until("R")(peek(c.rvalid))
      val r = (peek(c.rdata).toLong, peek(c.rresp).toInt)
      tick(); poke(c.rready, false)
      r
    }

    def read(name: String): Long = {
      val (d, r) = readResp(regs.offsets(name))
      assert(r == Resp.okay, s"read $name: RRESP $r")
      d
    }
    def write(name: String, value: Long): Unit = {
      val r = writeResp(regs.offsets(name), value)
      assert(r == Resp.okay, s"write $name: BRESP $r")
      if (name == "FRAME_WIDTH") width = value.toInt
      if (name == "FRAME_HEIGHT") height = value.toInt
    }

    /** Streams frames (left, right, rows sent) with StreamTester under `traffic` until `expected` output beats have
      * come; returns them.
      */
    def stream(frames: Seq[(GrayImage, GrayImage, Int)], traffic: StreamTester.Traffic, rnd: Random, expected: Long): Seq[OutBeat] = {
      val got = ArrayBuffer.empty[OutBeat]
      val input = frames.iterator.flatMap { case (l, r, rows) => beats(l, r, rows) }
      StreamTester.run[AxisBeat, AxisBeat, Beat, OutBeat](dut.clock, dut.in, input, pokeBeat,
        dut.out, expected, o => OutBeat(peek(o.tdata).toInt, peek(o.tuser), peek(o.tlast)),
        (_, o) => { observe(o); got += o }, traffic, rnd,
        maxCycles = 40L * frames.map(f => f._1.width * f._3).sum + 200000, what = "IElasAxi stream",
        onCycle = () => { account(); cycle += 1 })
      got.toSeq
    }

    private def pokeBeat(bits: AxisBeat, b: Beat): Unit = {
      poke(bits.tdata, b.tdata); poke(bits.tuser, b.tuser); poke(bits.tlast, b.tlast)
    }

    /** Sends beats (no gaps) with the output always ready; what comes out is drained. */
    def send(bs: Seq[Beat]): Unit = {
      for (b <- bs) {
        pokeBeat(dut.in.bits, b); poke(dut.in.valid, true)
        var n = 0
        while (!peek(dut.in.ready)) {
          if (n > 100000) throw new AssertionError("IElasAxi: input not taken")
          tick(); n += 1
        }
        tick()
      }
      poke(dut.in.valid, false)
    }

    /** Offers one beat for `cycles` cycles; returns whether it was taken (valid dropped afterwards). */
    def offerFor(b: Beat, cycles: Int): Boolean = {
      pokeBeat(dut.in.bits, b); poke(dut.in.valid, true)
      var taken = false
      for (_ <- 0 until cycles if !taken) { taken = peek(dut.in.ready); tick() }
      poke(dut.in.valid, false)
      taken
    }

    /** Drains the output until STATUS.BUSY clears (bounded). */
    def waitIdle(limit: Int = 200000): Unit = {
      val busy = regs.mask("STATUS", "BUSY")
      var n = 0
      while ((read("STATUS") & busy) != 0) {
        if (n > limit) throw new AssertionError("IElasAxi: BUSY never cleared")
        for (_ <- 0 until 64) tick()
        n += 64
      }
    }
  }
}
