#!/usr/bin/env python3
"""One sweep point (`make sweep-point POINT=<name>`): elaborate, synthesise per module, cycle model, accuracy;
then one row of the results table (docs/sweep.md).

usage: point.py POINT [--grid-dir DIR] [--force]

Steps, each recorded; a failing step gives the row status `failed` with its reason, and the others still run:
  1. configuration  DIR/configs/POINT.json (+ POINT-middlebury.json, POINT.model.json) from `make sweep-configs`
  2. elaboration    `make verilog CONFIG=<json>` (sbt, one at a time: a lock), under SWEEP_ELAB_TIMEOUT;
                    the generator's memory summary comes from its output
  3. synthesis      scripts/synth.sh in modules mode with the shared per-module cache (SYNTH_TIMEOUT, SYNTH_MEM_MB
                    per Yosys run)
  4. cycle model    from the configuration and IElas.latencyRows/cycleSlack (POINT.model.json)
  5. accuracy       golden ielas model, both parameter sets
A rerun skips the point when the recorded configuration hash, design hash (or, before elaborating, generator
source hash) and golden-model hash are the current ones; --force (FORCE=1) runs it anyway.

Environment: SWEEP_RESULTS (CSV), SWEEP_CACHE (synthesis cache; accuracy under its accuracy/), SWEEP_WORK,
IELAS_GOLDEN, IELAS_EVAL, IELAS_DATA, SWEEP_ELAB_TIMEOUT (s, default 3600), SYNTH_TIMEOUT (s, default 3600),
SYNTH_MEM_MB (default 8192), SWEEP_VERILOG_CMD (default `make --no-print-directory verilog CONFIG={config}`),
SWEEP_SYNTH_CMD (default `scripts/synth.sh {config} {verilog}`); for the tests, SWEEP_VERILOG_ROOT (default
build/verilog; `make verilog` writes build/verilog/POINT) and SWEEP_SBT_LOCK.
"""
import argparse
import datetime
import fcntl
import json
import os
import shlex
import shutil
import subprocess
import sys
import time

sys.dont_write_bytecode = True
here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, here)
sys.path.insert(0, os.path.join(here, "..", "synth"))
import accuracy  # noqa: E402
import common  # noqa: E402
import grid  # noqa: E402
import verilog_modules  # noqa: E402

ROOT = common.ROOT


def env(name, default):
    v = os.environ.get(name, "")
    return v if v else default


def log(point, msg):
    print(f"sweep-point {point}: {msg}", flush=True)


def git_commit():
    try:
        return subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def elaborate(cfg, verilog_dir, work, timeout, copy_to=None):
    """`make verilog` for the configuration; returns (log text, error or None). sbt runs one at a time. copy_to
    takes a private copy of the Verilog before the lock is released (another run may re-elaborate the directory)."""
    cmd = env("SWEEP_VERILOG_CMD", "make --no-print-directory verilog CONFIG={config}").format(
        config=cfg, verilog=verilog_dir)
    lock_path = env("SWEEP_SBT_LOCK", os.path.join(ROOT, "build", "sweep-sbt.lock"))
    os.makedirs(os.path.dirname(lock_path), exist_ok=True)
    with open(lock_path, "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        shutil.rmtree(verilog_dir, ignore_errors=True)
        try:
            proc = subprocess.run(["timeout", "--kill-after=30", str(timeout), "bash", "-c", cmd], cwd=ROOT,
                                  capture_output=True, text=True, stdin=subprocess.DEVNULL)
        except OSError as e:
            return "", f"elaboration: {e}"
        if proc.returncode == 0 and copy_to:
            shutil.rmtree(copy_to, ignore_errors=True)
            shutil.copytree(verilog_dir, copy_to)
    text = proc.stdout + proc.stderr
    with open(os.path.join(work, "verilog.log"), "w") as fh:
        fh.write(f"$ {cmd}\n{text}")
    if proc.returncode in (124, 137):
        return text, f"elaboration: exceeded the time limit ({timeout} s; SWEEP_ELAB_TIMEOUT)"
    if proc.returncode != 0:
        return text, f"elaboration: {common.elaboration_error(text)}"
    return text, None


def synthesise(cfg, verilog_dir, work, cache):
    cmd = env("SWEEP_SYNTH_CMD", "scripts/synth.sh {config} {verilog}").format(config=shlex.quote(cfg),
                                                                               verilog=shlex.quote(verilog_dir))
    out = os.path.join(work, "synth")
    e = dict(os.environ, SYNTH_MODE="modules", SYNTH_CACHE=cache, SYNTH_OUT=out,
             SYNTH_TIMEOUT=env("SYNTH_TIMEOUT", "3600"), SYNTH_MEM_MB=env("SYNTH_MEM_MB", "8192"))
    e.pop("SYNTH_STRICT", None)
    proc = subprocess.run(["bash", "-c", cmd], cwd=ROOT, capture_output=True, text=True, env=e,
                          stdin=subprocess.DEVNULL)
    with open(os.path.join(work, "synth.log"), "w") as fh:
        fh.write(f"$ {cmd}\n{proc.stdout}{proc.stderr}")
    if proc.returncode != 0:
        lines = [l for l in (proc.stderr + proc.stdout).splitlines() if l.strip()]
        why = next((l for l in lines if "error" in l.lower()), lines[-1] if lines else f"exit {proc.returncode}")
        return None, f"synthesis: {why.replace('synth: error: ', '')}"
    with open(os.path.join(out, "resources.json")) as fh:
        return json.load(fh), None


def run(point, grid_dir, force=False):
    start = time.time()
    p = grid.by_name(point)
    configs = os.path.join(grid_dir, "configs")
    work = os.path.abspath(env("SWEEP_WORK", os.path.join(grid_dir, "points", point)))
    results = common.Results(env("SWEEP_RESULTS", os.path.join(grid_dir, "results.csv")),
                             [q.name for q in grid.points(p.grid)])
    cache = os.path.abspath(env("SWEEP_CACHE", os.path.join(grid_dir, "cache")))
    golden = env("IELAS_GOLDEN", os.path.join(ROOT, "golden/build/ielas-golden"))
    evaluator = env("IELAS_EVAL", os.path.join(os.path.dirname(golden), "ielas-eval"))
    data = env("IELAS_DATA", os.path.join(ROOT, "..", "shared", "data"))

    cfg = os.path.join(configs, f"{point}.json")
    if not os.path.exists(cfg):
        error = os.path.join(configs, f"{point}.error")
        if not os.path.exists(error):
            print(f"sweep-point: {cfg} missing (make sweep-configs SWEEP={p.grid})", file=sys.stderr)
            return 1
        # ElasParams rejected the point: its require message is the result.
        with open(error) as fh:
            msg = fh.read().strip()
        results.upsert({"point": point, "grid": p.grid, "resolution": p.resolution, "dispMax": p.disp_max,
                        "storedDisparities": p.stored, "windowSize": p.window, "status": "failed",
                        "reason": f"configuration: {msg}", "config_hash": common.sha256_file(error)[:16],
                        "generator_hash": common.generator_hash(), "commit": git_commit(),
                        "wall_seconds": round(time.time() - start, 1),
                        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M")})
        log(point, f"failed: configuration: {msg}")
        return 0
    with open(cfg) as fh:
        conf = json.load(fh)
    cfg_hash = common.config_hash(cfg)
    gen_hash = common.generator_hash()
    gold_hash = common.sha256_file(golden)[:16] if os.path.exists(golden) else "missing"
    old = results.find(point)
    if not force and common.up_to_date(old, cfg_hash, gen_hash=gen_hash, gold_hash=gold_hash):
        log(point, f"up to date (config {cfg_hash}, generator {gen_hash}, design {old['design_hash']}); skipped")
        return 0

    os.makedirs(work, exist_ok=True)
    row = {"point": point, "grid": p.grid, "resolution": p.resolution, "config_hash": cfg_hash,
           "generator_hash": gen_hash, "golden_hash": gold_hash, "commit": git_commit(),
           "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M")}
    for k in ("maxWidth", "maxHeight", "dispMax", "storedDisparities", "windowSize"):
        row[k] = conf[k]
    row["supportLanes"], row["denseLanes"] = conf["supportLanesUsed"], conf["denseLanesUsed"]  # the lanes built
    reasons = []

    # 2. elaboration
    verilog_dir = os.path.join(env("SWEEP_VERILOG_ROOT", os.path.join(ROOT, "build", "verilog")), point)
    log(point, "elaborating (make verilog)")
    text, err = elaborate(cfg, verilog_dir, work, int(env("SWEEP_ELAB_TIMEOUT", "3600")))
    design = None
    if err:
        reasons.append(err)
    else:
        row["design_hash"] = common.design_hash(verilog_dir)
        if not force and common.up_to_date(old, cfg_hash, des_hash=row["design_hash"], gold_hash=gold_hash):
            old.update(generator_hash=gen_hash)  # same Verilog from changed sources: remember, skip the rest
            results.upsert(old)
            log(point, f"design {row['design_hash']} already recorded; skipped")
            return 0
        bits = common.memory_bits_from_log(text)
        if bits is not None:
            row["gen_memory_bits"] = bits
            row["gen_memory_bram36"] = round(bits / common.BRAM36_BITS, 2)
        try:
            design = verilog_modules.Design(verilog_dir)
            stages = design.stages("IElas")
            row["top_stages"] = "+".join(f"{m}x{n}" if n > 1 else m for m, n in sorted(stages.items()))
        except Exception as e:  # informative only
            row["top_stages"] = f"? ({e})"

    # 3. synthesis (per module, shared cache)
    if design is not None:
        log(point, "synthesising (per module, cache " + os.path.relpath(cache, ROOT) + ")")
        res, err = synthesise(cfg, verilog_dir, work, cache)
        if err:
            reasons.append(err)
        else:
            r = res["resources"]
            for k in ("LUT", "FF", "RAMB36E1", "RAMB18E1", "BRAM36eq", "DSP48E1", "LUTRAM_sites"):
                row[k] = r[k]
            row["lut_levels"] = res["lut_levels"]
            b = res["bram_check"]
            row["bram_check"] = f"{'pass' if b['pass'] else 'FAIL'} {b['in_bram']}/{b['sync_read_memories']}"
            row["yosys"] = res["yosys"].split()[1] if len(res["yosys"].split()) > 1 else res["yosys"]
            row["yosys_seconds"] = res["modules"]["seconds"]
            # Where the LUTs go: the units with the most LUTs in total (instances x one instance).
            units = sorted(((u["resources"]["LUT"] * u["instances"], u["module"], u["instances"])
                            for u in res["modules"].get("modules", [])), reverse=True)
            row["lut_by_unit"] = " ".join(f"{m}{'*' + str(n) if n > 1 else ''}:{lut}" for lut, m, n in units[:6])

    # 4. cycle model
    model_file = os.path.join(configs, f"{point}.model.json")
    try:
        with open(model_file) as fh:
            model = json.load(fh)
        row.update(common.cycle_model(conf["maxWidth"], conf["maxHeight"], model["latencyRows"], model["cycleSlack"],
                                      cycles_per_pixel=conf.get("cyclesPerPixel", 1)))
        if "gen_memory_bits" not in row:  # the same IElas.memorySummary, when `make verilog` did not print it
            row["gen_memory_bits"] = model["memoryBits"]
            row["gen_memory_bram36"] = round(model["memoryBits"] / common.BRAM36_BITS, 2)
    except (OSError, KeyError, ValueError) as e:
        reasons.append(f"cycle model: {e}")

    # 5. accuracy, both parameter sets
    pair_names = []
    for pset in grid.PARAMETER_SETS:
        pcfg = os.path.join(configs, f"{p.config_name(pset)}.json")
        log(point, f"accuracy ({pset})")
        try:
            a = accuracy.evaluate(pcfg, p.resolution, os.path.join(work, "accuracy"), golden, evaluator, data,
                                  os.path.join(cache, "accuracy"))
            row[f"{pset}_bad3"], row[f"{pset}_d1"], row[f"{pset}_density"] = a["bad3"], a["d1"], a["density"]
            pair_names = [x["pair"] + "/" + x["region"] for x in a["pairs"]]
        except (accuracy.AccuracyError, OSError) as e:
            reasons.append(f"accuracy {pset}: {e}")
    row["accuracy_pairs"] = " ".join(pair_names)

    row["status"] = "failed" if reasons else "ok"
    row["reason"] = "; ".join(reasons).replace("\n", " ")
    row["wall_seconds"] = round(time.time() - start, 1)
    results.upsert(row)
    log(point, f"{row['status']}{': ' + row['reason'] if reasons else ''} "
               f"(LUT {row.get('LUT', '-')}, FF {row.get('FF', '-')}, BRAM36eq {row.get('BRAM36eq', '-')}, "
               f"bad-3 {row.get('robotics_bad3', '-')}/{row.get('middlebury_bad3', '-')}, {row['wall_seconds']} s) "
               f"-> {os.path.relpath(results.path, ROOT)}")
    return 0  # a failing point is a recorded result; the sweep goes on


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("point")
    ap.add_argument("--grid-dir", help="configs/, points/, results.csv, cache/ (default by grid: docs/sweep's "
                    "results with build/sweep for full, build/sweep-quick for quick)")
    ap.add_argument("--force", action="store_true", default=os.environ.get("FORCE", "") not in ("", "0"))
    args = ap.parse_args()
    try:
        p = grid.by_name(args.point)
    except ValueError as e:
        print(f"sweep-point: {e}", file=sys.stderr)
        return 2
    if args.grid_dir:
        grid_dir = args.grid_dir
    elif p.grid == "quick":
        grid_dir = os.path.join(ROOT, "build", "sweep-quick")
    else:  # full: configs and work under build/; results (docs/sweep/) and cache (sweep-cache/) committed
        grid_dir = os.path.join(ROOT, "build", "sweep")
        os.environ.setdefault("SWEEP_RESULTS", os.path.join(ROOT, "docs", "sweep", "results.csv"))
        os.environ.setdefault("SWEEP_CACHE", os.path.join(ROOT, "sweep-cache"))
    return run(args.point, os.path.abspath(grid_dir), args.force)


if __name__ == "__main__":
    sys.exit(main())
