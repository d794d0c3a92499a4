package ielas

import java.nio.file.Paths

/** Command-line front door used by the Makefile and by `sbt run`:
  *   (no arguments)                emit the default configuration (kitti) as SystemVerilog into build/verilog/kitti,
  *                                 with the IElasAxi wrapper (as `make verilog`)
  *   --width W --height H ...      emit a custom configuration from the card parameters (`--help` lists them;
  *                                 `--axi` adds the IElasAxi wrapper)
  *   configs [DIR]                 write every named configuration to DIR (default golden/configs) and the
  *                                 golden model's --preset files to DIR/presets
  *   verilog CONFIG [DIR]          emit the accelerator top and the IElasAxi wrapper (with its register map and
  *                                 FuseSoC core) as SystemVerilog into DIR (default build/verilog/CONFIG)
  *   config DIR SPEC...            write one configuration per SPEC = NAME:BASE[:KEY=VALUE,...] to DIR/NAME.json
  *                                 (BASE a name or JSON; KEY a constructor field of ElasParams; SAD lanes re-derived
  *                                 unless given) and its cycle-model figures to DIR/NAME.model.json (the sweep's)
  */
object Main {
  def main(args: Array[String]): Unit = {
    val result = run(args)
    if (result != 0) sys.exit(result)
  }

  /** The command line's work; returns the exit code (errors are one line on stderr). */
  def run(args: Array[String]): Int =
      try {
        args.toList match {
          case Nil => // what `make verilog` writes for the default configuration
            emit(ElasParams.byName("kitti"), None, axi = true)
            0
          case ("--help" | "-h") :: _ =>
            println(usage)
            0
          case flags @ (first :: _) if first.startsWith("--") =>
            val (p, dir) = fromFlags(flags.filterNot(_ == "--axi"))
            emit(p, dir, axi = flags.contains("--axi"))
            0
          case "configs" :: rest =>
            val dir = Paths.get(rest.headOption.getOrElse("golden/configs"))
            ElasParams.named.foreach(p => println(s"wrote ${ConfigJson.write(p, dir)}"))
            ConfigJson.writePresets(dir).foreach(f => println(s"wrote $f"))
            0
          case "verilog" :: config :: rest =>
            val p = ConfigJson.load(config)
            val dir = Paths.get(rest.headOption.getOrElse(s"build/verilog/${p.name}"))
            VerilogEmitter.emitTop(p, dir, axi = true)
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
            System.err.println("usage: Main [--help | flags] | configs [DIR] | verilog CONFIG [DIR] | config DIR NAME:BASE[:KEY=VALUE,...]...")
            2
        }
      } catch { // every failure is one line and a non-zero exit, no stack trace
        case e: IllegalArgumentException =>
          System.err.println(s"error: ${e.getMessage.stripPrefix("requirement failed: ")}")
          1
        case e: java.nio.file.NoSuchFileException =>
          System.err.println(s"error: no such file: ${e.getFile}")
          1
        case e: java.nio.file.AccessDeniedException =>
          System.err.println(s"error: cannot write or read ${e.getFile} (permission denied)")
          1
        case e: java.io.IOException =>
          System.err.println(s"error: ${e.getClass.getSimpleName}: ${e.getMessage}")
          1
      }

  /** The card's parameters as flags: (flag, ElasParams field, legal range as the generator checks it). */
  private val cardFlags = Seq(
    ("--width", "maxWidth", "32..8192"),
    ("--height", "maxHeight", "16..8192"),
    ("--disp-max", "dispMax", "15..1023, below the width"),
    ("--window", "windowSize", "3, 5, 7"),
    ("--stored", "storedDisparities", "1..dispMax+1"),
    ("--cycles-per-pixel", "cyclesPerPixel", "1, 2, 4, 8"))

  val usage: String =
    (Seq("usage: sbt \"run [--name NAME] [--base CONFIG] [--out DIR] FLAG VALUE ...\"   (no arguments: the kitti configuration, with IElasAxi)",
      "  emits SystemVerilog of the IElas top and NAME.json (the configuration the golden model reads) into DIR",
      "  (default build/verilog/NAME); unset flags keep the base configuration's values (default base: kitti)") ++
      cardFlags.map { case (f, field, legal) => f"  $f%-20s $field%-18s legal: $legal" } ++
      Seq("  --axi                also emit the IElasAxi wrapper (AXI4-Stream video + AXI4-Lite registers), its",
        "                       register map (IElasAxi_regs.h, IElasAxi_regs.md) and a FuseSoC core (ielas_axi.core)")).mkString("\n")

  /** Flags to a configuration: every value an integer that fits, every range checked by ElasParams. */
  private def fromFlags(flags: List[String]): (ElasParams, Option[String]) = {
    require(flags.length % 2 == 0, s"flag ${flags.last} needs a value (see --help)")
    val pairs = flags.grouped(2).map { case Seq(k, v) => k -> v }.toSeq
    val known = cardFlags.map(_._1).toSet ++ Set("--name", "--base", "--out")
    pairs.foreach { case (k, _) => require(known(k), s"unknown flag $k (legal: ${known.toSeq.sorted.mkString(", ")})") }
    val m = pairs.toMap
    val name = m.getOrElse("--name", "custom")
    val overrides = cardFlags.flatMap { case (f, field, legal) =>
      m.get(f).map { v =>
        require(v.toIntOption.isDefined, s"$f $v is not an integer (legal: $legal)")
        s"$field=$v"
      }
    }
    val p = ConfigJson.fromSpec(s"$name:${m.getOrElse("--base", "kitti")}:${overrides.mkString(",")}")
    (p, m.get("--out"))
  }

  /** Verilog of the top plus the configuration JSON beside it. */
  private def emit(p: ElasParams, dir: Option[String], axi: Boolean = false): Unit = {
    val out = Paths.get(dir.getOrElse(s"build/verilog/${p.name}"))
    VerilogEmitter.emitTop(p, out, axi)
    println(s"wrote ${ConfigJson.write(p, out)}")
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
