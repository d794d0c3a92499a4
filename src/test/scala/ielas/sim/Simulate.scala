package ielas.sim

import ielas._

import java.nio.file.{Files, Path, Paths}
import scala.util.Random

/** `make simulate CONFIG=<name|json> STAGE=<stage> LEFT=L RIGHT=R OUT=DIR`: streams the pair through the Verilator
  * model of the hardware up to STAGE and writes that stage's dump files, DIR/cycles.txt, and the cycle count.
  * Every value it writes comes out of the simulated hardware: it never calls the golden model.
  */
object Simulate {
  val stages: Seq[String] = Stage.all.map(_.name)

  def main(args: Array[String]): Unit = Cli.exitOnError("simulate") {
    val opts = Cli.parse(args, Set("--config", "--stage", "--left", "--right", "--out"),
      "usage: Simulate --config NAME|FILE.json --stage STAGE --left L --right R --out DIR")
    val p = ConfigJson.load(opts("--config"))
    val stage = Stage.byName(opts("--stage"))
    val (left, right) = Cli.readPair(p, Paths.get(opts("--left")), Paths.get(opts("--right")))
    val out = Paths.get(opts("--out"))
    Files.createDirectories(out)
    val result = StageRun.run(p, stage, left, right)
    val files = result.write(out)
    Files.write(out.resolve("cycles.txt"), s"${result.cycles}\n".getBytes)
    println(s"cycles: ${result.cycles}")
    println(s"wrote ${(files :+ out.resolve("cycles.txt")).mkString(", ")}")
    if (result.framingErrors.nonEmpty)
      throw new IllegalStateException(s"framing wrong: ${result.framingErrors.mkString("; ")}")
  }
}

/** The descriptor stage's outputs of one frame, as streamed out of the hardware. */
case class DescriptorRun(width: Int, height: Int, left: Array[Byte], right: Array[Byte], cycles: Long, seconds: Double) {
  def writeDump(dir: Path): Unit = {
    NpyArray.write(dir.resolve("descriptor_L.npy"), "|u1", Seq(height, width, 16), left)
    NpyArray.write(dir.resolve("descriptor_R.npy"), "|u1", Seq(height, width, 16), right)
  }
  def simulatorCyclesPerSecond: Double = cycles / seconds
}

object DescriptorRun {
  /** Streams one frame through the DescriptorChain with no stalls; the Verilator build is cached per configuration. */
  def run(p: ElasParams, left: GrayImage, right: GrayImage): DescriptorRun = {
    val (w, h) = (left.width, left.height)
    val l = new Array[Byte](w * h * 16)
    val r = new Array[Byte](w * h * 16)
    var cycles = 0L
    var seconds = 0.0
    var framing: Option[String] = None
    val workDir = Paths.get("build", "sim-cache", s"${p.name}-descriptor").toAbsolutePath
    StreamTester.simulate(new DescriptorChain(p), workDir, cache = true) { dut =>
      StreamTester.reset(dut)
      val t0 = System.nanoTime()
      cycles = StreamTester.streamDescriptorFrames(dut, Seq((left, right)), StreamTester.noStall, new Random(0),
        (i, beat) => {
          val (x, y) = ((i % w).toInt, (i / w).toInt)
          if (framing.isEmpty && (beat.sof != (i == 0) || beat.eol != (x == w - 1) || beat.eof != (i == w.toLong * h - 1)))
            framing = Some(s"framing wrong at output (x=$x, y=$y): sof ${beat.sof} eol ${beat.eol} eof ${beat.eof}")
          for (k <- 0 until 16) {
            l((i * 16 + k).toInt) = (beat.left >> (8 * k)).toByte
            r((i * 16 + k).toInt) = (beat.right >> (8 * k)).toByte
          }
        }, 4L * w * h + 100000, "simulate")
      seconds = (System.nanoTime() - t0) / 1e9
      if (StreamTester.peek(dut.io.error)) framing = Some("the hardware raised its error bit")
    }
    framing.foreach(f => throw new IllegalStateException(f))
    DescriptorRun(w, h, l, r, cycles, seconds)
  }
}

/** Argument parsing and input checks shared by the simulation programs: bad input = one line on stderr, exit 1. */
object Cli {
  def exitOnError(program: String)(body: => Unit): Unit = {
    val ok = try { body; true } catch {
      case e @ (_: IllegalArgumentException | _: IllegalStateException | _: java.io.IOException) =>
        System.err.println(s"$program: ${Option(e.getMessage).getOrElse(e.toString).stripPrefix("requirement failed: ")}")
        false
    }
    if (!ok) sys.exit(1)
  }

  def parse(args: Array[String], known: Set[String], usage: String, required: Boolean = true): Map[String, String] = {
    if (args.length % 2 != 0) throw new IllegalArgumentException(usage)
    val opts = args.grouped(2).map(a => a(0) -> a(1)).toMap
    opts.keys.find(!known.contains(_)).foreach(k => throw new IllegalArgumentException(s"unknown option $k; $usage"))
    if (required) known.find(!opts.contains(_)).foreach(k => throw new IllegalArgumentException(s"missing $k; $usage"))
    opts
  }

  /** Reads a pair; both must have one size within 32x16 .. the configuration's maximum. */
  def readPair(p: ElasParams, left: Path, right: Path): (GrayImage, GrayImage) = {
    val (l, r) = (TestImages.read(left), TestImages.read(right))
    if (l.width != r.width || l.height != r.height)
      throw new IllegalArgumentException(s"left ${l.width}x${l.height} and right ${r.width}x${r.height} differ in size")
    if (l.width < 32 || l.height < 16 || l.width > p.maxWidth || l.height > p.maxHeight)
      throw new IllegalArgumentException(s"frame ${l.width}x${l.height} is outside 32x16..${p.maxWidth}x${p.maxHeight} of configuration ${p.name}")
    (l, r)
  }
}
