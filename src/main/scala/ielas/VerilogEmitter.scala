package ielas

import java.nio.file.Path

/** Emits SystemVerilog with firtool options that Verilator lint and Yosys 0.23 both accept (TOOLCHAIN.md). */
object VerilogEmitter {
  val firtoolOptions: Array[String] = Array(
    "-disable-all-randomization",
    "-strip-debug-info",
    "--lowering-options=disallowLocalVariables,disallowPackedArrays,locationInfoStyle=none",
    "--split-verilog"
  )

  def emit(gen: => chisel3.RawModule, dir: Path): Unit = {
    java.nio.file.Files.createDirectories(dir)
    _root_.circt.stage.ChiselStage.emitSystemVerilog(gen, Array("--target-dir", dir.toString), firtoolOptions ++ Array("-o", dir.toString))
  }

  def emitTop(p: ElasParams, dir: Path): Unit = {
    throw new IllegalArgumentException("verilog: the accelerator top is not built yet")
  }
}
