// Stand-in for the IElas top, only for developing and testing the C++ harness (src/test/cpp/ielas_sim.cpp).
// It has exactly the final top's ports. It is not the accelerator: it outputs left*16 for every pixel, delayed by
// a known amount, so the harness's cycle, latency and framing numbers can be checked against hand computation.
//
// Timing (no input gaps, no output stalls, no input back-pressure): input row y of the stream is released to the
// output once input row y+LAT_ROWS has arrived completely, or once its whole frame has arrived, and then only
// EXTRA cycles later (the release counters pass through an EXTRA-stage delay line). Output therefore runs one
// pixel per cycle, F frames of WxH take F*H*W + LAT_ROWS*W + EXTRA cycles from the first input to the last output,
// and every row's last output pixel follows its last input pixel by (LAT_ROWS+1)*W + EXTRA cycles.
//
// Run-time knobs (Verilator plusargs, passed through by the harness):
//   +stub_lat_rows=N   LAT_ROWS, 0..MAX_LAT_ROWS (default 2)
//   +stub_extra=N      EXTRA, 0..MAX_EXTRA (default 3)
//   +stub_bp=K         input back-pressure: in_ready is low one cycle in every K (K >= 2; 0 = never, default)
//   +stub_fault=N      deliberate faults for the harness's own tests:
//                        1 eol missing on output row 1 of the first frame, 2 eof missing on the first frame,
//                        3 output stops after 100 pixels, 4 error bit raised at the first frame's end,
//                        5 a second sof at output pixel (1, 0), 6 eol one pixel early on output row 0
// Frame size check like the real top: a start of frame whose size lies outside 32x16..MAX_W x MAX_H raises the
// sticky error bit (cleared by reset or clearError) with an errorCauses bit-0 pulse, and that frame's input is
// dropped up to the next sof. Nothing else is checked: lines of the wrong length and early starts of frame pass
// through as they come, no errorCauses pulse, no frameAborted pulse (the soak mode's tests rely on that).
/* verilator lint_off UNUSEDSIGNAL */  // a stand-in: the right image and the high bits of counters are unused
module IElas #(
  parameter int MAX_W = 128,
  parameter int MAX_H = 64,
  parameter int COL_BITS = $clog2(MAX_W + 1),
  parameter int ROW_BITS = $clog2(MAX_H + 1),
  parameter int MAX_LAT_ROWS = 8,
  parameter int MAX_EXTRA = 64
) (
  input  logic                clock,
  input  logic                reset,
  input  logic                io_in_valid,
  output logic                io_in_ready,
  input  logic [7:0]          io_in_bits_left,
  input  logic [7:0]          io_in_bits_right,
  input  logic                io_in_bits_sof,
  input  logic                io_in_bits_eol,
  input  logic [COL_BITS-1:0] io_frameWidth,
  input  logic [ROW_BITS-1:0] io_frameHeight,
  output logic                io_error,
  input  logic                io_clearError,
  output logic                io_out_valid,
  input  logic                io_out_ready,
  output logic [15:0]         io_out_bits_data,
  output logic                io_out_bits_sof,
  output logic                io_out_bits_eol,
  output logic                io_out_bits_eof,
  output logic [4:0]          io_errorCauses,
  output logic                io_frameAborted
);
  // (LAT_ROWS+1) whole rows must fit, or the release condition could wait for input that cannot enter.
  localparam int DEPTH = (MAX_LAT_ROWS + 2) * MAX_W;

  int latRows, extra, bpPeriod, fault;
  initial begin
    if (!$value$plusargs("stub_lat_rows=%d", latRows)) latRows = 2;
    if (!$value$plusargs("stub_extra=%d", extra)) extra = 3;
    if (!$value$plusargs("stub_bp=%d", bpPeriod)) bpPeriod = 0;
    if (!$value$plusargs("stub_fault=%d", fault)) fault = 0;
    if (latRows < 0 || latRows > MAX_LAT_ROWS) begin $display("stub: +stub_lat_rows out of 0..%0d", MAX_LAT_ROWS); $finish; end
    if (extra < 0 || extra > MAX_EXTRA) begin $display("stub: +stub_extra out of 0..%0d", MAX_EXTRA); $finish; end
  end

  // FIFO entry: {sof, eol, eof, left}; eof is computed at the input from the frame's latched height.
  logic [10:0] mem [DEPTH];
  int wrPtr, rdPtr, count;
  // Global row counters (over all frames): rows fully input, rows at the end of the last complete input frame,
  // rows fully output.
  int rowsIn, rowsAtFrameEnd, rowsOut;
  int rowsInD [MAX_EXTRA];   // rowsInD[i] = rowsIn i+1 cycles ago
  int frameEndD [MAX_EXTRA];

  logic error, dropping;
  logic [ROW_BITS-1:0] heightLatched;
  int inRow;            // row of the current input frame
  int cycle;
  int outPixels, outRowPix, outRowIdx; // output pixels so far, column and row in the current output frame
  logic stopped;

  wire sizeOk = int'(io_frameWidth) >= 32 && int'(io_frameHeight) >= 16 && int'(io_frameWidth) <= MAX_W && int'(io_frameHeight) <= MAX_H;
  wire sofIn = io_in_valid && io_in_bits_sof;
  wire drop = sofIn ? !sizeOk : dropping;
  wire bpLow = bpPeriod >= 2 && (cycle % bpPeriod) == bpPeriod - 1;
  assign io_in_ready = drop || (!bpLow && count < DEPTH);
  wire inFire = io_in_valid && io_in_ready && !drop;
  wire [ROW_BITS-1:0] height = io_in_bits_sof ? io_frameHeight : heightLatched;
  wire [ROW_BITS-1:0] rowNow = io_in_bits_sof ? 0 : inRow[ROW_BITS-1:0];
  wire inEof = io_in_bits_eol && rowNow == height - 1;

  // release: the head row has LAT_ROWS complete rows after it, or its frame is complete (both seen EXTRA late)
  wire int rowsInSeen = extra == 0 ? rowsIn : rowsInD[extra - 1];
  wire int frameEndSeen = extra == 0 ? rowsAtFrameEnd : frameEndD[extra - 1];
  wire released = count > 0 && (rowsInSeen >= rowsOut + 1 + latRows || frameEndSeen >= rowsOut + 1);
  wire [10:0] head = mem[rdPtr];
  assign io_out_valid = released && !stopped;
  assign io_out_bits_data = {4'b0, head[7:0], 4'b0};
  assign io_out_bits_sof = head[10] || (fault == 5 && outRowIdx == 1 && outRowPix == 0);
  assign io_out_bits_eol = (head[9] && !(fault == 1 && outPixels < 2 * int'(io_frameWidth) && outRowIdx == 1)
                            && !(fault == 6 && outPixels < int'(io_frameWidth)))
                           || (fault == 6 && outPixels == int'(io_frameWidth) - 2);
  assign io_out_bits_eof = head[8] && !(fault == 2 && outPixels < int'(io_frameWidth) * int'(io_frameHeight));
  wire outFire = io_out_valid && io_out_ready;
  assign io_error = error;
  // errorCauses bit 0 (frame size) as the real top; the stub checks nothing else, so it never aborts a frame
  assign io_errorCauses = {4'b0, sofIn && !sizeOk && io_in_ready};
  assign io_frameAborted = 1'b0;

  always_ff @(posedge clock) begin
    if (reset) begin
      wrPtr <= 0; rdPtr <= 0; count <= 0;
      rowsIn <= 0; rowsAtFrameEnd <= 0; rowsOut <= 0;
      for (int i = 0; i < MAX_EXTRA; i++) begin rowsInD[i] <= 0; frameEndD[i] <= 0; end
      error <= 1'b0; dropping <= 1'b0; heightLatched <= '0; inRow <= 0; cycle <= 0;
      outPixels <= 0; outRowPix <= 0; outRowIdx <= 0; stopped <= 1'b0;
    end else begin
      cycle <= cycle + 1;
      if (io_in_valid && io_in_ready) dropping <= drop;
      if (io_clearError) error <= 1'b0;
      if (sofIn && !sizeOk) error <= 1'b1;
      if (inFire) begin
        mem[wrPtr] <= {io_in_bits_sof, io_in_bits_eol, inEof, io_in_bits_left};
        wrPtr <= wrPtr == DEPTH - 1 ? 0 : wrPtr + 1;
        if (io_in_bits_sof) heightLatched <= io_frameHeight;
        if (io_in_bits_eol) begin
          rowsIn <= rowsIn + 1;
          inRow <= int'(rowNow) + 1;
          if (inEof) rowsAtFrameEnd <= rowsIn + 1;
        end else if (io_in_bits_sof) inRow <= 0;
      end
      rowsInD[0] <= rowsIn;
      frameEndD[0] <= rowsAtFrameEnd;
      for (int i = 1; i < MAX_EXTRA; i++) begin rowsInD[i] <= rowsInD[i - 1]; frameEndD[i] <= frameEndD[i - 1]; end
      if (outFire) begin
        rdPtr <= rdPtr == DEPTH - 1 ? 0 : rdPtr + 1;
        if (head[9]) rowsOut <= rowsOut + 1;
        outPixels <= outPixels + 1;
        if (fault == 3 && outPixels == 99) stopped <= 1'b1;
        if (head[9]) begin outRowPix <= 0; outRowIdx <= outRowIdx + 1; end else outRowPix <= outRowPix + 1;
        if (fault == 4 && head[8] && outPixels < int'(io_frameWidth) * int'(io_frameHeight)) error <= 1'b1;
      end
      count <= count + (inFire ? 1 : 0) - (outFire ? 1 : 0);
    end
  end
endmodule
