"""Tests of the synthesis flow: hand-made netlists, stat text and Verilog trees with hand-counted answers.
Run: python3 -m unittest discover -s scripts/synth -v   (the end-to-end case needs yosys, ~1 min)."""
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
import flow  # noqa: E402
import netlist_depth  # noqa: E402
import verilog_modules  # noqa: E402

LUT_DIRS = {"I0": "input", "I1": "input", "O": "output"}
FF_DIRS = {"C": "input", "CE": "input", "R": "input", "D": "input", "Q": "output"}
CARRY_DIRS = {"CI": "input", "S": "input", "DI": "input", "O": "output", "CO": "output"}


def cell(typ, dirs, **conns):
    return {"type": typ, "port_directions": dirs, "connections": {p: list(b) for p, b in conns.items()}}


def netlist(cells, ports=None):
    return {"modules": {"top": {"attributes": {"top": 1}, "ports": ports or {}, "cells": cells,
                                "netnames": {"q0": {"hide_name": 0, "bits": [10]}, "x": {"hide_name": 1, "bits": [11]},
                                             "sum": {"hide_name": 0, "bits": [13]}}}}}


class DepthTest(unittest.TestCase):
    def test_levels_between_registers(self):
        # ff0.Q(10) -> lut_a(11) -> carry(12) -> lut_b(13) -> ff1.D ; short path ff0.Q -> lut_c(14) -> ff2.D
        n = netlist({
            "ff0": cell("FDRE", FF_DIRS, C=[2], CE=["1"], R=["0"], D=[13], Q=[10]),
            "lut_a": cell("LUT2", LUT_DIRS, I0=[10], I1=[3], O=[11]),
            "carry": cell("CARRY4", CARRY_DIRS, CI=["0"], S=[11, 11, 3, 3], DI=["0", "0", "0", "0"],
                          O=[12, 20, 21, 22], CO=[23, 24, 25, 26]),
            "lut_b": cell("LUT2", LUT_DIRS, I0=[12], I1=[10], O=[13]),
            "lut_c": cell("LUT2", LUT_DIRS, I0=[10], I1=[10], O=[14]),
            "ff1": cell("FDRE", FF_DIRS, C=[2], CE=["1"], R=["0"], D=[13], Q=[15]),
            "ff2": cell("FDRE", FF_DIRS, C=[2], CE=["1"], R=["0"], D=[14], Q=[16]),
        })
        r = netlist_depth.longest_path(n)
        self.assertEqual((r["lut_levels"], r["logic_levels"], r["loops"]), (2, 3, 0))
        self.assertEqual(r["path"], ["from q0", "LUT2 -> (internal net)", "CARRY4 -> (internal net)", "LUT2 -> sum",
                                     "into FDRE q0"])

    def test_block_ram_and_dsp_cut_paths(self):
        n = netlist({
            "l1": cell("LUT2", LUT_DIRS, I0=[1], I1=[1], O=[2]),
            "ram": cell("RAMB18E1", {"ADDRARDADDR": "input", "DOADO": "output"}, ADDRARDADDR=[2], DOADO=[3]),
            "l2": cell("LUT2", LUT_DIRS, I0=[3], I1=[3], O=[4]),
            "l3": cell("LUT2", LUT_DIRS, I0=[4], I1=[4], O=[5]),
        })
        self.assertEqual(netlist_depth.longest_path(n)["lut_levels"], 2)

    def test_lut_ram_write_pins_end_a_path(self):
        # l1 -> ram.DIA (written at the clock edge: the path ends) ; l2 -> ram.ADDRA -> DOA -> l3 (2 levels + RAM)
        ram_dirs = {"ADDRA": "input", "DIA": "input", "WE": "input", "WCLK": "input", "DOA": "output"}
        n = netlist({
            "l0": cell("LUT2", LUT_DIRS, I0=[1], I1=[1], O=[2]),
            "l1": cell("LUT2", LUT_DIRS, I0=[2], I1=[2], O=[3]),
            "l2": cell("LUT2", LUT_DIRS, I0=[1], I1=[1], O=[4]),
            "ram": cell("RAM64M", ram_dirs, ADDRA=[4], DIA=[3], WE=[3], WCLK=[9], DOA=[5]),
            "l3": cell("LUT2", LUT_DIRS, I0=[5], I1=[5], O=[6]),
        })
        r = netlist_depth.longest_path(n)
        self.assertEqual(r["lut_levels"], 3)  # l2 -> ram -> l3, not l0 -> l1 -> ram -> l3
        self.assertEqual(r["path"][0], "LUT2 -> (internal net)")

    def test_loop_is_cut_and_counted(self):
        n = netlist({"a": cell("LUT2", LUT_DIRS, I0=[2], I1=[1], O=[3]),
                     "b": cell("LUT2", LUT_DIRS, I0=[3], I1=[1], O=[2])})
        r = netlist_depth.longest_path(n)
        self.assertEqual((r["lut_levels"], r["loops"]), (2, 1))

    def test_unmapped_cell_is_an_error(self):
        n = netlist({"g": cell("$and", {"A": "input", "B": "input", "Y": "output"}, A=[1], B=[2], Y=[3])})
        with self.assertRaises(ValueError):
            netlist_depth.longest_path(n)


STAT = """
=== IElas ===

   Number of wires:                 10
   Number of cells:                 12
     CARRY4                          2
     Descriptor                      1
     FDRE                            5
     FDSE                            2
     LUT2                            3
     LUT6                            4
     RAM64M                          2
     RAMB18E1                        3
     RAMB36E1                        1
     SRLC32E                         1

=== other ===

   Number of cells:                  1
     LUT1                          100
"""


class StatTest(unittest.TestCase):
    def test_resources_from_stat(self):
        counts = flow.parse_stat(STAT, "IElas")
        self.assertEqual(counts["LUT6"], 4)
        self.assertNotIn("LUT1", counts)  # another module's section
        r = flow.resources_of({t: n for t, n in counts.items() if t != "Descriptor"})
        self.assertEqual((r["LUT"], r["FF"], r["RAMB36E1"], r["RAMB18E1"], r["BRAM36eq"], r["LUTRAM_sites"],
                          r["CARRY4"]), (7, 7, 1, 3, 2.5, 9, 2))

    def test_missing_module(self):
        with self.assertRaises(flow.FlowError):
            flow.parse_stat(STAT, "Nope")

    def test_memory_mapping_log(self):
        log = ("mapping memory IElas.descriptor.lines_ext.Memory via $__XILINX_BLOCKRAM_SDP_\n"
               "mapping memory IElas.q.ram_ext.Memory via $__XILINX_LUTRAM_SDP_\n"
               "using FF mapping for memory IElas.tiny.Memory\n")
        self.assertEqual(flow.parse_memory_mapping(log), {
            "descriptor.lines_ext.Memory": ("BRAM", "$__XILINX_BLOCKRAM_SDP_"),
            "q.ram_ext.Memory": ("LUTRAM", "$__XILINX_LUTRAM_SDP_"), "tiny.Memory": ("FF", "memory_map")})


# Read-first block RAM (the read register samples the old word): no transparency logic, so the count is exact.
MEM_SYNC = """module mem_1024x16(input [9:0] R0_addr, input R0_en, R0_clk, output [15:0] R0_data,
  input [9:0] W0_addr, input W0_en, W0_clk, input [15:0] W0_data);
  reg [15:0] Memory[0:1023];
  reg [15:0] _R0_data_r;
  always @(posedge R0_clk) _R0_data_r <= Memory[R0_addr];
  always @(posedge W0_clk) if (W0_en) Memory[W0_addr] <= W0_data;
  assign R0_data = _R0_data_r;
endmodule
"""
STAGE = """module Stage(input clock, input [9:0] waddr, input [9:0] raddr, input [15:0] wdata, input we,
  output [15:0] out);
  mem_1024x16 m_ext (
    .R0_addr(raddr), .R0_en(1'h1), .R0_clk(clock), .R0_data(out),
    .W0_addr(waddr), .W0_en(we), .W0_clk(clock), .W0_data(wdata)
  );
endmodule
"""
TOP = """module Top(input clock, input [9:0] waddr, input [9:0] raddr, input [15:0] wdata, input we,
  output [15:0] out);
  wire [15:0] _a_out;
  wire [15:0] _b_out;
  wire [15:0] _own_R0_data;
  Stage a (.clock(clock), .waddr(waddr), .raddr(raddr), .wdata(wdata), .we(we), .out(_a_out));
  Stage b (.clock(clock), .waddr(waddr), .raddr(raddr), .wdata(~wdata), .we(we), .out(_b_out));
  mem_1024x16 own_ext (
    .R0_addr(raddr), .R0_en(1'h1), .R0_clk(clock), .R0_data(_own_R0_data),
    .W0_addr(waddr), .W0_en(we), .W0_clk(clock), .W0_data({wdata[7:0], wdata[15:8]})
  );
  reg [15:0] out_r;
  always @(posedge clock) out_r <= _a_out ^ _b_out ^ _own_R0_data;
  assign out = out_r;
endmodule
"""


class BramCheckTest(unittest.TestCase):
    def test_only_sync_read_memories_must_be_bram(self):
        mems = [{"path": "a", "sync_read": True, "mapped": "BRAM"},
                {"path": "b", "sync_read": True, "mapped": "LUTRAM"},
                {"path": "c", "sync_read": False, "mapped": "FF"}]
        b = flow.bram_check({"memories": mems})
        self.assertEqual((b["sync_read_memories"], b["in_bram"], [m["path"] for m in b["not_in_bram"]], b["pass"]),
                         (2, 1, ["b"], False))

    def test_small_memories_are_not_line_buffers(self):
        mems = [{"path": "row", "sync_read": True, "mapped": "BRAM", "depth": 1242, "width": 96},
                {"path": "shallow", "sync_read": True, "mapped": "LUTRAM", "depth": 64, "width": 128},
                {"path": "small", "sync_read": True, "mapped": "LUTRAM", "depth": 128, "width": 5},
                {"path": "big", "sync_read": True, "mapped": "LUTRAM", "depth": 1242, "width": 9}]
        b = flow.bram_check({"memories": mems})
        self.assertEqual((b["sync_read_memories"], b["in_bram"], [m["path"] for m in b["not_in_bram"]], b["pass"]),
                         (2, 1, ["big"], False))


TINY_SYNC = """module Tiny(input clock, input [3:0] waddr, input [3:0] raddr, input [7:0] wdata, input we,
  output [7:0] out);
  reg [7:0] Memory[0:15];
  reg [3:0] _R0_addr_d0;
  always @(posedge clock) begin
    _R0_addr_d0 <= raddr;
    if (we) Memory[waddr] <= wdata;
  end
  assign out = Memory[_R0_addr_d0];
endmodule
"""


class DesignTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="synth-test-")
        for name, text in (("mem_1024x16.sv", MEM_SYNC), ("Stage.sv", STAGE), ("Top.sv", TOP)):
            with open(os.path.join(self.dir, name), "w") as fh:
                fh.write(text)

    def tearDown(self):
        shutil.rmtree(self.dir)

    def test_hierarchy_and_memories(self):
        d = verilog_modules.Design(self.dir)
        self.assertEqual(d.children["Top"], {"Stage": 2, "mem_1024x16": 1})
        self.assertEqual(d.stages("Top"), {"Stage": 2})  # the top's own memory stays with its user
        self.assertEqual(d.closure("Stage"), ["Stage", "mem_1024x16"])
        paths = [(m["path"], m["width"], m["depth"], m["sync_read"]) for m in d.memory_instances("Top")]
        self.assertEqual(paths, [("a.m_ext.Memory", 16, 1024, True), ("b.m_ext.Memory", 16, 1024, True),
                                 ("own_ext.Memory", 16, 1024, True)])
        self.assertEqual([m["path"] for m in d.memory_instances("Top", skip={"Stage"})], ["own_ext.Memory"])

    def test_units_follow_the_hierarchy(self):
        # Top -> 2 x Holder -> {3 x Leaf, 4 x Rep} each: Rep (8 instances) is one unit counted 8 times under the
        # whole-top instance names; Leaf (6 < REPLICATED_MIN) is synthesised inside Holder.
        self.assertEqual(flow.REPLICATED_MIN, 8)
        with open(os.path.join(self.dir, "Stage.sv"), "a") as fh:
            fh.write("module Holder(input clock);\n" + "".join(f"  Leaf {n} (.clock(clock));\n" for n in "xyz") +
                     "".join(f"  Rep r{i} (.clock(clock));\n" for i in range(4)) + "endmodule\n"
                     "module Leaf(input clock);\nendmodule\nmodule Rep(input clock);\nendmodule\n")
        with open(os.path.join(self.dir, "Top.sv")) as fh:
            top = fh.read()
        with open(os.path.join(self.dir, "Top.sv"), "w") as fh:
            fh.write(top.replace("Stage a (", "Holder h0 (.clock(clock));\n  Holder h1 (.clock(clock));\n  Stage a ("))
        u = flow.units(verilog_modules.Design(self.dir), "Top")
        self.assertEqual({k: (sorted(v[0]) if v[0] is not None else None, v[1]) for k, v in u.items()}, {
            ("Top", "glue"): (["Holder", "Stage"], [""]),
            ("Holder", "glue"): (["Rep"], ["h0.", "h1."]),
            ("Rep", "stage"): (None, [f"h{h}.r{i}." for h in range(2) for i in range(4)]),
            ("Stage", "stage"): (None, ["a.", "b."])})

    def test_hash_follows_submodules_only(self):
        d = verilog_modules.Design(self.dir)
        stage, top = d.content_hash("Stage", "s"), d.content_hash("Top", "s")
        with open(os.path.join(self.dir, "Top.sv"), "a") as fh:
            fh.write("// top edited\n")
        d2 = verilog_modules.Design(self.dir)
        self.assertEqual(d2.content_hash("Stage", "s"), stage)
        self.assertNotEqual(d2.content_hash("Top", "s"), top)
        with open(os.path.join(self.dir, "mem_1024x16.sv"), "a") as fh:
            fh.write("// memory edited\n")
        self.assertNotEqual(verilog_modules.Design(self.dir).content_hash("Stage", "s"), stage)
        self.assertNotEqual(d.content_hash("Stage", "other salt"), stage)

    def test_cli_errors(self):
        script = os.path.join(HERE, "..", "synth.sh")
        r = subprocess.run([script], capture_output=True, text=True)
        self.assertEqual(r.returncode, 2)
        r = subprocess.run([script, "nope", os.path.join(self.dir, "missing")], capture_output=True, text=True)
        self.assertEqual(r.returncode, 1)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1)

    @unittest.skipUnless(shutil.which("yosys"), "yosys not installed")
    def test_yosys_error_is_one_line(self):
        with open(os.path.join(self.dir, "Top.sv"), "a") as fh:
            fh.write("module Broken(input a;\nendmodule\n")
        env = dict(os.environ, SYNTH_OUT=os.path.join(self.dir, "out"), SYNTH_TOP="Top")
        r = subprocess.run([os.path.join(HERE, "..", "synth.sh"), "t", self.dir], capture_output=True, text=True,
                           env=env)
        self.assertEqual(r.returncode, 1)
        self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
        self.assertIn("syntax error", r.stderr)

    @unittest.skipUnless(shutil.which("yosys"), "yosys not installed")
    def test_strict_fails_on_a_line_buffer_outside_bram(self):
        # 16 x 8 bits: Yosys puts a memory this small in LUT-RAM, so the line-buffer check must fail.
        tiny = os.path.join(self.dir, "tiny")
        os.makedirs(tiny)
        with open(os.path.join(tiny, "Tiny.sv"), "w") as fh:
            fh.write(TINY_SYNC)
        env = dict(os.environ, SYNTH_OUT=os.path.join(self.dir, "out"), SYNTH_TOP="Tiny", SYNTH_STRICT="1",
                   SYNTH_LINEBUF_MIN_DEPTH="0", SYNTH_LINEBUF_MIN_BITS="0")  # count every SyncReadMem
        r = subprocess.run([os.path.join(HERE, "..", "synth.sh"), "t", tiny], capture_output=True, text=True, env=env)
        self.assertEqual(r.returncode, 3, r.stdout + r.stderr)
        with open(os.path.join(self.dir, "out", "resources.json")) as fh:
            report = json.load(fh)
        self.assertEqual([(m["path"], m["sync_read"], m["mapped"]) for m in report["top"]["memories"]],
                         [("Memory", True, "LUTRAM")])
        self.assertFalse(report["bram_check"]["pass"])

    @unittest.skipUnless(shutil.which("yosys"), "yosys not installed")
    def test_end_to_end_top_and_modules(self):
        # Hand count: each 1024x16 RAM (one per Stage, one in the top) = one RAMB18E1 (1K x 18) holding its own
        # read register. The top registers the XOR of the three words: 16 LUT3, 16 FDRE, 1 LUT level.
        out, cache = os.path.join(self.dir, "out"), os.path.join(self.dir, "cache")
        env = dict(os.environ, SYNTH_MODE="both", SYNTH_OUT=out, SYNTH_CACHE=cache)
        cmd = [os.path.join(HERE, "..", "synth.sh"), "t", self.dir]
        runs = []
        for _ in range(2):
            r = subprocess.run(cmd, capture_output=True, text=True,
                               env=dict(env, SYNTH_TOP="Top"))
            self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
            with open(os.path.join(out, "resources.json")) as fh:
                runs.append(json.load(fh))
        first, second = runs
        for method in ("top", "modules"):
            res = first[method]["resources"]
            self.assertEqual((res["RAMB18E1"], res["RAMB36E1"], res["FF"], res["LUT"], res["BRAM36eq"]),
                             (3, 0, 16, 16, 1.5), method)
            self.assertEqual([m["mapped"] for m in first[method]["memories"]], ["BRAM"] * 3, method)
        self.assertEqual(first["top"]["lut_levels"], 1)
        self.assertEqual(first["modules"]["lut_levels"], 1)
        self.assertEqual(first["bram_check"], {"sync_read_memories": 3, "in_bram": 3, "not_in_bram": [],
                                               "pass": True})
        self.assertTrue(first["comparison"]["agree"])
        self.assertEqual([(m["module"], m["instances"], m["cached"]) for m in first["modules"]["modules"]],
                         [("Stage", 2, False), ("Top", 1, False)])
        self.assertEqual([m["cached"] for m in second["modules"]["modules"]], [True, True])
        self.assertEqual(second["modules"]["resources"], first["modules"]["resources"])


if __name__ == "__main__":
    unittest.main()
