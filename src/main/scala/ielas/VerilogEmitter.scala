package ielas

import java.nio.file.{Files, Path}

/** Emits SystemVerilog with firtool options that Verilator lint and Yosys 0.23 both accept (docs/toolchain.md). */
object VerilogEmitter {
  val firtoolOptions: Array[String] = Array(
    "-disable-all-randomization",
    "-strip-debug-info",
    "--lowering-options=disallowLocalVariables,disallowPackedArrays,locationInfoStyle=none",
    "--split-verilog"
  )

  /** One module per file in `dir`. Only firtool writes files (--split-verilog -o dir): Chisel 6.7's
    * emitSystemVerilog rejects --target-dir, and emitSystemVerilogFile would overwrite the top's file with the
    * (empty) string it returns. The memories [[CollisionFree]] checks are then marked `(* no_rw_check *)`.
    */
  def emit(gen: => chisel3.RawModule, dir: Path): Unit = {
    java.nio.file.Files.createDirectories(dir)
    val marks = CollisionFree.recorded {
      _root_.circt.stage.ChiselStage.emitSystemVerilog(gen, Array.empty[String], firtoolOptions ++ Array("-o", dir.toString))
    }
    CollisionFree.markVerilog(dir, marks)
  }

  /** The IElas top (and with `axi` the [[IElasAxi]] wrapper beside it) into `dir`. The .sv files already in `dir`
    * are removed first: a module an earlier version emitted (or named differently) would otherwise stay beside the
    * new ones and reach lint, synthesis and the wrapper's comparison below.
    */
  def emitTop(p: ElasParams, dir: Path, axi: Boolean = false): Unit = {
    import scala.jdk.CollectionConverters._
    if (Files.isDirectory(dir))
      Files.list(dir).iterator().asScala.filter(_.toString.endsWith(".sv")).toSeq.foreach(Files.delete)
    emit(new IElas(p), dir)
    // Verilator -Wall waivers for firtool's output, one reason each (docs/interfaces.md §5, docs/toolchain.md).
    val waivers = Seq(
      "// firtool keeps the full width of sums whose low bits the Sobel's arithmetic >> 2 drops, and of column",
      "// counters one bit wider than the line-buffer address (they also hold the width itself): unused by design.",
      "lint_off -rule UNUSEDSIGNAL",
      "// firtool leaves output pins of a submodule that nothing reads unconnected in the instance (e.g. the read data",
      "// of a memory's read-write port that is only written, a framing bit a stage ignores): unused by design.",
      "lint_off -rule PINCONNECTEMPTY"
    )
    java.nio.file.Files.write(dir.resolve("lint.vlt"), ("`verilator_config\n" + waivers.mkString("\n") + "\n").getBytes)
    val memories = IElas.memorySummary(p)
    println(s"memory summary for ${p.name} (maxWidth ${p.maxWidth}, maxHeight ${p.maxHeight}):")
    memories.foreach(m => println("  " + m))
    println(f"  total ${memories.map(_.bits).sum}%d bits (${memories.map(_.bits).sum / 36864.0}%.1f BRAM36 by capacity)")
    println(s"wrote SystemVerilog to $dir")
    if (axi) emitAxi(p, dir)
  }

  /** IElasAxi.sv (and any module only the wrapper uses) beside the IElas files already in `dir`, the register map
    * (IElasAxi_regs.h, IElasAxi_regs.md) and a FuseSoC core (ielas_axi.core). The wrapper is elaborated on its own
    * into a scratch directory: every file it shares with IElas must come out identical to the one in `dir`, so
    * IElas.sv stays exactly what `emit(new IElas(p))` writes.
    */
  def emitAxi(p: ElasParams, dir: Path): Unit = {
    import scala.jdk.CollectionConverters._
    val scratch = Files.createTempDirectory("ielas-axi-")
    try {
      emit(new IElasAxi(p), scratch)
      val files = Files.list(scratch).iterator().asScala.toSeq.filter(_.toString.endsWith(".sv")).sortBy(_.toString)
      for (f <- files) {
        val target = dir.resolve(f.getFileName.toString)
        if (Files.exists(target) && f.getFileName.toString != "IElasAxi.sv") {
          if (!java.util.Arrays.equals(Files.readAllBytes(f), Files.readAllBytes(target)))
            throw new IllegalStateException(s"IElasAxi's ${f.getFileName} differs from the one IElas wrote in $dir")
        } else Files.copy(f, target, java.nio.file.StandardCopyOption.REPLACE_EXISTING)
      }
      IElasAxi.writeRegisterMap(p, dir).foreach(f => println(s"wrote $f"))
      Files.write(dir.resolve("ielas_axi.core"), IElasAxi.fusesocCore(p, files.map(_.getFileName.toString)).getBytes("UTF-8"))
      println(s"wrote IElasAxi and ${dir.resolve("ielas_axi.core")}")
    } finally {
      Files.list(scratch).iterator().asScala.foreach(Files.delete)
      Files.delete(scratch)
    }
  }
}
