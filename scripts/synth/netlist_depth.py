"""Longest combinational path of a flattened, Xilinx-mapped Yosys JSON netlist, in LUT levels.

Yosys' `ltp -noff` only skips Yosys' internal FF cells, not FDRE & co., so after synth_xilinx it walks through
flip-flops (and reports false loops). Here paths start at module inputs and at outputs of clocked primitives
(FD*, RAMB*, DSP48*) and end at their inputs and at module outputs; each LUT1..LUT6 and each LUT-RAM/SRL read
counts one level. CARRY4 and MUXF7/F8 count zero LUT levels but are followed; `logic_levels` counts them too
(one each, as vendor timing reports do). The DSP48E1 is treated as fully registered (a bound, not a guarantee).
A LUT-RAM or SRL reads combinationally only from its address pins (ADDRA..D, A*, DPRA*): its data, write-enable and
clock pins are written at the clock edge, so a path into them ends there, as at a flip-flop's D.
"""
import json
import re

LUT_LIKE = re.compile(r"^(LUT[1-6]|RAM\d+M|RAM\d+X1[SD]|SRL16E|SRLC32E|SRLC16E)$")
PASS_THROUGH_LOGIC = re.compile(r"^(CARRY4|CARRY8|MUXF[789])$")
TRANSPARENT = re.compile(r"^(INV|BUF|IBUF|OBUF|BUFG|IBUFG|OBUFT)$")
SEQUENTIAL = re.compile(r"^(FD[A-Z]*|LD[A-Z]*|RAMB.*|DSP48.*|URAM.*|FIFO.*)$")
# Outputs of LUT-RAM/SRL cells by name, in case the netlist lacks port_directions.
# The pins of a LUT-RAM/SRL whose value reaches its outputs in the same cycle (the read address).
LUTRAM_READ_PINS = re.compile(r"^(ADDR[A-H]|A\d*|DPRA\d*)$")
OUTPUT_NAMES = re.compile(r"^(O|O\d|Q|Q\d*|CO|DO\w*|SPO|DPO|Y|P|PCOUT|ACOUT|BCOUT|CARRYCASCOUT|MULTSIGNOUT|O[A-D])$")


def _weights(cell_type):
    """(LUT levels, logic levels) a cell adds to a path, or None for a path boundary."""
    if SEQUENTIAL.match(cell_type):
        return None
    if LUT_LIKE.match(cell_type):
        return (1, 1)
    if PASS_THROUGH_LOGIC.match(cell_type):
        return (0, 1)
    if TRANSPARENT.match(cell_type):
        return (0, 0)
    if cell_type.startswith("$"):
        raise ValueError(f"unmapped Yosys cell {cell_type} in the netlist (synthesis incomplete?)")
    return None  # an unknown primitive or a blackbox: treat as a register boundary


def longest_path(netlist, top=None):
    """Returns dict(lut_levels, logic_levels, path=[cell names from start to end], loops=count)."""
    modules = netlist["modules"]
    if top is None:
        tops = [n for n, m in modules.items() if m.get("attributes", {}).get("top")]
        top = tops[0] if tops else next(iter(modules))
    cells = modules[top].get("cells", {})
    driver = {}  # net bit -> cell name (only combinational cells matter as predecessors)
    inputs = {}
    weight = {}
    for name, c in cells.items():
        w = _weights(c["type"])
        dirs = c.get("port_directions", {})
        ins = []
        lutram = w is not None and LUT_LIKE.match(c["type"]) and not c["type"].startswith("LUT")
        for port, bits in c["connections"].items():
            d = dirs.get(port) or ("output" if OUTPUT_NAMES.match(port) else "input")
            for b in bits:
                if isinstance(b, str):
                    continue  # constant
                if d == "output":
                    if w is not None:
                        driver[b] = name
                elif not lutram or LUTRAM_READ_PINS.match(port):
                    ins.append(b)
        if w is not None:
            weight[name] = w
            inputs[name] = ins
    best = {}  # cell -> (lut, logic, predecessor)
    state = {}  # 1 = on the stack, 2 = done
    loops = 0
    for root in weight:
        if state.get(root) == 2:
            continue
        stack = [(root, iter(set(driver[b] for b in inputs[root] if b in driver)))]
        state[root] = 1
        while stack:
            node, it = stack[-1]
            advanced = False
            for pred in it:
                s = state.get(pred)
                if s == 1:
                    loops += 1  # a combinational loop (or a cell-level false loop): cut it here
                    continue
                if s is None:
                    state[pred] = 1
                    stack.append((pred, iter(set(driver[b] for b in inputs[pred] if b in driver))))
                    advanced = True
                    break
            if advanced:
                continue
            stack.pop()
            lut, logic, via = 0, 0, None
            for pred in set(driver[b] for b in inputs[node] if b in driver):
                if state.get(pred) == 2 and best[pred][:2] > (lut, logic):
                    lut, logic, via = best[pred][0], best[pred][1], pred
            w = weight[node]
            best[node] = (lut + w[0], logic + w[1], via)
            state[node] = 2
    if not best:
        return {"lut_levels": 0, "logic_levels": 0, "path": [], "loops": loops}
    end = max(best, key=lambda n: best[n][:2])
    path, n = [], end
    while n is not None:
        path.append(n)
        n = best[n][2]
    path.reverse()
    names = _bit_names(modules[top])

    def outputs(n):
        return [b for bits in cells[n]["connections"].values() for b in bits
                if not isinstance(b, str) and driver.get(b) == n]

    def label(n):
        shown = [names[b] for b in outputs(n) if b in names]
        return f"{cells[n]['type']} -> {shown[0] if shown else '(internal net)'}"
    start = [names[b] for b in inputs[path[0]] if b in names and b not in driver]
    last = set(outputs(end))
    sinks = [f"{c['type']} {names.get(_output_bit(c), n)}" for n, c in cells.items() if n not in weight and any(
        b in last for p, bits in c["connections"].items() if c.get("port_directions", {}).get(p) != "output"
        for b in bits)]
    sinks += [f"output {p}" for p, info in modules[top].get("ports", {}).items()
              if info.get("direction") == "output" and any(b in last for b in info["bits"])]
    steps = [label(n) for n in path if weight[n] != (0, 0)]
    return {"lut_levels": best[end][0], "logic_levels": best[end][1],
            "path": ([f"from {start[0]}"] if start else []) + steps + ([f"into {sinks[0]}"] if sinks else []),
            "loops": loops}


def _output_bit(c):
    """The first output bit of a cell (a flip-flop's Q names the register)."""
    for p, bits in c["connections"].items():
        if c.get("port_directions", {}).get(p) == "output":
            for b in bits:
                if not isinstance(b, str):
                    return b
    return None


def _bit_names(module):
    """Net bit -> name from the source; Yosys marks the names it generated with hide_name."""
    names = {}
    for net, info in module.get("netnames", {}).items():
        if not info.get("hide_name", 0):
            bits = info["bits"]
            for i, b in enumerate(bits):
                if not isinstance(b, str):
                    names[b] = net if len(bits) == 1 else f"{net}[{i}]"
    return names


def longest_path_file(path, top=None):
    with open(path) as fh:
        return longest_path(json.load(fh), top)
