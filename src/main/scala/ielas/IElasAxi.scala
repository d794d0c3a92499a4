package ielas

import chisel3._
import chisel3.util._

import java.nio.file.{Files, Path}

/** An AXI4-Stream channel by the AMBA signal names (the master's view; `Flipped` for a slave). */
class AxiStream(dataBits: Int) extends Bundle {
  val tdata = Output(UInt(dataBits.W))
  val tvalid = Output(Bool())
  val tready = Input(Bool())
  /** Start of frame (Xilinx video convention). */
  val tuser = Output(Bool())
  /** End of line. */
  val tlast = Output(Bool())
}

/** An AXI4-Lite interface, 32-bit data, by the AMBA signal names (the master's view; `Flipped` for a slave). */
class AxiLite(addrBits: Int) extends Bundle {
  val awaddr = Output(UInt(addrBits.W))
  val awprot = Output(UInt(3.W))
  val awvalid = Output(Bool())
  val awready = Input(Bool())
  val wdata = Output(UInt(32.W))
  val wstrb = Output(UInt(4.W))
  val wvalid = Output(Bool())
  val wready = Input(Bool())
  val bresp = Input(UInt(2.W))
  val bvalid = Input(Bool())
  val bready = Output(Bool())
  val araddr = Output(UInt(addrBits.W))
  val arprot = Output(UInt(3.W))
  val arvalid = Output(Bool())
  val arready = Input(Bool())
  val rdata = Input(UInt(32.W))
  val rresp = Input(UInt(2.W))
  val rvalid = Input(Bool())
  val rready = Output(Bool())
}

/** The accelerator as drop-in IP (docs/interfaces.md §6): [[IElas]] behind AXI4-Stream video ports and an AXI4-Lite
  * register file ([[IElasAxi.registerMap]], also written as a C header and a Markdown table by `make verilog`).
  *
  *  - `s_axis_video`: tdata[15:8] = left pixel, tdata[7:0] = right pixel, tuser = start of frame, tlast = end of line.
  *  - `m_axis_video`: tdata = signed disparity·16 (4 fractional bits), 0xFFFF (−1) = invalid; tuser = start of
  *    frame, tlast = end of line. A frame cut because its input was malformed ends after a whole line.
  *  - `aclk`, `aresetn`: one clock; active-low synchronous reset of everything (AXI convention).
  *
  * CONTROL.SOFT_RESET resets the accelerator alone for a few cycles: the frames in flight are dropped (counted as
  * aborted), the registers and counters keep their values, and the output register slice (not reset) finishes the
  * beats it already offered, so m_axis_video never withdraws tvalid.
  */
class IElasAxi(p: ElasParams) extends RawModule {
  import IElasAxi._
  val aclk = IO(Input(Clock()))
  val aresetn = IO(Input(Bool()))
  val s_axis_video = IO(Flipped(new AxiStream(16)))
  val m_axis_video = IO(new AxiStream(16))
  val s_axi_ctrl = IO(Flipped(new AxiLite(addrBits)))

  withClockAndReset(aclk, !aresetn) {
    val regs = registerMap(p)
    def reg(name: String): Register = regs.find(_.name == name).get
    def field(r: String, f: String): Field = reg(r).fields.find(_.name == f).get

    // ---- control state ----
    val enable = RegInit((field("CONTROL", "ENABLE").reset == 1).B)
    val frameWidth = RegInit(reg("FRAME_WIDTH").reset.U(p.colBits.W))
    val frameHeight = RegInit(reg("FRAME_HEIGHT").reset.U(p.rowBits.W))
    val softResetLeft = RegInit(0.U(2.W)) // cycles of accelerator reset still to go
    val coreReset = softResetLeft =/= 0.U
    when(coreReset) { softResetLeft := softResetLeft - 1.U }
    val clearError = WireDefault(false.B)
    val clearCounters = WireDefault(false.B)

    // ---- the accelerator and its streams ----
    val core = withReset(!aresetn || coreReset) { Module(new IElas(p)) }
    val takeInput = enable && !coreReset
    core.io.in.valid := s_axis_video.tvalid && takeInput
    core.io.in.bits.left := s_axis_video.tdata(15, 8)
    core.io.in.bits.right := s_axis_video.tdata(7, 0)
    core.io.in.bits.sof := s_axis_video.tuser
    core.io.in.bits.eol := s_axis_video.tlast
    s_axis_video.tready := core.io.in.ready && takeInput
    core.io.frameWidth := frameWidth
    core.io.frameHeight := frameHeight
    core.io.clearError := clearError

    // Output register slice, outside the soft reset: a beat once offered stays offered until taken.
    val slice = Module(new Queue(new Framed(SInt(16.W)), 2))
    slice.io.enq.valid := core.io.out.valid && !coreReset
    slice.io.enq.bits := core.io.out.bits
    core.io.out.ready := slice.io.enq.ready && !coreReset
    m_axis_video.tvalid := slice.io.deq.valid
    m_axis_video.tdata := slice.io.deq.bits.data.asUInt
    m_axis_video.tuser := slice.io.deq.bits.sof
    m_axis_video.tlast := slice.io.deq.bits.eol
    slice.io.deq.ready := m_axis_video.tready

    // ---- status and counters ----
    val causes = RegInit(0.U(FrameGuard.Cause.count.W)) // sticky; a new cause in the clearing cycle wins
    val newCauses = Mux(coreReset, 0.U, core.io.errorCauses)
    causes := Mux(clearError, 0.U, causes) | newCauses

    val sofIn = s_axis_video.tvalid && s_axis_video.tready && s_axis_video.tuser
    val eofOut = core.io.out.fire && core.io.out.bits.eof
    // Every frame started at the input leaves complete (eof), is aborted (malformed) or is dropped (illegal size),
    // or is dropped by a soft reset: the frames in flight are those not yet accounted for.
    val ended = Mux(coreReset, 0.U, eofOut.asUInt +& core.io.frameAborted.asUInt +&
      core.io.errorCauses(FrameGuard.Cause.size).asUInt)
    val inFlight = RegInit(0.U(8.W))
    inFlight := Mux(coreReset, 0.U, inFlight + sofIn.asUInt - ended)
    val abortedNow = Mux(coreReset, inFlight, ended - eofOut.asUInt)

    def counter(inc: UInt): UInt = {
      val c = RegInit(0.U(32.W))
      c := Mux(clearCounters, 0.U, c + inc)
      c
    }
    val framesIn = counter(sofIn.asUInt)
    val framesOut = counter(eofOut.asUInt)
    val framesAborted = counter(abortedNow)
    val stalls = counter((m_axis_video.tvalid && !m_axis_video.tready).asUInt)
    // cycles from the first to the last transfer of the last complete output frame, both inclusive
    val outFire = m_axis_video.tvalid && m_axis_video.tready
    val running = RegInit(false.B)
    val frameCycles = RegInit(0.U(32.W))
    val lastFrameCycles = RegInit(0.U(32.W))
    when(running) { frameCycles := frameCycles + 1.U }
    when(outFire && slice.io.deq.bits.sof) { running := true.B; frameCycles := 1.U }
      .elsewhen(outFire && slice.io.deq.bits.eof && running) { running := false.B; lastFrameCycles := frameCycles + 1.U }
    when(clearCounters) { lastFrameCycles := 0.U }
    val busy = inFlight =/= 0.U || slice.io.count =/= 0.U || coreReset

    // ---- register values as read ----
    val readValue: Map[String, UInt] = Map(
      "CONTROL" -> enable.asUInt,
      "STATUS" -> Cat(busy, 0.U((8 - 1 - FrameGuard.Cause.count).W), causes, causes.orR || core.io.error),
      "FRAME_WIDTH" -> frameWidth,
      "FRAME_HEIGHT" -> frameHeight,
      "FRAMES_IN" -> framesIn,
      "FRAMES_OUT" -> framesOut,
      "FRAMES_ABORTED" -> framesAborted,
      "LAST_FRAME_CYCLES" -> lastFrameCycles,
      "OUTPUT_STALL_CYCLES" -> stalls)
    def valueOf(r: Register): UInt = readValue.getOrElse(r.name, r.reset.U(32.W)) // constants read their reset value

    // ---- AXI4-Lite write: AW and W are taken independently (either order), then answered on B ----
    val awHeld = RegInit(false.B)
    val awAddr = Reg(UInt(addrBits.W))
    val wHeld = RegInit(false.B)
    val wData = Reg(UInt(32.W))
    val wStrb = Reg(UInt(4.W))
    val bValid = RegInit(false.B)
    val bResp = RegInit(Resp.okay.U(2.W))
    s_axi_ctrl.awready := !awHeld
    s_axi_ctrl.wready := !wHeld
    s_axi_ctrl.bvalid := bValid
    s_axi_ctrl.bresp := bResp
    when(s_axi_ctrl.awvalid && !awHeld) { awHeld := true.B; awAddr := s_axi_ctrl.awaddr }
    when(s_axi_ctrl.wvalid && !wHeld) { wHeld := true.B; wData := s_axi_ctrl.wdata; wStrb := s_axi_ctrl.wstrb }
    when(bValid && s_axi_ctrl.bready) { bValid := false.B }

    val doWrite = awHeld && wHeld && !bValid
    val byteMask = Cat((3 to 0 by -1).map(i => Fill(8, wStrb(i))))
    def merged(old: UInt): UInt = (old & ~byteMask) | (wData & byteMask)
    val writeWord = awAddr >> 2
    val writeResp = WireDefault(Resp.decErr.U(2.W))
    for (r <- regs) when(writeWord === (r.offset / 4).U) {
      writeResp := (if (r.access == Access.RW) Resp.okay.U else Resp.slvErr.U)
    }
    def writes(name: String): Bool = doWrite && writeWord === (reg(name).offset / 4).U
    // a size that does not fit its register is refused (SLVERR) and leaves the register unchanged
    def sizeWrite(name: String, r: UInt): Unit = {
      val value = merged(r.pad(32))
      when(writes(name)) {
        when(value >> r.getWidth =/= 0.U) { writeResp := Resp.slvErr.U }.otherwise { r := value(r.getWidth - 1, 0) }
      }
    }
    sizeWrite("FRAME_WIDTH", frameWidth)
    sizeWrite("FRAME_HEIGHT", frameHeight)
    when(writes("CONTROL") && wStrb(0)) {
      def bit(f: String): Bool = wData(field("CONTROL", f).lsb)
      enable := bit("ENABLE")
      clearError := bit("CLEAR_ERROR")
      clearCounters := bit("CLEAR_COUNTERS")
      when(bit("SOFT_RESET")) { softResetLeft := 3.U }
    }
    when(doWrite) {
      awHeld := false.B
      wHeld := false.B
      bValid := true.B
      bResp := writeResp
    }

    // ---- AXI4-Lite read: one outstanding read, answered the cycle after AR ----
    val rValid = RegInit(false.B)
    val rData = RegInit(0.U(32.W))
    val rResp = RegInit(Resp.okay.U(2.W))
    s_axi_ctrl.arready := !rValid
    s_axi_ctrl.rvalid := rValid
    s_axi_ctrl.rdata := rData
    s_axi_ctrl.rresp := rResp
    when(rValid && s_axi_ctrl.rready) { rValid := false.B }
    when(s_axi_ctrl.arvalid && !rValid) {
      val word = s_axi_ctrl.araddr >> 2
      rValid := true.B
      rData := 0.U
      rResp := Resp.decErr.U
      for (r <- regs) when(word === (r.offset / 4).U) { rData := valueOf(r); rResp := Resp.okay.U }
    }
  }
}

object IElasAxi {
  /** Byte address bits of the register file: a 256-byte window. */
  val addrBits = 8
  /** VERSION register: major << 16 | minor. */
  val version: Int = 0x00010000

  object Resp {
    val okay = 0
    val slvErr = 2
    val decErr = 3
  }

  sealed abstract class Access(val name: String)
  object Access {
    case object RO extends Access("RO")
    case object RW extends Access("RW")
  }

  /** A bit field of a register; `access` "RW", "RO" or "W1" (write 1 for a one-cycle action, reads 0). */
  case class Field(name: String, lsb: Int, width: Int, access: String, reset: BigInt, doc: String) {
    def mask: BigInt = ((BigInt(1) << width) - 1) << lsb
  }
  case class Register(name: String, offset: Int, access: Access, reset: BigInt, doc: String, fields: Seq[Field],
      constant: Boolean = false)

  /** The register map: the hardware decodes these offsets, and the C header and the Markdown table are written from
    * it. Registers without fields are one value in bits width-1..0.
    */
  def registerMap(p: ElasParams): Seq[Register] = {
    import Access._
    def value(name: String, offset: Int, access: Access, bits: Int, reset: BigInt, doc: String) =
      Register(name, offset, access, reset, doc, Seq(Field("VALUE", 0, bits, access.name, reset, doc)))
    def counter(name: String, offset: Int, doc: String) = value(name, offset, RO, 32, 0, doc)
    def param(name: String, offset: Int, v: Int, doc: String) = value(name, offset, RO, 32, v, doc).copy(constant = true)
    val c = FrameGuard.Cause
    Seq(
      param("VERSION", 0x00, version, "register map version: major << 16 | minor"),
      Register("CONTROL", 0x04, RW, 1, "control", Seq(
        Field("ENABLE", 0, 1, "RW", 1, "1: take input (0 holds s_axis_video_tready low; frames in flight finish)"),
        Field("CLEAR_ERROR", 1, 1, "W1", 0, "write 1: clear STATUS error bits"),
        Field("SOFT_RESET", 2, 1, "W1", 0, "write 1: reset the accelerator, dropping the frames in flight (counted as aborted)"),
        Field("CLEAR_COUNTERS", 3, 1, "W1", 0, "write 1: zero the counters"))),
      Register("STATUS", 0x08, RO, 0, "status; error bits are sticky until CONTROL.CLEAR_ERROR", Seq(
        Field("ERROR", 0, 1, "RO", 0, "any error below"),
        Field("ERR_SIZE", 1 + c.size, 1, "RO", 0, "frame size at start of frame outside 32x16..maximum (frame dropped)"),
        Field("ERR_SHORT_LINE", 1 + c.shortLine, 1, "RO", 0, "a line ended early (padded with zeros, frame cut)"),
        Field("ERR_LONG_LINE", 1 + c.longLine, 1, "RO", 0, "a line too long (cut, frame cut)"),
        Field("ERR_EARLY_SOF", 1 + c.earlySof, 1, "RO", 0, "start of frame in mid-frame (frame cut)"),
        Field("ERR_EXTRA_LINES", 1 + c.extraLines, 1, "RO", 0, "pixels after a frame's last line (dropped)"),
        Field("BUSY", 8, 1, "RO", 0, "frames in flight or output beats not yet taken"))),
      value("FRAME_WIDTH", 0x0c, RW, p.colBits, p.maxWidth, s"frame width in pixels, sampled at start of frame (legal 32..${p.maxWidth})"),
      value("FRAME_HEIGHT", 0x10, RW, p.rowBits, p.maxHeight, s"frame height in lines, sampled at start of frame (legal 16..${p.maxHeight})"),
      counter("FRAMES_IN", 0x14, "start-of-frame beats taken on s_axis_video"),
      counter("FRAMES_OUT", 0x18, "complete frames put out"),
      counter("FRAMES_ABORTED", 0x1c, "frames cut (malformed input), dropped (illegal size) or dropped by SOFT_RESET"),
      counter("LAST_FRAME_CYCLES", 0x20, "cycles from the first to the last transfer of the last complete output frame"),
      counter("OUTPUT_STALL_CYCLES", 0x24, "cycles with m_axis_video_tvalid high and tready low"),
      param("MAX_WIDTH", 0x40, p.maxWidth, "maximum frame width"),
      param("MAX_HEIGHT", 0x44, p.maxHeight, "maximum frame height"),
      param("DISP_MAX", 0x48, p.dispMax, "largest disparity"),
      param("WINDOW_SIZE", 0x4c, p.windowSize, "descriptor window size"),
      param("STORED_DISPARITIES", 0x50, p.storedDisparities, "candidate disparities per grid cell"),
      param("CYCLES_PER_PIXEL", 0x54, p.cyclesPerPixel, "clocks per input pixel"))
  }

  private val prefix = "IELAS_AXI"

  /** The C header: NAME_OFFSET per register; NAME_FIELD_LSB/_MASK per field; NAME_VALUE for read-only constants. */
  def header(p: ElasParams): String = {
    val guard = s"${prefix}_REGS_H"
    val lines = Seq(
      s"/* IElasAxi register map for configuration ${p.name} (generated by the iELAS generator; do not edit). */",
      s"#ifndef $guard", s"#define $guard", "",
      s"#define ${prefix}_ADDR_BITS $addrBits",
      s"#define ${prefix}_RESP_OKAY ${Resp.okay}u",
      s"#define ${prefix}_RESP_SLVERR ${Resp.slvErr}u",
      s"#define ${prefix}_RESP_DECERR ${Resp.decErr}u",
      s"#define ${prefix}_INVALID_DISPARITY 0xFFFFu /* m_axis_video_tdata of an invalid pixel (-1) */", "") ++
      registerMap(p).flatMap { r =>
        val n = s"${prefix}_${r.name}"
        Seq(s"/* ${r.name} (${r.access.name}): ${r.doc} */", f"#define ${n}_OFFSET 0x${r.offset}%02Xu") ++
          (if (r.constant) Seq(s"#define ${n}_VALUE ${r.reset}u") else Nil) ++
          r.fields.filter(_.name != "VALUE").flatMap { f =>
            Seq(s"#define ${n}_${f.name}_LSB ${f.lsb}", s"#define ${n}_${f.name}_MASK 0x${f.mask.toString(16).toUpperCase}u")
          } :+ ""
      } :+ s"#endif /* $guard */"
    lines.mkString("", "\n", "\n")
  }

  /** The Markdown register table. */
  def markdown(p: ElasParams): String = {
    def cell(s: String) = s.replace("|", "\\|")
    val rows = registerMap(p).flatMap { r =>
      val fields = r.fields.filter(_.name != "VALUE")
      val bits = if (fields.isEmpty) s"${r.fields.head.width - 1}:0" else ""
      f"| 0x${r.offset}%02X | `${r.name}` | ${r.access.name} | $bits | 0x${r.reset.toString(16).toUpperCase} | ${cell(r.doc)} |" +:
        fields.map { f =>
          val b = if (f.width == 1) s"${f.lsb}" else s"${f.lsb + f.width - 1}:${f.lsb}"
          s"| | `${f.name}` | ${f.access} | $b | ${f.reset} | ${cell(f.doc)} |"
        }
    }
    (Seq(s"# IElasAxi registers, configuration `${p.name}`", "",
      s"AXI4-Lite, 32-bit data, byte addresses ($addrBits address bits). A write to a read-only register answers " +
        "SLVERR (so does a frame size that does not fit its register); an address not listed answers DECERR. " +
        "Counters are 32 bits and wrap.", "",
      "| offset | register / field | access | bits | reset | meaning |", "|---|---|---|---|---|---|") ++ rows)
      .mkString("", "\n", "\n")
  }

  /** A FuseSoC core: the generated files of this directory, a Verilator lint target with the waivers. */
  def fusesocCore(p: ElasParams, svFiles: Seq[String]): String = {
    val safe = p.name.replaceAll("[^A-Za-z0-9_]", "_")
    (Seq("CAPI=2:", "", s"name: ielas:ip:ielas_axi_$safe:1.0.0",
      s"description: iELAS stereo matcher with AXI4-Stream video and AXI4-Lite ports (configuration ${p.name})", "",
      "filesets:", "  rtl:", "    files:") ++ svFiles.sorted.map(f => s"      - $f") ++
      Seq("    file_type: systemVerilogSource", "  waivers:", "    files:", "      - lint.vlt",
        "    file_type: vlt", "  headers:", "    files:", "      - IElasAxi_regs.h: {is_include_file: true}",
        "    file_type: cSource", "",
        "targets:", "  default: &default", "    filesets: [rtl, headers]", "    toplevel: IElasAxi", "",
        "  lint:", "    <<: *default", "    filesets: [rtl, waivers]", "    default_tool: verilator",
        "    tools:", "      verilator:", "        mode: lint-only", "        verilator_options: [-Wall]", "    toplevel: IElasAxi"))
      .mkString("", "\n", "\n")
  }

  /** The register map files beside the Verilog: IElasAxi_regs.h and IElasAxi_regs.md. */
  def writeRegisterMap(p: ElasParams, dir: Path): Seq[Path] = {
    Files.createDirectories(dir)
    Seq("IElasAxi_regs.h" -> header(p), "IElasAxi_regs.md" -> markdown(p)).map { case (n, text) =>
      Files.write(dir.resolve(n), text.getBytes("UTF-8"))
    }
  }
}
