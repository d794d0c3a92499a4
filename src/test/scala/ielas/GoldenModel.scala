package ielas

import java.nio.file.{Files, Path, Paths}
import scala.sys.process._

/** Runs the C++ golden model (`ielas-golden dump`), building it with CMake when it is missing.
  * Binary: -Dielas.golden=PATH, else $IELAS_GOLDEN, else golden/build/ielas-golden.
  */
object GoldenModel {
  def binary: Path = Paths.get(sys.props.get("ielas.golden").orElse(sys.env.get("IELAS_GOLDEN")).getOrElse("golden/build/ielas-golden"))

  private lazy val ready: Path = {
    val bin = binary
    if (!Files.isExecutable(bin)) {
      println(s"golden: $bin missing, building it with CMake")
      val build = Seq("bash", "-c",
        "cmake -S golden -B golden/build -DCMAKE_BUILD_TYPE=Release && cmake --build golden/build -j2")
      if (build.! != 0 || !Files.isExecutable(bin)) throw new IllegalStateException(s"golden: could not build $bin")
    }
    bin
  }

  /** The golden model's executable, built when missing. */
  def executable: Path = ready

  /** The project's own synthetic scene (ielas-synth, next to ielas-golden): left.pgm and right.pgm in `dir`. */
  def synthScene(dir: Path): (Path, Path) = {
    val synth = ready.resolveSibling("ielas-synth")
    val rc = Seq(synth.toString, "--out", dir.toString).!(ProcessLogger(_ => (), System.err.println(_)))
    if (rc != 0) throw new IllegalStateException(s"golden: $synth failed ($rc)")
    (dir.resolve("left.pgm"), dir.resolve("right.pgm"))
  }

  /** Dumps every stage for the pair under `dir` (PGMs written there too) and returns `dir`. */
  def dump(config: String, left: GrayImage, right: GrayImage, dir: Path): Path = {
    Files.createDirectories(dir)
    val l = left.writePgm(dir.resolve("left.pgm"))
    val r = right.writePgm(dir.resolve("right.pgm"))
    dumpFiles(config, l, r, dir)
  }

  def dumpFiles(config: String, left: Path, right: Path, dir: Path): Path = {
    val cmd = Seq(ready.toString, "dump", "--mode", "ielas", "--config", config,
      "--left", left.toString, "--right", right.toString, "--out", dir.toString)
    val err = new StringBuilder
    val rc = cmd.!(ProcessLogger(_ => (), e => err.append(e).append('\n')))
    if (rc != 0) throw new IllegalStateException(s"golden: '${cmd.mkString(" ")}' failed ($rc): ${err.toString.trim}")
    dir
  }
}

/** Counts mismatches of one stage's outputs against the golden dump and keeps the first one for the report. */
class Scoreboard(val stage: String) {
  var compared = 0L
  var mismatches = 0L
  private var first: Option[String] = None

  def check(where: => String, expected: Long, got: Long): Unit = {
    compared += 1
    if (expected != got) {
      mismatches += 1
      if (first.isEmpty) first = Some(s"$where: expected $expected, got $got")
    }
  }

  def ok: Boolean = mismatches == 0
  def report: String =
    if (ok) s"$stage: $compared values equal"
    else s"$stage: $mismatches of $compared values differ; first mismatch at ${first.get}"
}

/** Scoreboard of the descriptor stream: every byte of both views and the framing. `expected(view, x, y, k)` gives
  * byte k of the expected descriptor (view 0 = left); [[DescriptorScoreboard.fromDump]] reads it from the golden dump.
  */
class DescriptorScoreboard(val width: Int, val height: Int, expected: (Int, Int, Int, Int) => Int, label: String = "") {
  val board = new Scoreboard(s"descriptor$label")

  /** Checks output `index` (raster order; frames of this size follow each other). */
  def check(index: Long, beat: StreamTester.DescriptorBeat): Unit = {
    val pixel = index % (width.toLong * height)
    val (x, y) = ((pixel % width).toInt, (pixel / width).toInt)
    val frame = index / (width.toLong * height)
    def at = s"frame $frame (x=$x, y=$y)"
    for ((got, view) <- Seq(beat.left, beat.right).zipWithIndex; k <- 0 until 16)
      board.check(s"$at view ${if (view == 0) "L" else "R"} byte $k", expected(view, x, y, k), ((got >> (8 * k)) & 0xff).toLong)
    board.check(s"$at sof", if (x == 0 && y == 0) 1 else 0, if (beat.sof) 1 else 0)
    board.check(s"$at eol", if (x == width - 1) 1 else 0, if (beat.eol) 1 else 0)
    board.check(s"$at eof", if (x == width - 1 && y == height - 1) 1 else 0, if (beat.eof) 1 else 0)
  }
}

object DescriptorScoreboard {
  def readDump(dumpDir: java.nio.file.Path, width: Int, height: Int): Seq[NpyArray] = Seq("L", "R").map { v =>
    val a = NpyArray.read(dumpDir.resolve(s"descriptor_$v.npy"))
    require(a.dtype == "|u1" && a.shape == Seq(height, width, 16), s"golden: descriptor_$v.npy has ${a.dtype} ${a.shape}")
    a
  }

  def fromDump(dumpDir: java.nio.file.Path, width: Int, height: Int, label: String = ""): DescriptorScoreboard = {
    val arrays = readDump(dumpDir, width, height)
    new DescriptorScoreboard(width, height, (v, x, y, k) => arrays(v)((y.toLong * width + x) * 16 + k), label)
  }
}
