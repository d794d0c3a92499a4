"""Tests of the timing flow's parsers and wrapper generator on canned text (no synthesis, no place and route).
Run: python3 scripts/timing/test_timing.py   (a second or so; the wrapper is elaborated by Yosys when it is
installed, else that check is skipped)."""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, HERE)
import pnr_report  # noqa: E402
import wrapper  # noqa: E402

# A hand-written module in firtool's style: grouped ports inherit the previous direction and range.
TINY = """// a hand-written stage
module Tiny(
  input        clock,
               reset,
  input  [3:0] io_a,
               io_b,   // same range as io_a
  input        io_en,
  output [4:0] io_sum,
  output       io_odd
);
  reg [4:0] acc;
  always @(posedge clock) if (reset) acc <= 5'd0; else if (io_en) acc <= io_a + io_b;
  assign io_sum = acc;
  assign io_odd = acc[0];
endmodule
"""

# The shape of nextpnr-ecp5's --report JSON (one clock, a register path and two IO paths), numbers made up.
REPORT = {
    "fmax": {"$glbnet$clk$TRELLIS_IO_IN": {"achieved": 123.456, "constraint": 200}},
    "critical_paths": [
        {"from": "<async>", "to": "posedge $glbnet$clk$TRELLIS_IO_IN", "path": [
            {"type": "source", "delay": 0.0, "from": {"cell": "scan_in$tr_io", "port": "O"},
             "to": {"cell": "scan_in$tr_io", "port": "O"}}]},
        {"from": "posedge $glbnet$clk$TRELLIS_IO_IN", "to": "posedge $glbnet$clk$TRELLIS_IO_IN", "path": [
            {"type": "clk-to-q", "delay": 0.5, "from": {"cell": "dut.acc_TRELLIS_FF_Q_2", "port": "Q"},
             "to": {"cell": "dut.acc_TRELLIS_FF_Q_2", "port": "Q"}},
            {"type": "routing", "delay": 1.25, "net": "dut.acc[2]", "from": {"cell": "dut.acc_TRELLIS_FF_Q_2", "port": "Q"},
             "to": {"cell": "dut.x_LUT4_Z", "port": "A"}},
            {"type": "logic", "delay": 0.25, "from": {"cell": "dut.x_LUT4_Z", "port": "A"},
             "to": {"cell": "dut.x_LUT4_Z", "port": "Z"}},
            {"type": "routing", "delay": 2.0, "net": "dut.x", "from": {"cell": "dut.x_LUT4_Z", "port": "Z"},
             "to": {"cell": "dut.sum_TRELLIS_FF_Q", "port": "DI"}},
            {"type": "setup", "delay": 0.1, "from": {"cell": "dut.sum_TRELLIS_FF_Q", "port": "DI"},
             "to": {"cell": "dut.sum_TRELLIS_FF_Q", "port": "DI"}}]},
        {"from": "posedge $glbnet$clk$TRELLIS_IO_IN", "to": "<async>", "path": []}],
    "utilization": {"TRELLIS_COMB": {"available": 83640, "used": 8364}, "TRELLIS_FF": {"available": 83640, "used": 10},
                    "DP16KD": {"available": 208, "used": 52}, "MULT18X18D": {"available": 156, "used": 0}},
}

# nextpnr-ecp5 log lines of a routed run (the layout of 0.11: tab after Info:, right-aligned counts).
LOG_OK = """Info: Device utilisation:
Info: \t          TRELLIS_IO:       3/    365     0%
Info: \t        TRELLIS_COMB:    8364/  83640    10%
Info: \t              DP16KD:      52/    208    25%

Info: Max frequency for clock '$glbnet$clk$TRELLIS_IO_IN': 150.00 MHz (FAIL at 200.00 MHz)
Info: Routing..
Info: Critical path report for clock '$glbnet$clk$TRELLIS_IO_IN' (posedge -> posedge):
Info:       type curr  total name
Info:   clk-to-q  0.50  0.50 Source dut.acc_TRELLIS_FF_Q_2.Q
Info:    routing  1.25  1.75 Net dut.acc[2] (10,5) -> (11,5)
Info:                          Sink dut.x_LUT4_Z.A
Info:      logic  0.25  2.00 Source dut.x_LUT4_Z.Z
Info:    routing  2.00  4.00 Net dut.x (11,5) -> (12,5)
Info:                          Sink dut.sum_TRELLIS_FF_Q.DI
Info:      setup  0.10  4.10 Source dut.sum_TRELLIS_FF_Q.DI
Info: 2.25 ns logic, 3.25 ns routing

Info: Critical path report for cross-domain path '<async>' -> 'posedge $glbnet$clk$TRELLIS_IO_IN':
Info:       type curr  total name
Info:     source  0.00  0.00 Source scan_in$tr_io.O

Warning: Max frequency for clock '$glbnet$clk$TRELLIS_IO_IN': 123.46 MHz (FAIL at 200.00 MHz)
"""

# An over-full design: the utilisation block is printed, then placement fails.
LOG_FULL = """Info: Device utilisation:
Info: \t        TRELLIS_COMB:  120000/  83640   143%
Info: \t          TRELLIS_FF:   20000/  83640    23%

Info: Placed 3 cells based on constraints.
ERROR: Unable to place cell 'dut.x_LUT4_Z', no BELs remaining to implement cell type 'TRELLIS_COMB'
1 warning, 1 error
"""

# Yosys 0.23 `sta` output: a register-to-register path and the shape of a path from a module input.
STA_REG = """
3. Executing STA pass (static timing analysis).
Latest arrival time in 'Tiny' is 1179:
    1179 $auto$ff.cc:266:slice$2041 (FDRE.R)
           $abc$2127$procmux$1539_CMP
     775 $abc$2127$auto$blifparse.cc:525:parse_blif$2128 (LUT4.I0->O)
           \\ra [0]
     303 $auto$ff.cc:266:slice$2042 (FDRE.C->Q)
       0   \\clock (<primary input>)

Arrival histogram:
"""
STA_IN = """Warning: Module 'RAM128X1S' has no timing arcs!
Latest arrival time in 'Tiny' is 745:
     745 $auto$ff.cc:266:slice$7 (FDRE.D)
           $0\\acc[4:0] [1]
     745 $abc$1$lut$2 (LUT6.I0->O)
           \\io_a [0]
       0   \\io_a [0] (<primary input>)
"""

# A path that ends at a carry output `sta` does not take for an endpoint: the warning sits inside the path block.
STA_UNKNOWN = """Latest arrival time in 'Tiny' is 1500:
    1500 (<unknown>)
Warning: Critical-path does not terminate in a recognised endpoint.
           $gt$x.CO [8]
    1500 $gt$x.carry4 (CARRY4.CI->CO)
           $gt$x.CO [7]
     900 $abc$1 (LUT6.I2->O)
           \\b [1]
     303 $auto$ff.cc:266:slice$9 (FDRE.C->Q)
       0   \\clock (<primary input>)

"""
STA_OUT = """Latest arrival time in 'Tiny' is 880:
     880 (<primary output>)
           \\io_odd
     880 $abc$2 (LUT2.I0->O)
           \\io_a [0]
       0   \\io_a [0] (<primary input>)
"""

STAT_ECP5 = """=== timing_wrap_Tiny ===

        +----------Local Count, excluding submodules.
        |
       40 wires
        3 ports
       30 cells
        3   CCU2C
       12   LUT4
       15   TRELLIS_FF
"""


class ReportTest(unittest.TestCase):
    def test_json_report(self):
        r = pnr_report.parse_nextpnr_json(REPORT)
        self.assertEqual(r["fmax_mhz"], 123.46)
        self.assertEqual(r["target_mhz"], 200)
        cp = r["critical_path"]  # the register path, not the IO paths
        self.assertEqual((cp["start"], cp["end"]), ("acc", "sum"))
        self.assertEqual(cp["to"], "dut.sum_TRELLIS_FF_Q.DI")
        self.assertAlmostEqual(cp["delay_ns"], 4.1)
        self.assertAlmostEqual(cp["routing_ns"], 3.25)
        self.assertAlmostEqual(cp["logic_ns"], 0.85)
        self.assertEqual(r["utilisation"]["TRELLIS_COMB"], {"used": 8364, "available": 83640, "percent": 10.0})
        self.assertEqual(r["utilisation"]["DP16KD"]["percent"], 25.0)
        self.assertFalse(pnr_report.does_not_fit(r))

    def test_log_report(self):
        r = pnr_report.parse_nextpnr_log(LOG_OK)
        self.assertEqual(r["fmax_mhz"], 123.46)  # the last (post-route) line, not the placer's estimate
        self.assertEqual(r["target_mhz"], 200.0)
        cp = r["critical_path"]
        self.assertEqual((cp["start"], cp["end"]), ("acc", "sum"))
        self.assertAlmostEqual(cp["delay_ns"], 4.1)
        self.assertAlmostEqual(cp["routing_ns"], 3.25)
        self.assertEqual(cp["steps"], 1)
        self.assertEqual(r["utilisation"]["TRELLIS_COMB"]["used"], 8364)
        self.assertEqual(len(r["utilisation"]), 3)

    def test_does_not_fit(self):
        r = pnr_report.parse_nextpnr_log(LOG_FULL)
        self.assertTrue(pnr_report.does_not_fit(r))
        self.assertEqual(list(pnr_report.overfull(r["utilisation"])), ["TRELLIS_COMB"])
        self.assertEqual(r["utilisation"]["TRELLIS_COMB"]["percent"], 143.47)
        self.assertIn("no BELs remaining", r["error"])
        self.assertNotIn("fmax_mhz", r)

    def test_sta_register_path(self):
        s = pnr_report.parse_sta(STA_REG)
        self.assertEqual(s["arrival_ps"], 1179)
        start, end = pnr_report.sta_ends(s)
        self.assertEqual(start["kind"], "register")
        self.assertEqual(start["type"], "FDRE")
        self.assertEqual(start["net"], "ra [0]")  # the net the start register drives
        self.assertEqual((end["type"], end["pin"]), ("FDRE", "R"))
        self.assertEqual(s["warnings"], [])

    def test_sta_input_path(self):
        s = pnr_report.parse_sta(STA_IN)
        self.assertEqual(s["arrival_ps"], 745)
        start, end = pnr_report.sta_ends(s)
        self.assertEqual(start, {"kind": "input", "net": "io_a [0]"})
        self.assertEqual((end["type"], end["pin"]), ("FDRE", "D"))
        self.assertEqual(s["warnings"], ["Module 'RAM128X1S' has no timing arcs!"])
        self.assertIsNone(pnr_report.parse_sta("no sta here"))

    def test_sta_other_ends(self):
        s = pnr_report.parse_sta(STA_UNKNOWN)
        self.assertEqual(s["arrival_ps"], 1500)
        start, end = pnr_report.sta_ends(s)
        self.assertEqual((start["kind"], start["net"]), ("register", "b [1]"))
        self.assertEqual((end["type"], end["net"]), ("unknown", "$gt$x.CO [8]"))
        start, end = pnr_report.sta_ends(pnr_report.parse_sta(STA_OUT))
        self.assertEqual(start, {"kind": "input", "net": "io_a [0]"})
        self.assertEqual((end["type"], end["net"]), ("output", "io_odd"))

    def test_stat_counts(self):
        self.assertEqual(pnr_report.parse_cell_counts(STAT_ECP5), {"CCU2C": 3, "LUT4": 12, "TRELLIS_FF": 15})

    def test_short_cell(self):
        self.assertEqual(pnr_report.short_cell("dut.memR_0_ext.Memory.0.0$DPRAM_COMB1"), "memR_0_ext.Memory.0.0")
        self.assertEqual(pnr_report.short_cell("dut.s2DL_TRELLIS_FF_Q_DI_CCU2C_B1"), "s2DL")
        self.assertEqual(pnr_report.short_cell("plain"), "plain")


class WrapperTest(unittest.TestCase):
    def test_ports(self):
        self.assertEqual(wrapper.parse_ports(TINY, "Tiny"), [
            ("input", 1, "clock"), ("input", 1, "reset"), ("input", 4, "io_a"), ("input", 4, "io_b"),
            ("input", 1, "io_en"), ("output", 5, "io_sum"), ("output", 1, "io_odd")])
        with self.assertRaises(wrapper.PortError):
            wrapper.parse_ports(TINY, "Other")

    def test_wrapper_text(self):
        text, info = wrapper.make_wrapper("Tiny", wrapper.parse_ports(TINY, "Tiny"))
        self.assertEqual(info, {"input_bits": 10, "output_bits": 6, "wrapper_ff": 22, "clock_ports": ["clock"]})
        for line in ["module timing_wrap_Tiny(", "input  clk,", "input  scan_in,", "output scan_out",
                     "reg [9:0] in_chain;", "in_chain <= {in_chain[8:0], scan_in};", ".clock(clk)",
                     ".reset(in_chain[0])", ".io_a(in_chain[4:1])", ".io_b(in_chain[8:5])", ".io_en(in_chain[9])",
                     ".io_sum(outs[4:0])", ".io_odd(outs[5])", "out_cap <= outs;",
                     "out_fold <= {out_fold[4:0], 1'b0} ^ out_cap;", "assign scan_out = out_fold[5];"]:
            self.assertIn(line, text)
        with self.assertRaises(wrapper.PortError):  # no clock: nothing to time
            wrapper.make_wrapper("Comb", [("input", 2, "a"), ("output", 1, "y")])

    @unittest.skipUnless(shutil.which("yosys"), "yosys not installed")
    def test_wrapper_elaborates(self):
        """The wrapper and the module elaborate together, and every register of the wrapper survives optimisation
        (nothing of the module is cut off: the scan output depends on every output bit)."""
        text, _ = wrapper.make_wrapper("Tiny", wrapper.parse_ports(TINY, "Tiny"))
        with tempfile.TemporaryDirectory() as d:
            for name, body in (("tiny.v", TINY), ("wrap.v", text)):
                with open(os.path.join(d, name), "w") as fh:
                    fh.write(body)
            script = ("read_verilog tiny.v wrap.v; hierarchy -check -top timing_wrap_Tiny; proc; flatten; opt; "
                      "tee -q -o stat.json stat -json")
            subprocess.run(["yosys", "-q", "-p", script], cwd=d, check=True, capture_output=True)
            with open(os.path.join(d, "stat.json")) as fh:
                stat = json.load(fh)
        cells = stat["modules"]["\\timing_wrap_Tiny"]["num_cells_by_type"]
        self.assertIn("$add", cells)  # the module's logic is still there
        self.assertIn("$xor", cells)  # the fold
        # word-level registers: scan chain, capture, fold, and the module's accumulator
        self.assertEqual(sum(n for t, n in cells.items() if "dff" in t), 4)


class SecondPassTest(unittest.TestCase):
    """flow.ecp5_result: which first-pass results are routed again with --tmg-ripup, and what the row then shows."""

    def run_with(self, first, second):
        import flow
        calls = []

        def fake_guarded(design, module, kind, salt, args, runner):
            calls.append((kind, salt))
            return dict(first if kind == "ecp5" else second)
        saved, flow.guarded = flow.guarded, fake_guarded
        try:
            return flow.ecp5_result(None, "M", "salt", None), calls, flow
        finally:
            flow.guarded = saved

    def test_slow_router2_module_gets_second_pass(self):
        first = {"status": "ok", "router": "router2", "fmax_mhz": 96.7, "cached": True, "seconds": {"nextpnr": 1.0},
                 "critical_path": {"start": "a", "end": "b"}}
        second = {"status": "ok", "router": "router2", "fmax_mhz": 102.7, "cached": False, "seconds": {"nextpnr": 2.0}}
        r, calls, flow = self.run_with(first, second)
        self.assertEqual([k for k, _ in calls], ["ecp5", "ecp5r"])
        self.assertEqual(calls[1][1], "salt|104|tmg-ripup")  # its own cache key: 1.08 x 96.7, rounded
        self.assertEqual(r["fmax_mhz"], 102.7)
        self.assertEqual(r["first_pass"]["fmax_mhz"], 96.7)
        self.assertEqual(flow.ecp5_cells(r)[0], "102.7 (2nd pass; 1st 96.7)")
        row = flow.timing_row("M", 1, False, {"cached": True, "seconds": 5}, r)
        self.assertEqual(row["wall_seconds"], 8.0)  # both passes and the 7-series run
        self.assertFalse(row["cached"])

    def test_second_pass_below_the_first_keeps_the_first(self):
        first = {"status": "ok", "router": "router2", "fmax_mhz": 100.6, "cached": True, "seconds": {"nextpnr": 1.0},
                 "critical_path": {"start": "a", "end": "b"}}
        second = {"status": "ok", "router": "router2", "fmax_mhz": 98.5, "cached": False, "seconds": {"nextpnr": 2.0},
                  "critical_path": {"start": "c", "end": "d"}}
        r, calls, flow = self.run_with(first, second)
        self.assertEqual([k for k, _ in calls], ["ecp5", "ecp5r"])
        self.assertEqual(r["fmax_mhz"], 100.6)
        self.assertEqual(r["critical_path"]["start"], "a")
        self.assertEqual(r["second_pass"]["fmax_mhz"], 98.5)
        self.assertEqual(flow.ecp5_cells(r)[0], "100.6 (1st pass; 2nd 98.5)")
        row = flow.timing_row("M", 1, False, {"cached": True, "seconds": 5}, r)
        self.assertEqual(row["wall_seconds"], 8.0)  # both passes and the 7-series run
        self.assertFalse(row["cached"])

    def test_fast_or_router1_or_failed_module_keeps_first_pass(self):
        for first in ({"status": "ok", "router": "router2", "fmax_mhz": 105.0},
                      {"status": "ok", "router": "router1", "fmax_mhz": 100.0},
                      {"status": "does_not_fit", "router": "router2"}):
            r, calls, _ = self.run_with(first, {"status": "ok"})
            self.assertEqual([k for k, _ in calls], ["ecp5"], first)
            self.assertNotIn("first_pass", r)

    def test_second_pass_constraint(self):
        import flow
        self.assertEqual(flow.ripup_freq(87.09), 94.0)   # a little above the first result
        self.assertEqual(flow.ripup_freq(97.02), 105.0)  # 104.8, rounded
        self.assertEqual(flow.ripup_freq(103.1), 105.0)  # never above RIPUP_BELOW_MHZ

    def test_second_pass_routes_the_first_pass_netlist(self):
        import flow
        first = {"status": "ok", "router": "router2", "fmax_mhz": 90.0, "cached": False, "seconds": {}, "key": "k1"}
        seen = {}

        def fake_guarded(design, module, kind, salt, args, runner):
            return dict(first) if kind == "ecp5" else runner(design, module, "w", args, "k2")

        def fake_run(design, module, workdir, args, key, second_pass=None, first_key=None):
            seen.update(key=key, second_pass=second_pass, first_key=first_key)
            return {"status": "ok", "fmax_mhz": 95.0, "seconds": {}}
        saved = flow.guarded, flow.ecp5_run
        flow.guarded, flow.ecp5_run = fake_guarded, fake_run
        try:
            flow.ecp5_result(None, "M", "salt", None)
        finally:
            flow.guarded, flow.ecp5_run = saved
        self.assertEqual(seen, {"key": "k2", "second_pass": 97.0, "first_key": "k1"})
        self.assertTrue(flow.needs_second_pass(first))  # so the first pass kept its netlist for it
        self.assertFalse(flow.needs_second_pass(dict(first, fmax_mhz=105.0)))

    def test_failed_second_pass_keeps_first_and_says_why(self):
        first = {"status": "ok", "router": "router2", "fmax_mhz": 99.0, "cached": True, "seconds": {}}
        r, _, flow = self.run_with(first, {"status": "error", "error": "time limit"})
        self.assertEqual(r["fmax_mhz"], 99.0)
        self.assertEqual(flow.ecp5_cells(r)[0], "99.0 (2nd pass failed: time limit)")
        r, _, flow = self.run_with(first, {"status": "not_run", "error": "no cached result"})
        self.assertEqual(flow.ecp5_cells(r)[0], "99.0 (2nd pass not run)")


if __name__ == "__main__":
    unittest.main(verbosity=1)
