package ielas

import org.scalatest.flatspec.AnyFlatSpec
import org.scalatest.matchers.should.Matchers

import java.io.{ByteArrayOutputStream, PrintStream}
import java.nio.file.Files

/** The generator's command line (`sbt run`): the flag form writes Verilog and the configuration JSON, and every
  * error is one line on stderr with a non-zero exit code.
  */
class MainSpec extends AnyFlatSpec with Matchers {
  private def capture(args: String*): (Int, String, String) = {
    val (out, err) = (new ByteArrayOutputStream, new ByteArrayOutputStream)
    val code = Console.withOut(new PrintStream(out)) {
      val saved = System.err
      System.setErr(new PrintStream(err))
      try Main.run(args.toArray) finally System.setErr(saved)
    }
    (code, out.toString, err.toString)
  }

  "Main" should "turn every bad argument into one line and exit code 1 or 2" in {
    val cases = Seq(
      Seq("--disp-max", "1e10") -> "--disp-max 1e10 is not an integer (legal: 15..1023, below the width)",
      Seq("--disp-max", "2000") -> "dispMax = 2000 is out of range (legal: 15..1023)",
      Seq("--window", "4") -> "windowSize = 4 is not supported (legal: 3, 5, 7)",
      Seq("--cycles-per-pixel", "3") -> "cyclesPerPixel = 3 is not supported (legal: 1, 2, 4, 8)",
      Seq("--colour", "1") -> "unknown flag --colour",
      Seq("--width") -> "flag --width needs a value",
      Seq("verilog", "no-such-config.json") -> "no such file: no-such-config.json",
      Seq("verilog", "no-such-config") -> "configuration: unknown 'no-such-config'")
    for ((args, expected) <- cases) {
      val (code, _, err) = capture(args: _*)
      withClue(s"${args.mkString(" ")}: ") {
        code should not be 0
        err.linesIterator.count(_.nonEmpty) shouldBe 1
        err should include(expected)
      }
    }
  }

  it should "list the card's flags with their legal ranges" in {
    val (code, out, _) = capture("--help")
    code shouldBe 0
    for (f <- Seq("--width", "--height", "--disp-max", "--window", "--stored", "--cycles-per-pixel")) out should include(f)
    out should include("legal: 1, 2, 4, 8")
  }

  it should "emit a custom configuration's Verilog and the JSON the golden model reads" in {
    val dir = Files.createTempDirectory("ielas-main")
    val (code, _, err) = capture("--base", "small", "--name", "cli-small", "--width", "96", "--disp-max", "23",
      "--stored", "12", "--out", dir.toString)
    withClue(err) { code shouldBe 0 }
    Files.exists(dir.resolve("IElas.sv")) shouldBe true
    val p = ConfigJson.load(dir.resolve("cli-small.json").toString)
    (p.maxWidth, p.maxHeight, p.dispMax, p.storedDisparities) shouldBe ((96, 64, 23, 12))
    Files.exists(dir.resolve("IElasAxi.sv")) shouldBe false // only with --axi
  }

  it should "emit the IElasAxi wrapper, its register map and FuseSoC core with --axi" in {
    val dir = Files.createTempDirectory("ielas-main-axi")
    val (code, _, err) = capture("--base", "small", "--name", "cli-axi", "--axi", "--width", "64", "--out", dir.toString)
    withClue(err) { code shouldBe 0 }
    for (f <- Seq("IElas.sv", "IElasAxi.sv", "IElasAxi_regs.h", "IElasAxi_regs.md", "ielas_axi.core", "cli-axi.json"))
      withClue(f) { Files.exists(dir.resolve(f)) shouldBe true }
    val header = new String(Files.readAllBytes(dir.resolve("IElasAxi_regs.h")), "UTF-8")
    header should include("#define IELAS_AXI_MAX_WIDTH_VALUE 64u")
    new String(Files.readAllBytes(dir.resolve("ielas_axi.core")), "UTF-8") should include("name: ielas:ip:ielas_axi_cli_axi:1.0.0")
  }
}
