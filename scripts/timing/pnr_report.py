"""Readers of the tools' reports: nextpnr-ecp5 (--report JSON, else its log), Yosys `sta` and `stat` text."""
import json
import re

# Resources reported per module, with the names nextpnr-ecp5 gives them.
ECP5_RESOURCES = ("TRELLIS_COMB", "TRELLIS_FF", "TRELLIS_RAMW", "DP16KD", "MULT18X18D", "TRELLIS_IO")
# Suffixes Yosys/nextpnr append to a cell name (the net it drives, the primitive it became).
_CELL_SUFFIX = re.compile(r"(_TRELLIS_|_LUT4|_CCU2C|_PFUMX|_L6MUX21|_DP16KD|_MULT18X18D|\$DPRAM|\$|_DPR16X4).*$")


def short_cell(name):
    """A readable name for a nextpnr cell: the wrapper's `dut.` prefix and the mapping suffixes removed
    ('dut.outBits_data_left_TRELLIS_FF_Q_5' -> 'outBits_data_left')."""
    if name.startswith("dut."):
        name = name[4:]
    short = _CELL_SUFFIX.sub("", name)
    return short or name


def _utilisation_percent(util):
    return {k: {"used": v["used"], "available": v["available"],
                "percent": round(100.0 * v["used"] / v["available"], 2) if v["available"] else None}
            for k, v in util.items()}


def parse_nextpnr_json(report):
    """From nextpnr's --report JSON (a dict): fmax of the clock (the one register-to-register domain), the critical
    path of that clock (start and end cell and pin, its delay split into logic and routing), and utilisation."""
    out = {"source": "nextpnr --report JSON"}
    fmax = report.get("fmax", {})
    if fmax:
        # The wrapper has one clock pin, so one clock; were there several, the slowest is the module's fmax.
        clock = min(fmax, key=lambda c: fmax[c]["achieved"])
        out["clock"] = clock
        out["fmax_mhz"] = round(fmax[clock]["achieved"], 2)
        out["target_mhz"] = fmax[clock].get("constraint")
    paths = [p for p in report.get("critical_paths", [])
             if not p.get("from", "").startswith("<async>") and not p.get("to", "").startswith("<async>")]
    if paths:
        p = paths[0]["path"]
        first, last = p[0], p[-1]
        out["critical_path"] = {
            "from": f"{first['from']['cell']}.{first['from']['port']}",
            "to": f"{last['to']['cell']}.{last['to']['port']}",
            "start": short_cell(first["from"]["cell"]), "end": short_cell(last["to"]["cell"]),
            "delay_ns": round(sum(e["delay"] for e in p), 3),
            "logic_ns": round(sum(e["delay"] for e in p if e["type"] != "routing"), 3),
            "routing_ns": round(sum(e["delay"] for e in p if e["type"] == "routing"), 3),
            "steps": len([e for e in p if e["type"] == "logic"]),
        }
    out["utilisation"] = _utilisation_percent(report.get("utilization", {}))
    return out


_UTIL_LINE = re.compile(r"^Info:\s+(\w+):\s+(\d+)/\s*(\d+)\s+(\d+)%\s*$", re.M)
_FMAX_LINE = re.compile(r"Max frequency for clock '([^']+)': ([\d.]+) MHz \((PASS|FAIL) at ([\d.]+) MHz\)")


def parse_nextpnr_log(text):
    """The same facts from nextpnr's log, for when no JSON report was written (a failed run). Utilisation is the
    last `Device utilisation:` block (printed after packing, before placement, so an over-full design has one); fmax
    is the last `Max frequency` line (post-route); the critical path is the last posedge -> posedge report."""
    out = {"source": "nextpnr log"}
    blocks = text.split("Device utilisation:")
    if len(blocks) > 1:
        util = {}
        for name, used, avail, _pct in _UTIL_LINE.findall(blocks[-1].split("\n\n")[0]):
            util[name] = {"used": int(used), "available": int(avail)}
        out["utilisation"] = _utilisation_percent(util)
    fm = _FMAX_LINE.findall(text)
    if fm:
        clock, mhz, _verdict, target = fm[-1]
        out.update(clock=clock, fmax_mhz=float(mhz), target_mhz=float(target))
    reports = re.split(r"Critical path report for clock '[^']+' \(posedge -> posedge\):", text)
    if len(reports) > 1:
        body = reports[-1].split("Critical path report for")[0]
        rows = re.findall(r"^Info:\s+(clk-to-q|routing|logic|setup)\s+([\d.-]+)\s+([\d.-]+)\s+(?:Source|Net)\s+(\S+)",
                          body, re.M)
        sinks = re.findall(r"^Info:\s+Sink (\S+)", body, re.M)
        if rows:
            start = rows[0][3].rsplit(".", 1)[0]
            end = sinks[-1] if sinks else rows[-1][3]
            out["critical_path"] = {
                "from": rows[0][3], "to": end, "start": short_cell(start), "end": short_cell(end.rsplit(".", 1)[0]),
                "delay_ns": float(rows[-1][2]),
                "logic_ns": round(sum(float(r[1]) for r in rows if r[0] != "routing"), 3),
                "routing_ns": round(sum(float(r[1]) for r in rows if r[0] == "routing"), 3),
                "steps": len([r for r in rows if r[0] == "logic"])}
    errors = re.findall(r"^ERROR: (.*)$", text, re.M)
    if errors:
        out["error"] = errors[0].strip()
    return out


def overfull(utilisation):
    """The resources a design asks for beyond the device (used > available)."""
    return {k: v for k, v in (utilisation or {}).items() if v["available"] is not None and v["used"] > v["available"]}


def does_not_fit(parsed):
    """True when nextpnr failed because the design needs more of some resource than the device has."""
    if overfull(parsed.get("utilisation")):
        return True
    err = parsed.get("error", "")
    return bool(re.search(r"no BELs remaining|Unable to find legal placement|utilisation limit|too many", err))


def parse_sta(text):
    """Yosys `sta` output: the latest arrival time (ps) and its path [{ps, cell, type, pins, net}], start first.
    Arrival = the start register's clock-to-out + every cell's pin-to-pin delay + the end pin's setup time, from
    the `specify` blocks of the cell library; a path from a module input starts at 0. The path ends at a cell pin,
    at a module output (`<primary output>`) or, when `sta` cannot tell, at `<unknown>`."""
    m = re.search(r"Latest arrival time in '[^']*' is (\d+):\n", text)
    if not m:
        return None
    steps = []
    for line in text[m.end():].splitlines():
        if not line.strip():
            break
        if line.startswith("Warning:"):
            continue
        s = re.match(r"^\s+(\d+)\s+(\S+)\s+\((\S+?)\.(\S+)\)\s*$", line)
        if s:
            steps.append({"ps": int(s.group(1)), "cell": s.group(2), "type": s.group(3), "pins": s.group(4)})
            continue
        s = re.match(r"^\s+(\d+)\s+(\S+(?: \[\d+\])?)\s+\(<primary input>\)\s*$", line)
        if s:
            steps.append({"ps": int(s.group(1)), "cell": None, "type": "input", "pins": None,
                          "net": s.group(2).lstrip("\\")})
            continue
        s = re.match(r"^\s+(\d+)\s+\(<(primary output|unknown)>\)\s*$", line)
        if s:
            steps.append({"ps": int(s.group(1)), "cell": None,
                          "type": "output" if s.group(2) == "primary output" else "unknown", "pins": None})
            continue
        if steps and "net" not in steps[-1]:
            steps[-1]["net"] = line.strip().lstrip("\\")
    steps.reverse()
    if not steps:
        return None
    return {"arrival_ps": int(m.group(1)), "steps": steps,
            "warnings": sorted(set(re.findall(r"^Warning: (.*)$", text, re.M)))}


def parse_cell_counts(stat_text):
    """Cell counts of the last module section of Yosys `stat` (any Yosys version: `  N  TYPE` or `TYPE  N`)."""
    sections = re.split(r"^=== .* ===\s*$", stat_text, flags=re.M)
    counts = {}
    for line in sections[-1].splitlines():
        a = re.match(r"^\s+(\d+)\s+(\$?[A-Za-z_][\w$]*)\s*$", line)
        b = re.match(r"^\s+(\$?[A-Za-z_][\w$]*)\s+(\d+)\s*$", line)
        if a and a.group(2) not in ("wires", "cells", "ports", "memories", "processes"):
            counts[a.group(2)] = counts.get(a.group(2), 0) + int(a.group(1))
        elif b and not line.strip().startswith("Number"):
            counts[b.group(1)] = counts.get(b.group(1), 0) + int(b.group(2))
    return counts


def load_json(path):
    with open(path) as fh:
        return json.load(fh)


_CLOCK_ARC = re.compile(r"^(C|CLK|CLKARDCLK|CLKBWRCLK|WCLK|CLKA|CLKB)->")


def sta_ends(parsed):
    """Start and end of a parsed `sta` path. A path that starts at a register shows the clock input first and then
    the register's clock-to-out arc; one that starts at a module input shows only that input. Each step's `net` is
    the net at that cell's input pin, so the net a start register drives is the next step's `net`."""
    steps = parsed["steps"]
    if len(steps) >= 2 and steps[0]["type"] == "input" and _CLOCK_ARC.match(steps[1]["pins"] or ""):
        start = {"kind": "register", "cell": steps[1]["cell"], "type": steps[1]["type"],
                 "net": steps[2].get("net") if len(steps) > 2 else None}
    else:
        start = {"kind": "input", "net": steps[0].get("net")}
    last = steps[-1]
    end = {"cell": last["cell"], "type": last["type"], "pin": last["pins"], "net": last.get("net")}
    return start, end
