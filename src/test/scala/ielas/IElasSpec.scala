package ielas

import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.{Files, Path}
import scala.jdk.CollectionConverters._
import scala.sys.process._

/** The accelerator top as `make verilog` emits it: one module per file, Verilator -Wall clean with the generated
  * waivers, memory summary as computed by hand. (Its streaming behaviour is tested in DescriptorSpec.)
  */
class IElasSpec extends AnyFlatSpec {
  behavior of "IElas top"

  def emitted(p: ElasParams): Path = {
    val dir = StreamTester.tmpDir(s"verilog-${p.name}")
    if (Files.exists(dir)) Files.list(dir).iterator().asScala.foreach(Files.delete)
    VerilogEmitter.emitTop(p, dir)
    dir
  }

  for (name <- Seq("small", "small-w7", "kitti")) {
    it should s"emit one module per file and lint clean at config $name" in {
      val dir = emitted(ElasParams.byName(name))
      val sv = Files.list(dir).iterator().asScala.filter(_.toString.endsWith(".sv")).toSeq
      for (f <- sv) {
        val modules = Files.readAllLines(f).asScala.count(_.startsWith("module "))
        assert(modules == 1, s"$f holds $modules modules")
      }
      assert(sv.exists(_.getFileName.toString == "IElas.sv"), s"no IElas.sv in $dir")
      val cmd = Seq("verilator", "--lint-only", "-Wall", dir.resolve("lint.vlt").toString) ++ sv.map(_.toString) ++
        Seq("--top-module", "IElas")
      val log = new StringBuilder
      val rc = cmd.!(ProcessLogger(l => log.append(l).append('\n'), l => log.append(l).append('\n')))
      assert(rc == 0, s"lint failed:\n$log")
    }
  }

  it should "report the descriptor line buffer as 2m pixel rows of both views by maxWidth" in {
    // kitti: windowSize 5 -> r = 2, m = 3: 6 rows x 16 bits (left + right) = 96 bits per column, 1242 columns
    assert(Descriptor.memorySummary(ElasParams.byName("kitti")).map(m => (m.rows, m.bitsPerRow)) == Seq((1242, 96)))
    // small-w7: r = 3, m = 4: 8 rows x 16 bits = 128 bits, 128 columns
    assert(Descriptor.memorySummary(ElasParams.byName("small-w7")).map(m => (m.rows, m.bitsPerRow)) == Seq((128, 128)))
  }
}
