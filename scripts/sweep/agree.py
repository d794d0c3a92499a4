#!/usr/bin/env python3
"""Does the sum of per-module Yosys runs agree with a whole-top run? (agreement = equal RAMB36/RAMB18 counts,
LUT and FF within 5 %, checked on two points). Runs scripts/synth.sh in `both` mode on each point's Verilog and
writes the comparison to docs/sweep/agreement.json (full) or build/sweep-quick/agreement.json (quick), which report.py
puts into docs/sweep.md.

usage: agree.py --grid full|quick [POINT ...]    (full default: kitti-d63-s10-w5 tsukuba-d63-s10-w5, the two
                                                  smallest points: a flattened whole-top run grows with dispMax)
Exit 0 when every point agrees, 1 when one disagrees or fails (the JSON records it either way). A full-grid rerun
reuses a recorded comparison of the same Verilog (design hash) under the same flow; --force runs it again.
"""
import argparse
import json
import os
import subprocess
import sys
import time

sys.dont_write_bytecode = True
here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, here)
sys.path.insert(0, os.path.join(here, "..", "synth"))
import common  # noqa: E402
import flow  # noqa: E402
import grid  # noqa: E402
import point as sweep_point  # noqa: E402

ROOT = common.ROOT
DEFAULT = {"full": ["kitti-d63-s10-w5", "tsukuba-d63-s10-w5"]}
TOLERANCE_PCT = 5.0


def compare(top, mods):
    """The agreement criterion (module docstring) on two resource tables."""
    def pct(k):
        return 100.0 * (mods[k] - top[k]) / top[k] if top[k] else (0.0 if mods[k] == 0 else float("inf"))
    c = {"LUT_diff_pct": round(pct("LUT"), 2), "FF_diff_pct": round(pct("FF"), 2),
         "RAMB36E1_equal": mods["RAMB36E1"] == top["RAMB36E1"], "RAMB18E1_equal": mods["RAMB18E1"] == top["RAMB18E1"]}
    c["agree"] = bool(c["RAMB36E1_equal"] and c["RAMB18E1_equal"] and abs(c["LUT_diff_pct"]) <= TOLERANCE_PCT
                      and abs(c["FF_diff_pct"]) <= TOLERANCE_PCT)
    return c


def one(point, grid_dir, cache, previous=None):
    cfg = os.path.join(grid_dir, "configs", f"{point}.json")
    verilog = os.path.join(sweep_point.env("SWEEP_VERILOG_ROOT", os.path.join(ROOT, "build", "verilog")), point)
    entry = {"point": point}
    start = time.time()
    out = os.path.join(grid_dir, "agree", point)
    private = os.path.join(out, "verilog")
    # Elaborate from the current sources and take a private copy under the sbt lock: under `make -j` the point's own
    # run may re-elaborate build/verilog/<point> meanwhile.
    os.makedirs(out, exist_ok=True)
    _, err = sweep_point.elaborate(cfg, verilog, out, int(sweep_point.env("SWEEP_ELAB_TIMEOUT", "3600")),
                                   copy_to=private)
    if err:
        entry["error"] = err
        return entry
    verilog = private
    entry["design_hash"] = common.design_hash(verilog)
    # The whole-top run is not cached (it is what the cache is checked against): a full-grid rerun reuses a recorded
    # comparison of the same Verilog under the same flow instead of repeating a long flattened Yosys run.
    if previous and previous.get("design_hash") == entry["design_hash"] and "comparison" in previous \
            and previous.get("flow_version") == flow.FLOW_VERSION and previous.get("flow", "").startswith(flow.SYNTH_CMD):
        print(f"agree: {point}: design {entry['design_hash']} already compared under this flow; reused", flush=True)
        return previous
    env = dict(os.environ, SYNTH_MODE="both", SYNTH_CACHE=cache, SYNTH_OUT=out,
               SYNTH_TIMEOUT=os.environ.get("SYNTH_TIMEOUT") or "3600",
               SYNTH_MEM_MB=os.environ.get("SYNTH_MEM_MB") or "8192")
    env.pop("SYNTH_STRICT", None)
    proc = subprocess.run(["scripts/synth.sh", cfg, verilog], cwd=ROOT, capture_output=True, text=True, env=env,
                          stdin=subprocess.DEVNULL)
    if proc.returncode != 0:
        lines = [l for l in (proc.stderr + proc.stdout).splitlines() if l.strip()]
        entry["error"] = "synthesis: " + (lines[-1] if lines else f"exit {proc.returncode}")
        return entry
    with open(os.path.join(out, "resources.json")) as fh:
        res = json.load(fh)
    keys = ("LUT", "FF", "RAMB36E1", "RAMB18E1", "BRAM36eq", "DSP48E1", "LUTRAM_sites")
    entry.update(top={k: res["top"]["resources"][k] for k in keys},
                 modules={k: res["modules"]["resources"][k] for k in keys},
                 top_seconds=res["top"]["seconds"], modules_seconds=res["modules"]["seconds"],
                 top_lut_levels=res["top"]["lut_levels"], modules_lut_levels=res["modules"]["lut_levels"],
                 stages=sorted(r["module"] for r in res["modules"]["modules"] if r["kind"] == "stage"),
                 yosys=res["yosys"], flow=res["flow"], flow_version=res.get("flow_version"),
                 wall_seconds=round(time.time() - start, 1))
    entry["comparison"] = compare(entry["top"], entry["modules"])
    return entry


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", choices=["full", "quick"], required=True)
    ap.add_argument("points", nargs="*")
    ap.add_argument("--force", action="store_true", help="run every point even when its comparison is recorded")
    args = ap.parse_args()
    pts = args.points or DEFAULT.get(args.grid) or [p.name for p in grid.points(args.grid)[:1]]
    for p in pts:
        grid.by_name(p)
    if args.grid == "full":
        grid_dir, cache = os.path.join(ROOT, "build", "sweep"), os.path.join(ROOT, "sweep-cache")
        out = os.path.join(ROOT, "docs", "sweep", "agreement.json")
    else:
        grid_dir = os.path.join(ROOT, "build", "sweep-quick")
        cache, out = os.path.join(grid_dir, "cache"), os.path.join(grid_dir, "agreement.json")
    recorded = {}
    if args.grid == "full" and not args.force and os.path.exists(out):
        with open(out) as fh:
            recorded = {e["point"]: e for e in json.load(fh).get("points", [])}
    entries = []
    for p in pts:
        print(f"agree: {p}: whole top and sum of modules", flush=True)
        e = one(p, grid_dir, cache, recorded.get(p))
        entries.append(e)
        if "error" in e:
            print(f"agree: {p}: {e['error']}")
        else:
            c = e["comparison"]
            print(f"agree: {p}: LUT {e['modules']['LUT']} vs {e['top']['LUT']} ({c['LUT_diff_pct']:+.2f} %), "
                  f"FF {e['modules']['FF']} vs {e['top']['FF']} ({c['FF_diff_pct']:+.2f} %), RAMB36 "
                  f"{e['modules']['RAMB36E1']}/{e['top']['RAMB36E1']}, RAMB18 {e['modules']['RAMB18E1']}/"
                  f"{e['top']['RAMB18E1']}: {'agree' if c['agree'] else 'DISAGREE'}")
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "w") as fh:
        json.dump({"criterion": f"equal RAMB36E1 and RAMB18E1, LUT and FF within {TOLERANCE_PCT:g} %",
                   "commit": subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                                            text=True).stdout.strip(),
                   "date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()), "points": entries}, fh, indent=1)
    print(f"agree: wrote {os.path.relpath(out, ROOT)}")
    return 0 if all("comparison" in e and e["comparison"]["agree"] for e in entries) else 1


if __name__ == "__main__":
    sys.exit(main())
