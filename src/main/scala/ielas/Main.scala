package ielas

import java.nio.file.Paths

/** Command-line front door used by the Makefile:
  *   configs [DIR]                 write every named configuration to DIR (default golden/configs)
  *   verilog CONFIG [DIR]          emit the accelerator top as SystemVerilog into DIR (default build/verilog/CONFIG)
  */
object Main {
  def main(args: Array[String]): Unit = {
    val result =
      try {
        args.toList match {
          case "configs" :: rest =>
            val dir = Paths.get(rest.headOption.getOrElse("golden/configs"))
            ElasParams.named.foreach(p => println(s"wrote ${ConfigJson.write(p, dir)}"))
            0
          case "verilog" :: config :: rest =>
            val p = ConfigJson.load(config)
            val dir = Paths.get(rest.headOption.getOrElse(s"build/verilog/${p.name}"))
            VerilogEmitter.emitTop(p, dir)
            0
          case _ =>
            System.err.println("usage: Main configs [DIR] | verilog CONFIG [DIR]")
            2
        }
      } catch {
        case e: IllegalArgumentException =>
          System.err.println(s"error: ${e.getMessage.stripPrefix("requirement failed: ")}")
          1
      }
    if (result != 0) sys.exit(result)
  }
}
