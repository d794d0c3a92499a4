package ielas.sim

import chisel3.UInt
import ielas._

import java.nio.file.{Path, Paths}
import scala.util.Random

/** The dump arrays of one stage as the hardware put them out (name -> (dtype, shape, values)), in the golden
  * model's file names (docs/interfaces.md §3), plus the cycle count and the framing errors seen.
  */
case class StageOutput(arrays: Seq[(String, String, Seq[Int], Array[Long])], cycles: Long, framingErrors: Seq[String]) {
  def write(dir: Path): Seq[Path] = arrays.map { case (name, dtype, shape, values) =>
    val item = NpyArray.itemBytes(dtype)
    val raw = new Array[Byte](values.length * item)
    for (i <- values.indices; b <- 0 until item) raw(i * item + b) = (values(i) >> (8 * b)).toByte
    val path = dir.resolve(s"$name.npy")
    NpyArray.write(path, dtype, shape, raw)
    path
  }
}

/** Streams frames through a [[StageTap]] (pixel input -> ... -> one stage) and unpacks the stage's beats into its
  * dump arrays. Every value comes out of the simulated hardware.
  */
object StageRun {
  /** Splits `v` into fields of the given widths, most significant first, as two's complement when `signed`. */
  def fields(v: BigInt, widths: Seq[(Int, Boolean)]): Seq[Long] = {
    var shift = widths.map(_._1).sum
    widths.map { case (w, signed) =>
      shift -= w
      val x = (v >> shift) & ((BigInt(1) << w) - 1)
      (if (signed && x.testBit(w - 1)) x - (BigInt(1) << w) else x).toLong
    }
  }

  /** How many beats the stage puts out for a w x h frame, and how to turn them into dump arrays. */
  case class Layout(beats: Int, rowLength: Int, unpack: Seq[BigInt] => Seq[(String, String, Seq[Int], Array[Long])])

  def layout(p: ElasParams, stage: Stage, w: Int, h: Int): Layout = {
    val vb = p.signedDispBits
    val (lh, lw) = (p.latticeCount(h), p.latticeCount(w))
    val (gh, gw) = (p.gridCount(h), p.gridCount(w))
    def lattice(name: String) = Layout(lh * lw, lw, beats => Seq((name, "<i2", Seq(lh, lw), beats.map(b => fields(b, Seq((vb, true))).head).toArray)))
    def pair(l: String, r: String) = Layout(w * h, w, beats => {
      val f = beats.map(fields(_, Seq((vb, true), (vb, true))))
      Seq((l, "<i2", Seq(h, w), f.map(_(0)).toArray), (r, "<i2", Seq(h, w), f.map(_(1)).toArray))
    })
    stage match {
      case Stage.Descriptor => Layout(w * h, w, beats => {
        val bytes = p.descriptorBytes
        def view(shift: Int) = beats.flatMap(b => (0 until bytes).map(k => ((b >> (shift + 8 * k)) & 0xff).toLong)).toArray
        Seq(("descriptor_L", "|u1", Seq(h, w, bytes), view(8 * bytes)), ("descriptor_R", "|u1", Seq(h, w, bytes), view(0)))
      })
      case Stage.Support => lattice("support_L")
      case Stage.Filter => lattice("support_filtered_L")
      case Stage.Interp => lattice("lattice_L")
      case Stage.Grid => Layout(gh * gw, gw, beats => {
        val s = p.storedDisparities
        val f = beats.map(b => fields(b, Seq.fill(2 * s)((vb, true)))) // left slots s-1..0, then right slots s-1..0
        Seq(("grid_L", "<i2", Seq(gh, gw, s), f.flatMap(x => x.take(s).reverse).toArray),
          ("grid_R", "<i2", Seq(gh, gw, s), f.flatMap(x => x.drop(s).reverse).toArray))
      })
      case Stage.Planes => Layout((lh - 1) * (lw - 1), lw - 1, beats => {
        val coeffs = Seq((32, true), (32, true), (32, true), (p.colBits + 1, true), (p.rowBits, false), (1, false))
        // MSB first: left triangles 1, 0; right triangles 1, 0; corners BR, BL, TR, TL (so slot 1 - t holds triangle t)
        val f = beats.map(b => fields(b, Seq.fill(4)(coeffs).flatten ++ Seq.fill(4)((p.dispBits, false))))
        def view(first: Int) = f.flatMap(x => Seq(1, 0).map(t => x.slice((first + t) * 6, (first + t + 1) * 6)).flatten).toArray
        Seq(("planes_L", "<i4", Seq(lh - 1, lw - 1, 2, 6), view(0)), ("planes_R", "<i4", Seq(lh - 1, lw - 1, 2, 6), view(2)))
      })
      case Stage.Dense => pair("dense_L", "dense_R")
      case Stage.LrCheck => pair("lrcheck_L", "lrcheck_R")
      case Stage.Post => Layout(w * h, w, beats => Seq(("disparity", "<i2", Seq(h, w), beats.map(b => fields(b, Seq((16, true))).head).toArray)))
    }
  }

  /** Streams `frames` (one size) back to back through `dut` with the given traffic; returns each frame's output. */
  def stream(dut: StageTap, p: ElasParams, frames: Seq[(GrayImage, GrayImage)], traffic: StreamTester.Traffic,
      rnd: Random, maxCycles: Long, what: String): Seq[StageOutput] = {
    val (w, h) = (frames.head._1.width, frames.head._1.height)
    val lay = layout(p, dut.stage, w, h)
    StreamTester.poke(dut.io.frameWidth, w)
    StreamTester.poke(dut.io.frameHeight, h)
    StreamTester.poke(dut.io.clearError, false)
    val beats = frames.iterator.flatMap { case (l, r) =>
      Iterator.range(0, w * h).map(i => (l.pixels(i) & 0xff, r.pixels(i) & 0xff, i == 0, i % w == w - 1))
    }
    val got = Array.fill(frames.length)(new Array[BigInt](lay.beats))
    val framing = Array.fill(frames.length)(scala.collection.mutable.ArrayBuffer.empty[String])
    val cycles = StreamTester.run[PixelPair, Framed[UInt], (Int, Int, Boolean, Boolean), (BigInt, Boolean, Boolean, Boolean)](
      dut.clock, dut.io.in, beats,
      (bits, b) => { StreamTester.poke(bits.left, b._1); StreamTester.poke(bits.right, b._2); StreamTester.poke(bits.sof, b._3); StreamTester.poke(bits.eol, b._4) },
      dut.io.out, frames.length.toLong * lay.beats,
      o => (StreamTester.peek(o.data), StreamTester.peek(o.sof), StreamTester.peek(o.eol), StreamTester.peek(o.eof)),
      (i, o) => {
        val (f, k) = ((i / lay.beats).toInt, (i % lay.beats).toInt)
        got(f)(k) = o._1
        val want = (k == 0, k % lay.rowLength == lay.rowLength - 1, k == lay.beats - 1)
        if ((o._2, o._3, o._4) != want && framing(f).length < 5)
          framing(f) += s"${dut.stage.name} frame $f beat $k (row ${k / lay.rowLength}, col ${k % lay.rowLength}): sof/eol/eof ${(o._2, o._3, o._4)}, expected $want"
      }, traffic, rnd, maxCycles, what)
    frames.indices.map(f => StageOutput(lay.unpack(got(f).toSeq), cycles, framing(f).toSeq))
  }

  /** `make simulate`: one frame with no stalls, the Verilator build cached per configuration and stage. */
  def run(p: ElasParams, stage: Stage, left: GrayImage, right: GrayImage): StageOutput = {
    val workDir = Paths.get("build", "sim-cache", s"${p.name}-tap-${stage.name}").toAbsolutePath
    var out: StageOutput = null
    StreamTester.simulate(new StageTap(p, stage), workDir, cache = true) { dut =>
      StreamTester.reset(dut)
      val t0 = System.nanoTime()
      out = stream(dut, p, Seq((left, right)), StreamTester.noStall, new Random(0), 40L * left.width * left.height + 200000, "simulate").head
      val seconds = (System.nanoTime() - t0) / 1e9
      println(f"simulation: $seconds%.1f s wall (build excluded), ${out.cycles / seconds}%.0f cycles/s")
      if (StreamTester.peek(dut.io.error)) throw new IllegalStateException("the hardware raised its error bit")
    }
    out
  }
}
