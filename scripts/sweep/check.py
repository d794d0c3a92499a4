#!/usr/bin/env python3
"""Checks the outputs of a sweep (run by `make sweep SWEEP=quick`, so CI fails when the flow breaks).

usage: check.py --grid quick|full
quick: every point of the grid is recorded and ok, with resources, a passing line-buffer check, the cycle model
and accuracy in range; the sum-vs-top agreement holds; sweep.md and the plots exist. full: the full
grid's completion criterion (at most 4 failures, kitti-d255-s20-w5 not among them, every other point with
LUT/FF/BRAM figures).
Exit 0 when everything holds, 1 otherwise (each problem printed).
"""
import argparse
import json
import os
import sys

sys.dont_write_bytecode = True
here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, here)
import common  # noqa: E402
import grid  # noqa: E402

PLOTS = ["bram_vs_stored.png", "lut_vs_dispmax.png", "bad3_vs_stored.png", "fps_latency_vs_resolution.png"]


def problems(rows, grid_name, agreement, data_dir, md_path):
    out = []
    by = {r["point"]: r for r in rows}
    names = [p.name for p in grid.points(grid_name)]
    for n in names:
        if n not in by:
            out.append(f"{n}: not recorded")
    has_synth = lambda r: all(r.get(k) not in (None, "") for k in ("LUT", "FF", "BRAM36eq"))  # noqa: E731
    if grid_name == "quick":
        for n in names:
            r = by.get(n)
            if not r:
                continue
            if r["status"] != "ok":
                out.append(f"{n}: status {r['status']}: {r['reason']}")
                continue
            if not has_synth(r) or float(r["LUT"]) <= 0 or float(r["FF"]) <= 0:
                out.append(f"{n}: no synthesis figures")
            if not r.get("bram_check", "").startswith("pass"):
                out.append(f"{n}: line-buffer check {r.get('bram_check')}")
            w, h = int(r["maxWidth"]), int(r["maxHeight"])
            if int(r["cycles_per_frame"]) < w * h or float(r["fps_200MHz"]) <= 0:
                out.append(f"{n}: cycle model {r['cycles_per_frame']} cycles for {w}x{h}")
            for pset in grid.PARAMETER_SETS:
                for k in ("bad3", "d1", "density"):
                    v = r.get(f"{pset}_{k}", "")
                    if v == "" or not 0 <= float(v) <= 100:
                        out.append(f"{n}: {pset} {k} = '{v}'")
            if not r.get("design_hash") or not r.get("config_hash"):
                out.append(f"{n}: hashes missing")
        if not agreement or not agreement.get("points"):
            out.append("agreement: not run")
        else:
            for e in agreement["points"]:
                if "error" in e or not e["comparison"]["agree"]:
                    out.append(f"agreement {e['point']}: {e.get('error') or e['comparison']}")
        for f in PLOTS:
            if not os.path.exists(os.path.join(data_dir, f)):
                out.append(f"plot {f} missing")
    else:
        failed = [r for r in rows if not has_synth(r)]
        if len(failed) > 4:
            out.append(f"{len(failed)} points without LUT/FF/BRAM figures (at most 4 allowed)")
        if "kitti-d255-s20-w5" in {r["point"] for r in failed}:
            out.append("kitti-d255-s20-w5 has no LUT/FF/BRAM figures")
    if not os.path.exists(md_path):
        out.append(f"{md_path} missing")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", choices=["full", "quick"], required=True)
    args = ap.parse_args()
    root = common.ROOT
    if args.grid == "quick":
        data_dir = os.path.join(root, "build", "sweep-quick")
        md = os.path.join(data_dir, "sweep.md")
    else:
        data_dir, md = os.path.join(root, "docs", "sweep"), os.path.join(root, "docs", "sweep.md")
    rows = common.Results(os.path.join(data_dir, "results.csv")).read()
    agreement = None
    if os.path.exists(os.path.join(data_dir, "agreement.json")):
        with open(os.path.join(data_dir, "agreement.json")) as fh:
            agreement = json.load(fh)
    found = problems(rows, args.grid, agreement, data_dir, md)
    for p in found:
        print(f"sweep check ({args.grid}): {p}")
    print(f"sweep check ({args.grid}): {'FAILED' if found else 'passed'} ({len(rows)} points)")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
