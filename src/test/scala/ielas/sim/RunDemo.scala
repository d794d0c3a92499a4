package ielas.sim

import ielas._

import java.awt.image.BufferedImage
import java.nio.file.{Files, Paths}
import javax.imageio.ImageIO

/** `make run`: a stereo pair (default KITTI 2012 000070) through the hardware built so far, in Verilator, checked
  * against the golden model's dump, with a report and a du/dv picture in build/run/.
  */
object RunDemo {
  def main(args: Array[String]): Unit = Cli.exitOnError("run") {
    val opts = Cli.parse(args, Set("--config", "--left", "--right", "--gt"),
      "usage: RunDemo [--config NAME|FILE.json] [--left L --right R] [--gt GT]", required = false)
    val p = ConfigJson.load(opts.getOrElse("--config", "kitti"))
    val data = TestImages.dataDir
    val kittiLeft = data.resolve("kitti2012/training/image_0/000070_10.png")
    val kittiRight = data.resolve("kitti2012/training/image_1/000070_10.png")
    // without ../shared/data: the project's own synthetic scene
    lazy val synth = GoldenModel.synthScene(Paths.get("build", "run", "synth").toAbsolutePath)
    val useSynth = !opts.contains("--left") && !Files.isReadable(kittiLeft)
    val leftPath = opts.get("--left").map(Paths.get(_)).getOrElse(if (useSynth) synth._1 else kittiLeft)
    val rightPath = opts.get("--right").map(Paths.get(_)).getOrElse(if (useSynth) synth._2 else kittiRight)
    val (left, right) = Cli.readPair(p, leftPath, rightPath)
    val (w, h) = (left.width, left.height)
    val outDir = Paths.get("build", "run").toAbsolutePath
    println(s"run: ${p.name}, ${w}x$h pair $leftPath | $rightPath")

    val hw = DescriptorRun.run(p, left, right)
    hw.writeDump(outDir.resolve("hardware"))

    val goldenDir = GoldenModel.dump(p.name, left, right, outDir.resolve("golden"))
    val board = new Scoreboard("descriptor")
    val expected = DescriptorScoreboard.readDump(goldenDir, w, h)
    for ((got, view) <- Seq(hw.left, hw.right).zip(expected).zip(Seq("L", "R")); i <- got._1.indices) {
      val pixel = i / 16
      board.check(s"(x=${pixel % w}, y=${pixel / w}) view $view byte ${i % 16}", got._2(i.toLong), got._1(i) & 0xff)
    }
    val picture = outDir.resolve("descriptor_du_dv.png")
    writeGradients(hw, picture)

    val pixels = w.toLong * h
    val cpp = hw.cycles.toDouble / pixels
    println(board.report)
    println(s"mismatches: ${board.mismatches}")
    println(f"cycles/pixel: $cpp%.3f")
    println(f"fps@200MHz: ${200e6 / hw.cycles}%.1f")
    println(s"latency rows: ${Descriptor.latencyRows(p)}")
    println(s"cycles: ${hw.cycles} for $pixels pixels")
    println(f"verilator: ${hw.simulatorCyclesPerSecond}%.0f cycles/s (${hw.seconds}%.1f s streaming, testbench included)")
    println(s"wrote $picture (left: du centre = byte 5, right: dv above = byte 12), dumps in $outDir/{hardware,golden}")
    if (opts.contains("--gt")) println("bad-3: needs the whole accelerator (only the descriptor stage exists so far)")
    if (board.mismatches != 0) throw new IllegalStateException(s"${board.mismatches} mismatches against the golden model")
  }

  /** Left half: du at the centre (byte 5) of the left view; right half: dv (byte 12). */
  def writeGradients(hw: DescriptorRun, path: java.nio.file.Path): Unit = {
    val (w, h) = (hw.width, hw.height)
    val img = new BufferedImage(2 * w, h, BufferedImage.TYPE_BYTE_GRAY)
    val raster = img.getRaster
    for (y <- 0 until h; x <- 0 until w) {
      val base = (y * w + x) * 16
      raster.setSample(x, y, 0, hw.left(base + 5) & 0xff)
      raster.setSample(w + x, y, 0, hw.left(base + 12) & 0xff)
    }
    Files.createDirectories(path.getParent)
    ImageIO.write(img, "png", path.toFile)
  }
}
