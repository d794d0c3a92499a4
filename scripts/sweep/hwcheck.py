#!/usr/bin/env python3
"""The hardware side of the sweep's accuracy and cycle columns: a real full-size pair through the Verilator model
of the point's configuration (`make simulate`), compared value for value with the golden model's dump of the
same configuration (`ielas-compare`), and its cycle count set beside the cycle model.

usage: hwcheck.py [--stage STAGE] [POINT ...]   (default: kitti-d255-s20-w5 kitti-d255-s20-w5-c8
                                                  tsukuba-d127-s20-w5 kitti-d63-s20-w5)
STAGE (default: SWEEP_HW_STAGE or `top`, the whole accelerator: the disparity itself, hence the accuracy columns,
is checked bit for bit; any earlier stage name checks the hardware up to that stage).
Writes docs/sweep/hwcheck.json (report.py shows it). Exit 0 when every point is bit-exact and within the model.
Pairs: kitti = KITTI 2012 #70 (1241x376); tsukuba = the centred 640x480 crop of Middlebury 2006 Reindeer.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

sys.dont_write_bytecode = True
here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, here)
import common  # noqa: E402
import grid  # noqa: E402

ROOT = common.ROOT
DEFAULT = ["kitti-d255-s20-w5", "kitti-d255-s20-w5-c8", "tsukuba-d127-s20-w5", "kitti-d63-s20-w5"]


def pair(resolution, data, work, evaluator):
    if resolution == "kitti":
        k = f"{data}/kitti2012/training"
        return "kitti2012-000070", f"{k}/image_0/000070_10.png", f"{k}/image_1/000070_10.png"
    d = f"{data}/middlebury2006/Reindeer"
    out = []
    for view in ("view1", "view5"):
        dst = os.path.join(work, f"reindeer-640x480-{view}.png")
        subprocess.run([evaluator, "crop", "--in", f"{d}/{view}.png", "--out", dst, "--width", "640", "--height",
                        "480"], check=True, capture_output=True)
        out.append(dst)
    return "mb06-Reindeer-640x480", out[0], out[1]


def size_of(evaluator, image):
    w, h = subprocess.run([evaluator, "size", image], capture_output=True, text=True, check=True).stdout.split()
    return int(w), int(h)


def one(point, stage, golden, evaluator, data):
    p = grid.by_name(point)
    cfg = os.path.join(ROOT, "build", "sweep", "configs", f"{point}.json")
    work = os.path.join(ROOT, "build", "sweep", "hwcheck", point)
    os.makedirs(work, exist_ok=True)
    entry = {"point": point, "stage": stage}
    start = time.time()
    try:
        name, left, right = pair(p.resolution, data, work, evaluator)
        entry["pair"] = name
        hw, gold = os.path.join(work, "hw"), os.path.join(work, "golden")
        sim = subprocess.run(["flock", os.path.join(ROOT, "build", "sweep-sbt.lock"), "make", "--no-print-directory",
                              "simulate", f"CONFIG={cfg}", f"STAGE={stage}", f"LEFT={left}", f"RIGHT={right}",
                              f"OUT={hw}"], cwd=ROOT, capture_output=True, text=True, stdin=subprocess.DEVNULL)
        if sim.returncode != 0:
            entry["error"] = "simulate: " + common.elaboration_error(sim.stdout + sim.stderr)
            return entry
        subprocess.run([golden, "dump", "--mode", "ielas", "--config", cfg, "--left", left, "--right", right,
                        "--out", gold], check=True, capture_output=True)
        cmp = subprocess.run([os.path.join(os.path.dirname(golden), "ielas-compare"), hw, gold], capture_output=True,
                             text=True)
        entry["compare"] = (cmp.stdout + cmp.stderr).strip().splitlines()[-3:]
        entry["bit_exact"] = cmp.returncode == 0
        m = re.search(r"(\d+) values", cmp.stdout)
        entry["values_compared"] = int(m.group(1)) if m else None
        with open(os.path.join(hw, "cycles.txt")) as fh:
            entry["cycles_measured"] = int(fh.read().split()[0])
        with open(os.path.join(ROOT, "build", "sweep", "configs", f"{point}.model.json")) as fh:
            model = json.load(fh)
        with open(cfg) as fh:
            rate = json.load(fh).get("cyclesPerPixel", 1)
        w, h = size_of(evaluator, left)
        entry["size"] = f"{w}x{h}"
        entry["cycles_model"] = common.cycle_model(w, h, model["latencyRows"], model["cycleSlack"],
                                                   cycles_per_pixel=rate)["cycles_per_frame"]
        entry["within_model"] = entry["cycles_measured"] <= entry["cycles_model"]
    except (subprocess.CalledProcessError, OSError, ValueError) as e:
        entry["error"] = str(e)
    entry["seconds"] = round(time.time() - start, 1)
    return entry


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stage", default=os.environ.get("SWEEP_HW_STAGE") or "top")
    ap.add_argument("points", nargs="*")
    args = ap.parse_args()
    golden = os.environ.get("IELAS_GOLDEN") or os.path.join(ROOT, "golden/build/ielas-golden")
    evaluator = os.environ.get("IELAS_EVAL") or os.path.join(os.path.dirname(golden), "ielas-eval")
    data = os.environ.get("IELAS_DATA") or os.path.join(ROOT, "..", "shared", "data")
    out = os.path.join(ROOT, "docs", "sweep", "hwcheck.json")
    entries = []
    for point in args.points or DEFAULT:
        print(f"hwcheck: {point}: {args.stage} through Verilator vs golden", flush=True)
        e = one(point, args.stage, golden, evaluator, data)
        print(f"hwcheck: {point}: " + (e["error"] if "error" in e else
              f"{'bit-exact' if e['bit_exact'] else 'MISMATCH'} ({e['values_compared']} values), cycles "
              f"{e['cycles_measured']} vs model {e['cycles_model']}"), flush=True)
        entries.append(e)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    with open(out, "w") as fh:
        json.dump({"date": time.strftime("%Y-%m-%d %H:%M", time.gmtime()),
                   "commit": subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                                            text=True).stdout.strip(), "points": entries}, fh, indent=1)
    print(f"hwcheck: wrote {os.path.relpath(out, ROOT)}")
    return 0 if all(e.get("bit_exact") and e.get("within_model") for e in entries) else 1


if __name__ == "__main__":
    sys.exit(main())
