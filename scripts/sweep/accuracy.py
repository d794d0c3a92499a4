"""Accuracy of one configuration with the golden `ielas` model, on the pairs of its resolution (docs/sweep.md).

Each pair runs in a fresh `ielas-golden match --mode ielas --config <json>` process and is scored by `ielas-eval
score` exactly as docs/evaluation.md defines it (bad-3 with invalid = bad, D1, density); the point's figure is
the plain mean over its pairs. Results are cached by (configuration bytes, golden and eval binaries, pair list).
"""
import csv
import hashlib
import io
import json
import os
import subprocess
import sys

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402

# Bump when the pair list or the scoring below changes.
PAIRS_VERSION = "1"


class AccuracyError(Exception):
    pass


def pairs(resolution, data):
    """(name, region, left, right, gt, gt scale, keep-mask or None, crop (w, h) or None) per resolution.

    kitti: the KITTI 2012 #70 grey pair (noc) and KITTI 2015 #46 (all), the regions of the goal families.
    tsukuba: centred 640x480 crops of Middlebury 2006 Reindeer and Wood2 (all) and 2014 Motorcycle (noc), as
    docs/evaluation.md prescribes for New Tsukuba-sized configurations (New Tsukuba itself has no reachable GT).
    small (SWEEP=quick only): centred 128x64 crops of Middlebury 2001 tsukuba and venus (all; disparities < 20).
    """
    k12, k15 = f"{data}/kitti2012/training", f"{data}/kitti2015/training"
    mb06, mb14 = f"{data}/middlebury2006", f"{data}/middlebury2014/trainingQ/Motorcycle"
    mb = f"{data}/middlebury"
    if resolution == "kitti":
        return [("kitti2012-000070", "noc", f"{k12}/image_0/000070_10.png", f"{k12}/image_1/000070_10.png",
                 f"{k12}/disp_noc/000070_10.png", 256, None, None),
                ("kitti2015-000046", "all", f"{k15}/image_2/000046_10.png", f"{k15}/image_3/000046_10.png",
                 f"{k15}/disp_occ_0/000046_10.png", 256, None, None)]
    if resolution == "tsukuba":
        crop = (640, 480)
        return [(f"mb06-{s}-640x480", "all", f"{mb06}/{s}/view1.png", f"{mb06}/{s}/view5.png",
                 f"{mb06}/{s}/disp1.png", 2, None, crop) for s in ("Reindeer", "Wood2")] + \
               [("mb14q-Motorcycle-640x480", "noc", f"{mb14}/im0.png", f"{mb14}/im1.png", f"{mb14}/disp0GT.pfm", 1,
                 f"{mb14}/mask0nocc.png", crop)]
    if resolution == "small":
        return [(f"mb-{s}-128x64", "all", f"{mb}/{s}/im2.png", f"{mb}/{s}/im6.png", f"{mb}/{s}/disp2.png", scale,
                 None, (128, 64)) for s, scale in (("tsukuba", 16), ("venus", 8))]
    raise AccuracyError(f"no accuracy pairs for resolution '{resolution}'")


def _run(cmd, what):
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        msg = (proc.stderr.strip() or proc.stdout.strip() or f"exit {proc.returncode}").splitlines()[-1]
        raise AccuracyError(f"{what}: {msg}")
    return proc.stdout


def evaluate(config_json, resolution, work, golden, evaluator, data, cache_dir=None):
    """{'bad3', 'd1', 'density' (means), 'pairs': [...], 'cached'} for one configuration JSON."""
    plist = pairs(resolution, data)
    missing = [f for p in plist for f in (p[2], p[3], p[4]) + ((p[6],) if p[6] else ()) if not os.path.exists(f)]
    if missing:
        raise AccuracyError(f"ground-truth data missing: {missing[0]} (set IELAS_DATA)")
    for b in (golden, evaluator):
        if not os.access(b, os.X_OK):
            raise AccuracyError(f"{b} not built (make golden, or set IELAS_GOLDEN / IELAS_EVAL)")
    h = hashlib.sha256()
    with open(config_json, "rb") as fh:
        config_bytes = fh.read()
    for part in (config_bytes, common.sha256_file(golden).encode(),
                 common.sha256_file(evaluator).encode(), PAIRS_VERSION.encode(), repr(plist).encode()):
        h.update(part + b"\0")
    key = h.hexdigest()
    name = os.path.basename(config_json)[:-len(".json")]
    entry = os.path.join(cache_dir, f"{name}-{key[:16]}.json") if cache_dir else None
    if entry and os.path.exists(entry):
        with open(entry) as fh:
            result = json.load(fh)
        if result.get("key") == key:
            result["cached"] = True
            return result

    os.makedirs(work, exist_ok=True)
    header = _run([evaluator, "header"], "ielas-eval header").strip().split(",")
    scored = []
    for pname, region, left, right, gt, scale, mask, crop in plist:
        if crop:
            w, h = crop
            cut = {}
            for role, src in (("left", left), ("right", right), ("gt", gt), ("mask", mask)):
                if src:
                    cut[role] = os.path.join(work, f"{pname}-{role}{os.path.splitext(src)[1]}")
                    _run([evaluator, "crop", "--in", src, "--out", cut[role], "--width", str(w), "--height", str(h)],
                         f"crop {src}")
            left, right, gt, mask = cut["left"], cut["right"], cut["gt"], cut.get("mask")
        disp = os.path.join(work, f"{pname}-{name}.pfm")
        _run([golden, "match", "--mode", "ielas", "--config", config_json, "--left", left, "--right", right,
              "--out", disp], f"ielas-golden match {pname}")
        cmd = [evaluator, "score", "--disp", disp, "--gt", gt, "--gt-scale", str(scale), "--name", pname,
               "--region", region]
        if mask:
            cmd += ["--mask", mask]
        line = _run(cmd, f"ielas-eval score {pname}").strip().splitlines()[-1]
        row = next(csv.DictReader(io.StringIO(",".join(header) + "\n" + line + "\n")))
        scored.append({"pair": pname, "region": region, "pixels": int(float(row["pixels"])),
                       "bad3": float(row["bad3"]), "d1": float(row["d1"]), "density": float(row["density"])})
    result = {"config": name, "key": key, "pairs": scored,
              "bad3": round(sum(p["bad3"] for p in scored) / len(scored), 2),
              "d1": round(sum(p["d1"] for p in scored) / len(scored), 2),
              "density": round(sum(p["density"] for p in scored) / len(scored), 2)}
    if entry:
        os.makedirs(cache_dir, exist_ok=True)
        tmp = f"{entry}.{os.getpid()}.tmp"
        with open(tmp, "w") as fh:
            json.dump(result, fh, indent=1)
        os.replace(tmp, entry)
    result["cached"] = False
    return result
