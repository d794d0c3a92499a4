package ielas

import chisel3._
import chisel3.util._

/** Stage `post` (docs/ALGORITHM.md "post", golden postprocess.cpp): lrcheck_L in, disparity * 16 out (-1 invalid),
  * raster order with the same framing (eof on the last pixel). The steps, in pipeline order, each a Decoupled
  * module with bounded row buffers:
  *   [[PostProcessSpeckle]] (small segments, L = speckleWindowRows) -> [[PostRowGaps]] (x16, row gaps, corners)
  *   -> [[PostColumnGaps]] (G = min(ipolGapWidth, ipolColumnWindow) rows) -> [[PostMean]] horizontal + vertical
  *   (filterAdaptiveMean) and/or [[PostMedian]] horizontal + vertical (filterMedian).
  * Latency in rows (steady state): (L + 2) + 1 + G + 3 = (L - 1) + G + 3 of the algorithm's look-ahead plus 4:
  * speckle's forward maps lag one row and its flattening one more (+ 3 over L - 1), and the row gap step needs its
  * row complete (+ 1); the first mean / median pass starts 4 columns behind its input.
  * The steps' register stages add clock cycles, not rows (mean 9, median 2, row gaps 2 plus the register slices
  * before and after them 2, column gaps 3; the ring steps read a row being written 2 columns behind it).
  * See [[PostProcess.latencyRows]].
  */
class PostProcess(p: ElasParams) extends Module {
  private val vW = p.signedDispBits
  val io = IO(new Bundle {
    val in = Flipped(Decoupled(new Framed(SInt(vW.W))))
    val frameWidth = Input(UInt(p.colBits.W))
    val frameHeight = Input(UInt(p.rowBits.W))
    val out = Decoupled(new Framed(SInt(16.W)))
  })
  val speckle = Module(new PostProcessSpeckle(p))
  speckle.io.in <> io.in
  speckle.io.frameWidth := io.frameWidth
  speckle.io.frameHeight := io.frameHeight

  // a register slice between the two: the speckle output queue's LUT-RAM read and the row step's input compares
  // would otherwise share one clock (the whole top's worst path on the ECP5)
  val rows = Module(new PostRowGaps(p))
  val speckleOut = Wire(Decoupled(chiselTypeOf(rows.io.in.bits)))
  speckleOut.valid := speckle.io.out.valid
  speckle.io.out.ready := speckleOut.ready
  speckleOut.bits.data := speckle.io.out.bits.data
  speckleOut.bits.sof := speckle.io.out.bits.sof
  speckleOut.bits.eol := speckle.io.out.bits.eol
  speckleOut.bits.eof := speckle.io.out.bits.eof
  speckleOut.bits.lastRow := speckle.io.outLastRow
  speckleOut.bits.cols := speckle.io.outWidth
  rows.io.in <> RegisterSlice(speckleOut)

  // and one between the row and column gap steps: the column step's ready (from its look-ahead state) would
  // otherwise reach the row step's output register and its ring's write address in the same clock (84 MHz at
  // `small` on the ECP5, 6 LUT levels across the two modules)
  val cols = Module(new PostColumnGaps(p))
  cols.io.in <> RegisterSlice(rows.io.out)
  var tail: DecoupledIO[PostBeat] = cols.io.out
  if (p.filterAdaptiveMean) {
    val h = Module(new PostMean(p, vertical = false))
    val v = Module(new PostMean(p, vertical = true))
    h.io.in <> tail; v.io.in <> h.io.out
    tail = v.io.out
  }
  if (p.filterMedian) {
    val h = Module(new PostMedian(p, vertical = false))
    val v = Module(new PostMedian(p, vertical = true))
    h.io.in <> tail; v.io.in <> h.io.out
    tail = v.io.out
  }
  io.out.valid := tail.valid
  tail.ready := io.out.ready
  io.out.bits.data := tail.bits.data
  io.out.bits.sof := tail.bits.sof
  io.out.bits.eol := tail.bits.eol
  io.out.bits.eof := tail.bits.eof
}

object PostProcess {
  def columnWindow(p: ElasParams): Int = math.min(p.ipolGapWidth, p.ipolColumnWindow)
  /** Rows from an input row to the same output row, steady state: speckle L + 2, then each RowRing step its `below`
    * rows (vertical steps start row v while row v + below arrives), 1 row for the row gaps (the row whole) and ~0 for
    * the first mean / median pass (4 columns behind its input).
    */
  def latencyRows(p: ElasParams): Int =
    PostProcessSpeckle.latencyRows(p) + 1 + columnWindow(p) + (if (p.filterAdaptiveMean) 3 else 0) +
      (if (p.filterMedian) 3 else 0)

  def memorySummary(p: ElasParams): Seq[MemoryUse] = {
    val w = p.maxWidth
    val g = columnWindow(p)
    PostProcessSpeckle.memorySummary(p) ++ Seq(
      MemoryUse("PostRows", "rows", 2 * w, p.signedDispBits, "2 row slots; read-first Mem (block RAM)"),
      MemoryUse("PostRows", "runs", 2 << p.colBits, p.colBits + p.signedDispBits,
        "run table (end column, right value), 2 rows, addressed {slot, column}; read-first Mem (block RAM)"),
      MemoryUse("PostCols", "rows", (g + 2) * w, 1 + p.rowBits + 1 + 16,
        "(G + 2) row slots: value or fill, marker, end row; read-first Mem (block RAM)"),
      MemoryUse("PostCols", "columns", 2 * w, 1 + p.rowBits + 1 + 16,
        "last valid above (read-first Mem) / running fill (SyncReadMem) per column (block RAM)")) ++
      (if (p.filterAdaptiveMean) Seq(
        MemoryUse("PostMean", "windowH", 9, 16 + 4 + 14, "horizontal: 9 pixel registers (value, framing, width)"),
        MemoryUse("PostMean", "rowsV", 9 * w, 16, "9 row slots (rows v-4..v+3 + 1); read-first Mem (block RAM)"),
        MemoryUse("PostMean", "outQueues", 2 * PostMean.outEntries, 16 + 4 + 14,
          "output queue of each pass (its pipeline never stalls; it enters a pixel with a credit)")) else Nil) ++
      (if (p.filterMedian) Seq(
        MemoryUse("PostMedian", "windowH", 9, 16 + 4 + 14, "horizontal: 9 pixel registers (value, framing, width)"),
        MemoryUse("PostMedian", "rowsV", 8 * w, 17, "8 row slots (rows v-3..v+3 + 1); read-first Mem (block RAM)")) else Nil)
  }
}
