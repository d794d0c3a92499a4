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
