"""Ports of a firtool module and the out-of-context timing wrapper around it.

A stage's ports are thousands of bits wide, far more than any FPGA package has pins. The wrapper gives the module
registers on every side and only three pins (clock, scan input, scan output):

- every input bit of the module is a bit of one serial shift register (the scan chain) fed from `scan_in`, so each
  input is driven straight from a flip-flop;
- every output bit is captured in a register (`out_cap`, a plain flip-flop per bit: the module's output paths end
  there, as they would at the next stage's register) and the captured bits are folded into `scan_out` by a
  shift-and-XOR register (`out_fold[i] <= out_fold[i-1] ^ out_cap[i]`: one 2-input XOR between two registers per
  bit), so no output can be optimised away and the fold never adds a long path.

The `clock` input goes to the wrapper's clock pin; `reset` and every other input come from the chain, so the
place-and-route tool sees every path of the module as register to register.
"""
import re

_HEADER = r"^\s*module\s+%s\s*(?:#\s*\((?:.|\n)*?\)\s*)?\(((?:.|\n)*?)\)\s*;"
_PORT = re.compile(r"^(?:(input|output|inout)\s+)?(?:(?:wire|logic|reg|var)\s+)?(signed\s+)?"
                   r"(?:\[\s*(\d+)\s*:\s*(\d+)\s*\]\s*)?([A-Za-z_]\w*)$")
CLOCK_NAMES = ("clock", "clk")
WRAPPER_VERSION = "1"  # part of every ECP5 cache key: bump when the generated wrapper changes


class PortError(ValueError):
    pass


def parse_ports(text, module):
    """The ANSI port list of `module` in `text`: [(direction, width, name)] in declaration order. A port without a
    direction inherits the previous port's direction and range (firtool writes `input [5:0] a,\\n b,`)."""
    m = re.search(_HEADER % re.escape(module), text, re.M)
    if not m:
        raise PortError(f"module {module}: no ANSI port list found")
    body = re.sub(r"//[^\n]*", "", m.group(1))
    body = re.sub(r"/\*.*?\*/", "", body, flags=re.S)
    ports, direction, width = [], None, 1
    for item in (s.strip() for s in body.split(",")):
        if not item:
            continue
        p = _PORT.match(" ".join(item.split()))
        if not p:
            raise PortError(f"module {module}: cannot parse port declaration '{item}'")
        d, _signed, hi, lo, name = p.groups()
        if d:
            direction = d
            width = abs(int(hi) - int(lo)) + 1 if hi is not None else 1
        elif hi is not None:
            width = abs(int(hi) - int(lo)) + 1
        if direction is None:
            raise PortError(f"module {module}: port {name} has no direction")
        if direction == "inout":
            raise PortError(f"module {module}: inout port {name} is not supported")
        ports.append((direction, width, name))
    return ports


def wrapper_name(module):
    return f"timing_wrap_{module}"


def make_wrapper(module, ports):
    """Verilog of the wrapper around `module` (see the module docstring). Returns (text, info) where info counts the
    scan-chain and capture bits (the flip-flops the wrapper itself adds)."""
    clocks = [n for d, w, n in ports if d == "input" and w == 1 and n in CLOCK_NAMES]
    if not clocks:
        raise PortError(f"module {module}: no clock input (one of {', '.join(CLOCK_NAMES)})")
    ins = [(w, n) for d, w, n in ports if d == "input" and n not in clocks]
    outs = [(w, n) for d, w, n in ports if d == "output"]
    n_in, n_out = sum(w for w, _ in ins), sum(w for w, _ in outs)
    conns = [f"    .{c}(clk)" for c in clocks]
    lines = [f"// Out-of-context timing wrapper of {module}, written by scripts/timing/wrapper.py (version "
             f"{WRAPPER_VERSION}).",
             f"// {n_in} input bits from a scan chain, {n_out} output bits captured and folded into scan_out.",
             f"module {wrapper_name(module)}(", "  input  clk,", "  input  scan_in,", "  output scan_out", ");"]
    if n_in:
        lines.append(f"  reg [{n_in - 1}:0] in_chain;")
        shift = "scan_in" if n_in == 1 else f"{{in_chain[{n_in - 2}:0], scan_in}}"
        lines.append(f"  always @(posedge clk) in_chain <= {shift};")
    pos = 0
    for w, n in ins:
        conns.append(f"    .{n}(in_chain[{pos + w - 1}:{pos}])" if w > 1 else f"    .{n}(in_chain[{pos}])")
        pos += w
    if n_out:
        lines.append(f"  wire [{n_out - 1}:0] outs;")
    pos = 0
    for w, n in outs:
        conns.append(f"    .{n}(outs[{pos + w - 1}:{pos}])" if w > 1 else f"    .{n}(outs[{pos}])")
        pos += w
    lines.append(f"  {module} dut (")
    lines.append(",\n".join(conns))
    lines.append("  );")
    if n_out:
        lines += [f"  reg [{n_out - 1}:0] out_cap;", f"  reg [{n_out - 1}:0] out_fold;",
                  "  always @(posedge clk) begin", "    out_cap <= outs;"]
        shifted = "1'b0" if n_out == 1 else f"{{out_fold[{n_out - 2}:0], 1'b0}}"
        lines += [f"    out_fold <= {shifted} ^ out_cap;", "  end", f"  assign scan_out = out_fold[{n_out - 1}];"]
    else:
        lines.append("  assign scan_out = " + (f"in_chain[{n_in - 1}];" if n_in else "1'b0;"))
    lines += ["endmodule", ""]
    info = {"input_bits": n_in, "output_bits": n_out, "wrapper_ff": n_in + 2 * n_out, "clock_ports": clocks}
    return "\n".join(lines), info
