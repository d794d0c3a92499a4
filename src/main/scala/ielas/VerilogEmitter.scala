package ielas

import java.nio.file.Path

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
    * (empty) string it returns.
    */
  def emit(gen: => chisel3.RawModule, dir: Path): Unit = {
    java.nio.file.Files.createDirectories(dir)
    _root_.circt.stage.ChiselStage.emitSystemVerilog(gen, Array.empty[String], firtoolOptions ++ Array("-o", dir.toString))
  }

  def emitTop(p: ElasParams, dir: Path): Unit = {
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
  }
}
