package ielas

import chisel3._
import org.scalatest.flatspec.AnyFlatSpec

import java.nio.file.{Files, Path}
import scala.jdk.CollectionConverters._

/** The `(* no_rw_check *)` mark and its check: the assertion fires when a used read meets a write of the same entry
  * in its clock and stays quiet for an unused one or another entry (cases written by hand); the emitted Verilog marks
  * exactly the memory modules that only checked memories use.
  */
class CollisionFreeSpec extends AnyFlatSpec {
  import StreamTester._

  class Harness extends Module {
    val io = IO(new Bundle {
      val wen = Input(Bool()); val waddr = Input(UInt(4.W)); val raddr = Input(UInt(4.W)); val used = Input(Bool())
      val rdata = Output(UInt(8.W))
    })
    val mem = SyncReadMem(16, UInt(8.W))
    when(io.wen) { mem.write(io.waddr, io.waddr + 1.U) }
    io.rdata := mem.read(io.raddr)
    CollisionFree.check("harness", Seq(mem), Seq(CollisionFree.Read(io.raddr, io.used)),
      Seq(CollisionFree.Write(io.wen, io.waddr)))
  }

  /** Clock 1: a write of entry 3 and a read of `raddr`; clock 2: whether that read's word is used. */
  def run(raddr: Int, used: Boolean, name: String): Unit =
    simulate(new Harness, tmpDir(s"CollisionFreeSpec-$name")) { dut =>
      reset(dut)
      poke(dut.io.wen, true); poke(dut.io.waddr, BigInt(3)); poke(dut.io.raddr, BigInt(raddr)); poke(dut.io.used, false)
      step(dut.clock)
      poke(dut.io.wen, false); poke(dut.io.used, used)
      step(dut.clock)
      poke(dut.io.used, false)
      step(dut.clock, 2)
    }

  behavior of "CollisionFree"

  it should "assert when a used read meets a write of its entry in its clock, and only then" in {
    run(raddr = 5, used = true, "other-entry")
    run(raddr = 3, used = false, "unused")
    val failed = try { run(raddr = 3, used = true, "collision"); None } catch { case e: Throwable => Some(e) }
    assert(failed.nonEmpty, "a used read that met a write passed")
  }

  class TwoMemories(sameShape: Boolean) extends Module {
    val io = IO(new Bundle {
      val wen = Input(Bool()); val addr = Input(UInt(4.W)); val data = Input(UInt(8.W))
      val checked = Output(UInt(8.W)); val plain = Output(UInt(8.W))
    })
    val checkedMem = SyncReadMem(16, UInt(8.W))
    val plainMem = SyncReadMem(if (sameShape) 16 else 12, UInt(8.W))
    when(io.wen) { checkedMem.write(io.addr, io.data); plainMem.write(io.addr, io.data) }
    io.checked := checkedMem.read(io.addr + 1.U)
    io.plain := plainMem.read(io.addr + 1.U)
    CollisionFree.check("checked", Seq(checkedMem), Seq(CollisionFree.Read(io.addr + 1.U, true.B)),
      Seq(CollisionFree.Write(io.wen, io.addr)))
  }

  def markedModules(dir: Path): Seq[String] =
    Files.list(dir).iterator().asScala.toSeq.filter(f => new String(Files.readAllBytes(f)).contains("(* no_rw_check *)"))
      .map(_.getFileName.toString.stripSuffix(".sv")).sorted

  it should "mark the memory modules of checked memories only, and not one an unchecked memory shares" in {
    for (sameShape <- Seq(false, true)) {
      val dir = tmpDir(s"CollisionFreeSpec-verilog-$sameShape")
      if (Files.isDirectory(dir)) Files.list(dir).iterator().asScala.foreach(Files.delete)
      VerilogEmitter.emit(new TwoMemories(sameShape), dir)
      val files = Files.list(dir).iterator().asScala.map(_.getFileName.toString).toSeq
      val memoryModules = files.filter(f => new String(Files.readAllBytes(dir.resolve(f))).contains("Memory["))
      val marked = markedModules(dir)
      if (sameShape) assert(marked.isEmpty, s"one module serves both memories, yet marked: $marked")
      else {
        assert(memoryModules.size == 2, s"expected two memory modules, got $memoryModules")
        assert(marked.size == 1 && marked.head.startsWith("checkedMem"), s"marked: $marked of $memoryModules")
        val text = new String(Files.readAllBytes(dir.resolve(marked.head + ".sv")))
        assert(text.contains("(* no_rw_check *)\n  reg [7:0] Memory[0:15];"), text)
      }
    }
  }
}
