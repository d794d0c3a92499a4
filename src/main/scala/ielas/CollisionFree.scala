package ielas

import chisel3._
import chisel3.experimental.BaseModule

import java.nio.file.{Files, Path}
import scala.collection.mutable.ArrayBuffer

/** Memories whose used reads never meet a write of the same entry in the same clock, marked `(* no_rw_check *)` in
  * the emitted Verilog (docs/memory-collisions.md).
  *
  * What a block RAM returns when a read and a write of one address share a clock differs between parts, so Yosys
  * (ECP5) emulates the Verilog's answer around every block-RAM read it cannot prove collision-free: a multiplexer per
  * read bit and registers for the written word and the address compare (one LUT4 per bit and about 80 flip-flops on
  * a 36-bit port). The mark tells it that answer is never used. Each marked memory states why in its stage, and
  * [[CollisionFree.check]] asserts it in every simulation; a memory without an assertion is not marked.
  */
object CollisionFree {
  /** A read port: `addr` is the address it is given (for a SyncReadMem, the clock before its word; for a `Mem` read
    * into a register, the clock of the read), `usedNext` whether the word read at that address is used, known a
    * clock later (the word's own clock). */
  case class Read(addr: UInt, usedNext: Bool)
  /** A write port: its enable and address, of the same clock. */
  case class Write(enable: Bool, addr: UInt)

  /** Marks `mems` and asserts that no used read meets a write of its clock to the same entry. */
  def check(what: String, mems: Seq[MemBase[_]], reads: Seq[Read], writes: Seq[Write]): Unit = {
    for ((r, i) <- reads.zipWithIndex) {
      val met = RegNext(writes.map(w => w.enable && w.addr === r.addr).reduce(_ || _), false.B)
      assert(!(met && r.usedNext), s"$what: a used read (port $i) met a write of the same entry")
    }
    mark(mems)
  }

  /** Records `mems` for [[VerilogEmitter]] (only while it elaborates; other elaborations record nothing). */
  private def mark(mems: Seq[MemBase[_]]): Unit = recording.get.foreach { marks =>
    val parent = Module.currentModule.get
    mems.foreach(m => marks += ((parent, m)))
  }
  private val recording = new ThreadLocal[Option[ArrayBuffer[(BaseModule, MemBase[_])]]] {
    override def initialValue(): Option[ArrayBuffer[(BaseModule, MemBase[_])]] = None
  }

  /** Runs `elaborate` and returns the marked memories as (module name, memory instance name). */
  def recorded(elaborate: => Unit): Set[(String, String)] = {
    val marks = ArrayBuffer.empty[(BaseModule, MemBase[_])]
    recording.set(Some(marks))
    try elaborate
    finally recording.set(None)
    marks.map { case (parent, m) => (parent.name, m.instanceName) }.toSet
  }

  private val instance = """(?m)^\s*(\w+)\s+(\w+)_ext\s*\(""".r
  private val memoryArray = """(?m)^([ \t]*)(reg\s+(\[[^\]]*\]\s*)?Memory\s*\[)""".r

  /** Puts the mark on the memory modules of `dir` (firtool's --split-verilog output) that only marked memories use.
    * firtool shares one module among memories of one shape, so a module that any unmarked memory also uses is left
    * as it is (its marked memories then keep Yosys's emulation: slower, never wrong). Returns the modules marked. */
  def markVerilog(dir: Path, marks: Set[(String, String)]): Seq[String] = {
    import scala.jdk.CollectionConverters._
    val files = Files.list(dir).iterator().asScala.filter(_.toString.endsWith(".sv")).toSeq
    val uses = files.flatMap { f =>
      val parent = f.getFileName.toString.stripSuffix(".sv")
      instance.findAllMatchIn(new String(Files.readAllBytes(f), "UTF-8")).map(m => m.group(1) -> (parent, m.group(2)))
    }.groupBy(_._1).map { case (module, xs) => module -> xs.map(_._2) }
    val marked = uses.collect { case (module, insts) if insts.forall(marks.contains) => module }.toSeq.sorted
    for (module <- marked) {
      val f = dir.resolve(s"$module.sv")
      if (Files.exists(f)) {
        val text = new String(Files.readAllBytes(f), "UTF-8")
        if (!text.contains("no_rw_check") && memoryArray.findFirstIn(text).isDefined)
          Files.write(f, memoryArray.replaceFirstIn(text, "$1(* no_rw_check *)\n$1$2").getBytes("UTF-8"))
      }
    }
    marked.filter(m => Files.exists(dir.resolve(s"$m.sv")))
  }
}
