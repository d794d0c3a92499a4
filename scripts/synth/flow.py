#!/usr/bin/env python3
"""Open-source resource flow: Yosys synth_xilinx (xc7) on the IElas top, or stage by stage with a content cache.

usage: flow.py --config NAME --verilog DIR --out DIR [--mode top|modules|both] [--cache DIR] [--top IElas]
               [--timeout S] [--mem-mb MB] [--jobs N] [--strict]
Writes OUT/resources.json and OUT/resources.md and prints the table. docs/synthesis.md explains the numbers.
"""
import argparse
import concurrent.futures
import fcntl
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import netlist_depth  # noqa: E402
import verilog_modules  # noqa: E402

# Bump when anything below changes what a cached result means (Yosys options, parsing, depth rules).
FLOW_VERSION = "3"  # 2: units by hierarchy (a submodule of a stage is its own unit); 3: LUT-RAM write pins end paths
SYNTH_BASE = "synth_xilinx -family xc7 -flatten -noiopad -noclkbuf"
# LUT mapper. Default lut6: classic ABC without MUXF7/F8 "wide LUTs". With wide LUTs, ABC's choices depend on the
# surrounding netlist, so a stage alone and the same stage in the flattened top differed by 5 % in LUTs (small);
# -abc9 agrees best but Yosys 0.23's ABC9_OPS aborts on the tsukuba Descriptor (YosysHQ/yosys#3384).
MAPPERS = {"lut6": " -nowidelut", "widelut": "", "abc9": " -abc9"}
SYNTH_CMD = SYNTH_BASE + MAPPERS["lut6"]
PAPER = {"LUT": 144.8e3, "FF": 74.6e3, "BRAM36eq": 469.5}  # iELAS paper, whole accelerator at 1242x375

# LUT-RAM/SRL primitives and how many LUT sites each uses (7-series).
LUTRAM_SITES = {"RAM32M": 4, "RAM64M": 4, "RAM32X1D": 2, "RAM64X1D": 2, "RAM128X1D": 4, "RAM256X1S": 4,
                "RAM32X1S": 1, "RAM64X1S": 1, "RAM128X1S": 2, "SRL16E": 1, "SRLC32E": 1, "SRLC16E": 1}


class FlowError(Exception):
    pass


def yosys_version():
    try:
        out = subprocess.run(["yosys", "-V"], capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError) as e:
        raise FlowError(f"yosys not runnable ({e}); run `make deps-synth`")
    return out


def parse_stat(text, module):
    """Cell counts of `module` from Yosys `stat` output."""
    section = re.search(r"^=== %s ===\s*$(.*?)(?=^=== |\Z)" % re.escape(module), text, re.M | re.S)
    if not section:
        raise FlowError(f"no stat section for module {module}")
    cells = re.search(r"Number of cells:\s+\d+\s*\n((?:\s+\S+\s+\d+\s*\n)*)", section.group(1))
    counts = {}
    if cells:
        for typ, n in re.findall(r"^\s+(\S+)\s+(\d+)\s*$", cells.group(1), re.M):
            counts[typ] = counts.get(typ, 0) + int(n)
    return counts


def resources_of(counts):
    """The resource table from cell counts. LUT = LUT1..LUT6 only; LUT-RAM/SRL sites are reported apart."""
    lut = sum(n for t, n in counts.items() if re.fullmatch(r"LUT[1-6]", t))
    ff = sum(n for t, n in counts.items() if t.startswith("FD"))
    lutram = sum(n * LUTRAM_SITES[t] for t, n in counts.items() if t in LUTRAM_SITES)
    r36, r18 = counts.get("RAMB36E1", 0), counts.get("RAMB18E1", 0)
    return {"LUT": lut, "FF": ff, "RAMB36E1": r36, "RAMB18E1": r18, "DSP48E1": counts.get("DSP48E1", 0),
            "BRAM36eq": r36 + r18 / 2, "LUTRAM_sites": lutram, "CARRY4": counts.get("CARRY4", 0),
            "MUXF7": counts.get("MUXF7", 0), "MUXF8": counts.get("MUXF8", 0), "INV": counts.get("INV", 0)}


def parse_memory_mapping(log):
    """Yosys memory_libmap's decisions: flattened memory path (without the top's name) -> (kind, via)."""
    mapping = {}
    for full, via in re.findall(r"^mapping memory (\S+) via (\S+)", log, re.M):
        kind = "BRAM" if "BLOCKRAM" in via or "URAM" in via else "LUTRAM" if "LUTRAM" in via else via
        mapping[full.split(".", 1)[1]] = (kind, via)
    for full in re.findall(r"^using FF mapping for memory (\S+)", log, re.M):
        mapping[full.split(".", 1)[1]] = ("FF", "memory_map")
    return mapping


def run_yosys(script, workdir, label, timeout, mem_mb):
    """Runs one Yosys script under a wall-clock and an address-space limit."""
    os.makedirs(workdir, exist_ok=True)
    ys = os.path.join(workdir, "synth.ys")
    with open(ys, "w") as fh:
        fh.write(script)
    log = os.path.join(workdir, "yosys.log")
    limit = f"ulimit -v {mem_mb * 1024} && " if mem_mb > 0 else ""
    cmd = ["bash", "-c", f'{limit}exec timeout --kill-after=30 {timeout} yosys -q -l "$1" -s "$2" >/dev/null',
           "yosys", log, ys]
    start = time.time()
    proc = subprocess.run(cmd, cwd=workdir, capture_output=True, text=True)
    seconds = time.time() - start
    if proc.returncode in (124, 137):
        raise FlowError(f"{label}: Yosys exceeded the time limit ({timeout} s; SYNTH_TIMEOUT); log {log}")
    if proc.returncode != 0:
        text = (open(log).read() if os.path.exists(log) else "") + proc.stderr
        errors = re.findall(r"^.*ERROR: .*$", text, re.M)
        if errors:
            why = errors[0].strip()
        elif proc.returncode < 0 or "bad_alloc" in text:
            why = f"killed by signal {-proc.returncode} (out of memory? SYNTH_MEM_MB={mem_mb})"
        else:
            why = f"exit {proc.returncode}"
        raise FlowError(f"{label}: Yosys failed: {why}; log {log}")
    return seconds, open(log).read()


def synthesise(design, module, workdir, args, glue_children=None):
    """Synthesises `module` flattened (its children as black boxes when glue_children is given)."""
    # Glue run: the stages are read as black boxes (-lib: ports only); everything else is synthesised.
    boxed = set(glue_children or {})
    inside = design.reachable(module, skip=boxed)
    lines = []
    for f in design.closure_files(module):
        path = os.path.abspath(os.path.join(design.dir, f))
        defined = {m for m, g in design.file_of.items() if g == f}
        lib = bool(defined) and not (defined & inside)
        lines.append(f'read_verilog -sv {"-lib " if lib else ""}"{path}"')
    lines += [f"{SYNTH_CMD} -top {module}", "tee -q -o stat.txt stat", "write_json netlist.json"]
    seconds, log = run_yosys("\n".join(lines) + "\n", workdir, module, args.timeout, args.mem_mb)
    counts = parse_stat(open(os.path.join(workdir, "stat.txt")).read(), module)
    netlist = os.path.join(workdir, "netlist.json")
    depth = netlist_depth.longest_path_file(netlist, module)
    if not args.keep_netlist:
        os.remove(netlist)
    mapping = parse_memory_mapping(log)
    memories = []
    expected = design.memory_instances(module, skip=boxed)
    for mem in expected:
        kind, via = mapping.pop(mem["path"], ("removed", "optimised away before memory mapping"))
        memories.append(dict(mem, mapped=kind, via=via))
    for path, (kind, via) in sorted(mapping.items()):  # a memory Yosys inferred that firtool did not declare
        memories.append({"path": path, "module": "?", "mapped": kind, "via": via})
    children = glue_children or {}
    cells = {t: n for t, n in counts.items() if t not in children}
    return {"module": module, "seconds": round(seconds, 1), "cells": cells, "resources": resources_of(cells),
            "lut_levels": depth["lut_levels"], "logic_levels": depth["logic_levels"],
            "critical_path": depth["path"], "memories": memories}


def cached(design, module, kind, args, salt, glue_children=None):
    # A glue unit that boxes only some of its children means something else than one boxing all of them.
    boxed_all = glue_children is None or set(glue_children) == set(design.stages(module))
    key = design.content_hash(module, salt + "|" + kind + ("" if boxed_all else "|boxed=" + ",".join(sorted(glue_children))))
    entry = os.path.join(args.cache, f"{module}-{kind}-{key[:16]}.json")
    # Several flows may share a cache (`make -j sweep`): one lock per key (outside the cache, which is committed),
    # so a module is synthesised once and the others wait for its result.
    locks = os.path.join(tempfile.gettempdir(), "ielas-synth-locks")
    os.makedirs(locks, exist_ok=True)
    with open(os.path.join(locks, key[:32] + ".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if os.path.exists(entry):
            with open(entry) as fh:
                result = json.load(fh)
            if result.get("key") == key:
                result["cached"] = True
                return result
        result = synthesise(design, module, os.path.join(args.out, "modules", f"{module}-{kind}"), args, glue_children)
        result["key"] = key
        os.makedirs(args.cache, exist_ok=True)
        tmp = f"{entry}.{os.getpid()}.tmp"
        with open(tmp, "w") as fh:
            json.dump(result, fh, indent=1)
        os.replace(tmp, entry)
    result["cached"] = False
    return result


# Below the top, a leaf module used fewer times than this is synthesised inside its parent: splitting off a small
# block used once or twice saves no Yosys time and loses the optimisation across its ports (a barrel rotator
# split from the muxes behind it cost 7 % LUTs at small). Replicated units (SAD units, cost lookups) and modules
# with submodules of their own are units.
REPLICATED_MIN = 8


def units(design, top):
    """The synthesis units below `top`, by hierarchy. Every direct child of the top is a unit (a stage); below it, a
    module is a unit when it has submodules (memory wrappers aside) or is instantiated at least REPLICATED_MIN times
    in the design; other modules are synthesised inside their parent. A unit with unit children is a `glue` unit (its
    own logic and its merged children, the unit children as black boxes), else a `stage` unit (flattened with its
    memories). Returns {(module, kind): (boxed children or None, [instance path prefixes])}; a unit used under
    several parents or several times is synthesised once and counted per path."""
    count = {}

    def tally(module, n):
        for child, k in design.stages(module).items():
            count[child] = count.get(child, 0) + n * k
            tally(child, n * k)
    tally(top, 1)

    def is_unit(child, parent):
        return parent == top or bool(design.stages(child)) or count.get(child, 0) >= REPLICATED_MIN

    found = {}

    def walk(module, prefixes, is_top):
        children = {c: n for c, n in design.stages(module).items() if is_unit(c, module)}
        kind = "glue" if children or is_top else "stage"
        entry = found.setdefault((module, kind), (children if kind == "glue" else None, []))
        entry[1].extend(prefixes)
        for child in sorted(children):
            paths = [pre + inst + "." for pre in prefixes for typ, inst in design.instances[module] if typ == child]
            walk(child, paths, False)
    walk(top, [""], True)
    return found


def per_module(design, args, salt):
    """Every unit of the hierarchy synthesised on its own (a replicated unit once) and summed by instance count."""
    found = units(design, args.top)
    jobs = sorted(found, key=lambda mk: (mk[0] == args.top, mk))  # the top's glue last
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = [pool.submit(cached, design, m, kind, args, salt, found[(m, kind)][0]) for m, kind in jobs]
        results = [f.result() for f in futures]
    total = {}
    memories = []
    for (m, kind), r in zip(jobs, results):
        prefixes = found[(m, kind)][1]
        r["instances"] = len(prefixes)
        r["kind"] = kind
        for t, n in r["cells"].items():
            total[t] = total.get(t, 0) + n * r["instances"]
        # one entry per instance, named as in the whole-top run
        memories += [dict(x, path=pre + x["path"]) for pre in prefixes for x in r["memories"]]
    worst = max(results, key=lambda r: (r["lut_levels"], r["logic_levels"]))
    return {"method": "modules", "cells": total, "resources": resources_of(total),
            "lut_levels": worst["lut_levels"], "logic_levels": worst["logic_levels"],
            "critical_path": [f"(in {worst['module']})"] + worst["critical_path"],
            "seconds": round(sum(0 if r["cached"] else r["seconds"] for r in results), 1),
            "memories": memories, "modules": results}


def whole_top(design, args):
    r = synthesise(design, args.top, os.path.join(args.out, "top"), args)
    r["method"] = "top"
    return r


# A line buffer is a SyncReadMem of more than 64 words (the depth of the LUT-RAM primitive RAM64M, which holds
# shallower memories directly) and at least LINE_BUFFER_MIN_BITS bits: smaller or shallower memories (a 27-node
# lattice row, a 128x5 row or a 64-word bank of descriptor rows at a test width) belong in LUT-RAM, which is also
# what Vivado would pick. Both can be set from the environment (0 and 0: every SyncReadMem must be block RAM).
LINE_BUFFER_MIN_DEPTH = int(os.environ.get("SYNTH_LINEBUF_MIN_DEPTH", "65"))
LINE_BUFFER_MIN_BITS = int(os.environ.get("SYNTH_LINEBUF_MIN_BITS", "4096"))


def bram_check(result):
    """Line buffers (large SyncReadMem memories) must become block RAM; anything else is listed."""
    sync = [m for m in result["memories"] if m.get("sync_read") and
            (m.get("depth") is None or (m["depth"] >= LINE_BUFFER_MIN_DEPTH and
                                        m["depth"] * m.get("width", 1) >= LINE_BUFFER_MIN_BITS))]
    bad = [m for m in sync if m["mapped"] != "BRAM"]
    return {"sync_read_memories": len(sync), "in_bram": len(sync) - len(bad), "not_in_bram": bad, "pass": not bad}


def fmt(v):
    return f"{v:g}" if isinstance(v, float) else str(v)


COLUMNS = ["LUT", "FF", "RAMB36E1", "RAMB18E1", "BRAM36eq", "DSP48E1", "LUTRAM_sites", "CARRY4"]


def markdown(report):
    out = [f"# Synthesis: {report['config']}", "",
           f"`{report['flow']}` ({report['yosys']}), Verilog from `{report['verilog_dir']}`.", ""]
    rows = []
    if "top" in report:
        rows.append(("whole top (flattened)", report["top"]))
    if "modules" in report:
        rows.append(("sum of modules", report["modules"]))
    out.append("| run | " + " | ".join(COLUMNS) + " | LUT levels | logic levels | Yosys s (this run) |")
    out.append("|---|" + "---:|" * (len(COLUMNS) + 3))
    for label, r in rows:
        res = r["resources"]
        out.append(f"| {label} | " + " | ".join(fmt(res[c]) for c in COLUMNS) +
                   f" | {r['lut_levels']} | {r['logic_levels']} | {r['seconds']} |")
    if "modules" in report:
        out += ["", "Per module (instances x one instance):", "",
                "| module | kind | instances | " + " | ".join(COLUMNS) + " | LUT levels | cached | Yosys s (when run) |",
                "|---|---|---:|" + "---:|" * (len(COLUMNS) + 3)]
        for r in report["modules"]["modules"]:
            res = r["resources"]
            out.append(f"| {r['module']} | {r['kind']} | {r['instances']} | " +
                       " | ".join(fmt(res[c]) for c in COLUMNS) +
                       f" | {r['lut_levels']} | {'yes' if r['cached'] else 'no'} | {r['seconds']} |")
    if "comparison" in report:
        c = report["comparison"]
        out += ["", f"Sum of modules vs whole top: LUT {c['LUT_diff_pct']:+.2f} %, FF {c['FF_diff_pct']:+.2f} %, "
                f"RAMB36E1 {c['RAMB36E1_equal']}, RAMB18E1 {c['RAMB18E1_equal']} "
                f"({'agree' if c['agree'] else 'DISAGREE'}: equal RAMB counts, LUT and FF within 5 %)."]
    primary = report[report["primary"]]
    out += ["", "Memories (firtool memory modules; `sync` = SyncReadMem with registered read address):", "",
            "| path | module | width x depth | bits | sync | mapped to | via |", "|---|---|---|---:|---|---|---|"]
    for m in primary["memories"]:
        wd = f"{m['width']} x {m['depth']}" if "width" in m else "?"
        out.append(f"| {m['path']} | {m['module']} | {wd} | {m.get('bits', '?')} | "
                   f"{'yes' if m.get('sync_read') else 'no'} | {m['mapped']} | `{m['via']}` |")
    b = report["bram_check"]
    out += ["", f"Line-buffer check: {b['in_bram']} of {b['sync_read_memories']} SyncReadMem memories in block RAM "
            f"({'PASS' if b['pass'] else 'FAIL: ' + ', '.join(m['path'] for m in b['not_in_bram'])}).",
            "", f"Longest combinational path: {primary['lut_levels']} LUT levels, {primary['logic_levels']} logic "
            f"levels (LUT + CARRY4 + MUXF), from `{report['primary']}`:", ""]
    out += ["    " + " -> ".join(p.replace(" -> (internal net)", "") for p in primary["critical_path"]), ""]
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--verilog", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--mode", choices=["top", "modules", "both"], default="top")
    ap.add_argument("--cache", default="build/synth/cache")
    ap.add_argument("--top", default="IElas")
    ap.add_argument("--timeout", type=int, default=3600)
    ap.add_argument("--mem-mb", type=int, default=8192)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--strict", action="store_true", help="exit 3 when a line buffer is not in block RAM")
    ap.add_argument("--keep-netlist", action="store_true")
    ap.add_argument("--mapper", choices=sorted(MAPPERS), default="lut6", help="Yosys LUT mapping")
    args = ap.parse_args()
    global SYNTH_CMD
    SYNTH_CMD = SYNTH_BASE + MAPPERS[args.mapper]
    try:
        design = verilog_modules.Design(args.verilog)
        if args.top not in design.file_of:
            raise FlowError(f"top module {args.top} not found in {args.verilog}")
        version = yosys_version()
        args.out = os.path.abspath(args.out)
        args.cache = os.path.abspath(args.cache)
        # Clear only what this flow writes: SYNTH_OUT may point anywhere.
        for sub in ("top", "modules"):
            shutil.rmtree(os.path.join(args.out, sub), ignore_errors=True)
        for f in ("resources.json", "resources.md"):
            if os.path.exists(os.path.join(args.out, f)):
                os.remove(os.path.join(args.out, f))
        os.makedirs(args.out, exist_ok=True)
        salt = f"{FLOW_VERSION}|{SYNTH_CMD}|{version}"
        report = {"config": args.config, "verilog_dir": args.verilog, "flow": SYNTH_CMD + f" -top {args.top}",
                  "yosys": version, "flow_version": FLOW_VERSION}
        if args.mode in ("top", "both"):
            report["top"] = whole_top(design, args)
        if args.mode in ("modules", "both"):
            report["modules"] = per_module(design, args, salt)
        report["primary"] = "top" if "top" in report else "modules"
        primary = report[report["primary"]]
        report["resources"] = primary["resources"]
        report["lut_levels"] = primary["lut_levels"]
        if "top" in report and "modules" in report:
            t, s = report["top"]["resources"], report["modules"]["resources"]
            pct = {k: (100.0 * (s[k] - t[k]) / t[k] if t[k] else (0.0 if s[k] == 0 else float("inf")))
                   for k in ("LUT", "FF")}
            report["comparison"] = {
                "LUT_diff_pct": round(pct["LUT"], 2), "FF_diff_pct": round(pct["FF"], 2),
                "RAMB36E1_equal": s["RAMB36E1"] == t["RAMB36E1"], "RAMB18E1_equal": s["RAMB18E1"] == t["RAMB18E1"]}
            c = report["comparison"]
            c["agree"] = (c["RAMB36E1_equal"] and c["RAMB18E1_equal"] and abs(pct["LUT"]) <= 5
                          and abs(pct["FF"]) <= 5)
        report["bram_check"] = bram_check(primary)
        report["paper_whole_accelerator"] = PAPER
        with open(os.path.join(args.out, "resources.json"), "w") as fh:
            json.dump(report, fh, indent=1)
        md = markdown(report)
        with open(os.path.join(args.out, "resources.md"), "w") as fh:
            fh.write(md)
        print(md)
        print(f"wrote {os.path.join(args.out, 'resources.json')} and resources.md")
        if "comparison" in report and not report["comparison"]["agree"]:
            print("synth: WARNING: sum of modules and whole top disagree (see comparison)")
        if not report["bram_check"]["pass"]:
            print("synth: WARNING: line buffers not in block RAM: " +
                  ", ".join(f"{m['path']} -> {m['mapped']}" for m in report["bram_check"]["not_in_bram"]))
            if args.strict:
                return 3
        return 0
    except (FlowError, ValueError, OSError) as e:
        print(f"synth: error: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
