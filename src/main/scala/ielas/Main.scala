package ielas

import java.nio.file.Paths

/** Command-line front door used by the Makefile:
  *   configs [DIR]                 write every named configuration to DIR (default golden/configs)
  *   verilog CONFIG [DIR]          emit the accelerator top as SystemVerilog into DIR (default build/verilog/CONFIG)
  *   config DIR SPEC...            write one configuration per SPEC = NAME:BASE[:KEY=VALUE,...] to DIR/NAME.json
  *                                 (BASE a name or JSON; KEY a constructor field of ElasParams; SAD lanes re-derived
  *                                 unless given) and its cycle-model figures to DIR/NAME.model.json (the sweep's)
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
          case "config" :: dir :: specs if specs.nonEmpty =>
            val out = Paths.get(dir)
            java.nio.file.Files.createDirectories(out)
            // An illegal point is written as NAME.error (the require message) and the others go on: the sweep
            // records it as that point's result. Exit 1 when any failed.
            val failed = specs.filterNot { spec =>
              try { writeConfig(spec, out); true }
              catch {
                case e: IllegalArgumentException =>
                  val msg = e.getMessage.stripPrefix("requirement failed: ")
                  System.err.println(s"error: $spec: $msg")
                  java.nio.file.Files.write(out.resolve(spec.takeWhile(_ != ':') + ".error"), (msg + "\n").getBytes("UTF-8"))
                  false
              }
            }
            if (failed.isEmpty) 0 else 1
          case _ =>
            System.err.println("usage: Main configs [DIR] | verilog CONFIG [DIR] | config DIR NAME:BASE[:KEY=VALUE,...]...")
            2
        }
      } catch {
        case e: IllegalArgumentException =>
          System.err.println(s"error: ${e.getMessage.stripPrefix("requirement failed: ")}")
          1
      }
    if (result != 0) sys.exit(result)
  }

  /** DIR/NAME.json and DIR/NAME.model.json (the top's cycle-model figures and memory bits) for one spec. */
  private def writeConfig(spec: String, out: java.nio.file.Path): Unit = {
    val p = ConfigJson.fromSpec(spec)
    println(s"wrote ${ConfigJson.write(p, out)}")
    val model = Seq("name" -> s"\"${p.name}\"", "latencyRows" -> IElas.latencyRows(p).toString,
      "cycleSlack" -> IElas.cycleSlack(p).toString, "memoryBits" -> IElas.memorySummary(p).map(_.bits).sum.toString)
    java.nio.file.Files.write(out.resolve(s"${p.name}.model.json"),
      model.map { case (k, v) => s"""  "$k": $v""" }.mkString("{\n", ",\n", "\n}\n").getBytes("UTF-8"))
  }
}
