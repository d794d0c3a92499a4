#!/usr/bin/env python3
"""docs/sweep.md and the plots from the sweep's results (run with the venv's python: matplotlib).

usage: report.py --grid full|quick [--wall SECONDS]
full:  docs/sweep/results.csv + docs/sweep/agreement.json -> docs/sweep.md, docs/sweep/*.png
quick: build/sweep-quick/results.csv + agreement.json      -> build/sweep-quick/sweep.md, build/sweep-quick/*.png
Every number in the output comes from those files; nothing is typed here except the paper's figures.
"""
import argparse
import csv
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
# iELAS paper (Table II resources, Tables III-IV speed): whole accelerator, Vivado, Virtex-7.
PAPER = {"kitti": {"size": "1242x375", "BRAM36eq": 469.5, "LUT": 144.8e3, "FF": 74.6e3, "fps": 57.5},
         "tsukuba": {"size": "640x480", "BRAM36eq": 501.5, "LUT": 114.2e3, "FF": 58.4e3, "fps": 57.6}}
# The named points (storedDisparities 20, windowSize 5) set beside the paper.
NAMED_POINTS = {"kitti": "kitti-d255-s20-w5", "tsukuba": "tsukuba-d127-s20-w5"}
# Stages of the whole accelerator, as substrings of the top's child module names (case-insensitive). While one is
# missing from a point's top, its resource, cycle and latency figures are marked provisional.
STAGE_KEYWORDS = ["descriptor", "support", "filter", "lattice|interp|fill", "grid", "plane", "dense", "lr",
                  "post"]
MARK = "**PROVISIONAL**"
# The paper's device (XC7VX485T on the VC707): slice LUTs, for "does it fit" (logic LUTs + LUT-RAM/SRL sites).
PAPER_DEVICE = {"name": "XC7VX485T", "LUT": 303600, "BRAM36": 1030}


def num(row, k):
    try:
        return float(row.get(k, ""))
    except ValueError:
        return None


def fmt(v, digits=None):
    if v is None or v == "":
        return "-"
    if isinstance(v, str):
        try:
            v = float(v)
        except ValueError:
            return v
    if digits is None:
        return f"{int(v):,}".replace(",", " ") if float(v).is_integer() else f"{v:g}"
    return f"{v:.{digits}f}"


def missing_stages(rows):
    stages = " ".join(r.get("top_stages", "") for r in rows).lower()
    return [k for k in STAGE_KEYWORDS if not any(alt in stages for alt in k.split("|"))]


def plots(rows, outdir, prefix=""):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    ok = [r for r in rows if r.get("status") in ("ok", "failed")]
    made = []
    meta = {"Software": None}

    def series(filter_fn, xkey, ykey, group_fn):
        groups = {}
        for r in ok:
            if not filter_fn(r) or num(r, ykey) is None:
                continue
            groups.setdefault(group_fn(r), []).append((num(r, xkey), num(r, ykey)))
        return {g: sorted(v) for g, v in sorted(groups.items())}

    def save(fig, name):
        path = os.path.join(outdir, prefix + name)
        fig.tight_layout()
        fig.savefig(path, dpi=90, metadata=meta)
        plt.close(fig)
        made.append(path)

    w5 = lambda r: r["windowSize"] == "5"  # noqa: E731

    def ticks(ax, key, filter_fn):
        ax.set_xticks(sorted({int(num(r, key)) for r in ok if filter_fn(r) and num(r, key) is not None}))
    # BRAM vs storedDisparities, Yosys (solid) and the generator's own accounting (dashed, by capacity)
    fig, ax = plt.subplots(figsize=(6.4, 4))
    for g, pts in series(w5, "storedDisparities", "BRAM36eq", lambda r: (r["resolution"], int(r["dispMax"]))).items():
        line, = ax.plot(*zip(*pts), marker="o", label=f"{g[0]} d{g[1]} Yosys")
        gen = series(lambda r: w5(r) and (r["resolution"], int(r["dispMax"])) == g, "storedDisparities",
                     "gen_memory_bram36", lambda r: 0).get(0)
        if gen:
            ax.plot(*zip(*gen), ls="--", marker="x", color=line.get_color(), label=f"{g[0]} d{g[1]} generator")
    ticks(ax, "storedDisparities", w5)
    ax.set_xlabel("storedDisparities")
    ax.set_ylabel("BRAM36 equivalents")
    ax.set_title("Block RAM vs stored disparities (windowSize 5)")
    ax.legend(fontsize=6, ncol=2)
    save(fig, "bram_vs_stored.png")
    # LUT vs dispMax
    fig, ax = plt.subplots(figsize=(6.4, 4))
    for g, pts in series(w5, "dispMax", "LUT", lambda r: (r["resolution"], int(r["storedDisparities"]))).items():
        ax.plot(*zip(*pts), marker="o", label=f"{g[0]} s{g[1]}")
    ticks(ax, "dispMax", w5)
    ax.set_xlabel("dispMax")
    ax.set_ylabel("LUT")
    ax.set_title("LUTs vs disparity range (windowSize 5)")
    ax.legend(fontsize=7)
    save(fig, "lut_vs_dispmax.png")
    # bad-3 vs storedDisparities, both parameter sets
    fig, axes = plt.subplots(1, 2, figsize=(9, 4), sharey=True)
    for ax, pset in zip(axes, grid.PARAMETER_SETS):
        for g, pts in series(w5, "storedDisparities", f"{pset}_bad3",
                             lambda r: (r["resolution"], int(r["dispMax"]))).items():
            ax.plot(*zip(*pts), marker="o", label=f"{g[0]} d{g[1]}")
        ticks(ax, "storedDisparities", w5)
        ax.set_xlabel("storedDisparities")
        ax.set_title(f"{pset} parameter set")
        ax.legend(fontsize=7)
    axes[0].set_ylabel("bad-3 % (invalid = bad)")
    save(fig, "bad3_vs_stored.png")
    # fps and latency vs resolution (every windowSize-5 point: the model depends on the size and the window)
    fig, axes = plt.subplots(1, 2, figsize=(9, 4))
    res = sorted({r["resolution"] for r in ok if num(r, "fps_200MHz") is not None},
                 key=lambda x: -int(next(r["maxWidth"] for r in ok if r["resolution"] == x)))
    for ax, key, label in ((axes[0], "fps_200MHz", "frames/s at an assumed 200 MHz"), (axes[1], "latency_rows", "latency (rows)")):
        vals = [num(by_point(ok, NAMED_POINTS[x]), key) if x in NAMED_POINTS and by_point(ok, NAMED_POINTS[x])
                and num(by_point(ok, NAMED_POINTS[x]), key) is not None else
                max(num(r, key) for r in ok if r["resolution"] == x and num(r, key) is not None) for x in res]
        names = [f"{x}\n{next(r['maxWidth'] + 'x' + r['maxHeight'] for r in ok if r['resolution'] == x)}" for x in res]
        bars = ax.bar(names, vals)
        ax.bar_label(bars, labels=[fmt(v) for v in vals])
        paper = [PAPER[x]["fps"] if x in PAPER and key == "fps_200MHz" else 0 for x in res]
        if any(paper):
            ax.scatter(names, paper, color="red", zorder=3, label="iELAS paper")
            ax.legend(fontsize=7)
        ax.set_ylabel(label)
    axes[0].set_title("Throughput (cycle model, named points)")
    axes[1].set_title("Latency (cycle model, named points)")
    save(fig, "fps_latency_vs_resolution.png")
    return made


def c1(r):
    """A point of the card grid (one pixel per clock), not one of the cyclesPerPixel twins (`<point>-c<N>`)."""
    return re.search(r"-c\d+$", r["point"]) is None


def how_to_choose(rows, provisional):
    """A paragraph from the measured numbers (deltas across the grid), marked while the top is incomplete."""
    by = {r["point"]: r for r in rows}
    out = []
    # The opening sentence: what sets the size, from the named kitti point's largest units and the dispMax series.
    lead = []
    k = by.get("kitti-d255-s20-w5")
    if k and k.get("lut_by_unit") and num(k, "LUT"):
        units = dict(item.rsplit(":", 1) for item in k["lut_by_unit"].split())
        sad = sum(float(v) for u, v in units.items() if u.split("*")[0] == "DescriptorSad")
        if sad:
            lead.append(f"the SAD lanes set the size: at kitti-d255-s20-w5 the DescriptorSad units "
                        f"(quarter-descriptor SADs of the support lanes, which grow with dispMax, and of the dense "
                        f"candidate lanes, which grow with storedDisparities) are {100 * sad / num(k, 'LUT'):.0f} % of "
                        f"the LUTs")
    series = [by.get(f"kitti-d{d}-s20-w5") for d in (63, 127, 255)]
    if all(r and num(r, "LUT") is not None for r in series):
        lead.append("kitti LUT (logic) at dispMax 63 / 127 / 255: " + " / ".join(fmt(r["LUT"]) for r in series) +
                    ", BRAM36eq " + " / ".join(fmt(r["BRAM36eq"]) for r in series))
    if lead:
        out.append("- **What costs what**: " + "; ".join(lead) + ". Pick the smallest dispMax that covers the "
                   "scene's largest disparity (the accuracy columns show when a range is too short), then "
                   "storedDisparities (it sets the dense lanes and their block RAM) and the window by the deltas "
                   "below, then cyclesPerPixel by the frame rate needed.")
    s20 = {res: [r for r in (by.get(f"{res}-d{d}-s20-w5") for d in (63, 127, 255)) if r] for res in ("kitti", "tsukuba")}
    fits = []
    for res, pts in s20.items():
        slice_luts = [(r, num(r, "LUT") + (num(r, "LUTRAM_sites") or 0)) for r in pts if num(r, "LUT") is not None]
        if slice_luts:
            fits.append(f"{res}: " + ", ".join(
                f"d{r['dispMax']} {fmt(n)}" + (" (fits)" if n <= PAPER_DEVICE["LUT"] and num(r, "BRAM36eq")
                                               <= PAPER_DEVICE["BRAM36"] else " (does not fit)")
                for r, n in slice_luts))
    if fits:
        out.append(f"- **Device**: slice LUTs (logic + LUT-RAM sites) at storedDisparities 20 against the paper's "
                   f"{PAPER_DEVICE['name']} ({fmt(PAPER_DEVICE['LUT'])} LUT, {PAPER_DEVICE['BRAM36']} BRAM36): "
                   + "; ".join(fits) + ". Yosys' counts are an estimate of Vivado's, so leave margin.")
    levels = [(num(r, "lut_levels"), r["point"]) for r in rows if num(r, "lut_levels") is not None]
    if levels:
        lo, hi = min(levels), max(levels)
        span = (f"{fmt(hi[0])} LUT levels at every point" if lo[0] == hi[0] else
                f"{fmt(lo[0])} to {fmt(hi[0])} LUT levels ({hi[1]} the deepest)")
        out.append(f"- **Clock**: the fps column is the cycle model at an assumed 200 MHz, not a measured clock. The "
                   f"LUT lvl column is the logic-depth estimate: {span}, where a 5 ns period leaves room for roughly "
                   "5-8 levels of LUT and routing on a 7-series part (a rule of thumb). Measured clocks are in docs/timing.md (`make timing`): each stage placed "
                   "and routed on its own on an ECP5 LFE5U-85F with nextpnr, and a logic-only Yosys `sta` for the "
                   "7-series mapping.")
    for named in ("kitti-d255-s20-w5", "tsukuba-d127-s20-w5"):
        knob = [(c, by.get(named if c == 1 else f"{named}-c{c}")) for c in (1, 2, 4, 8)]
        knob = [(c, r) for c, r in knob if r and num(r, "LUT") is not None]
        if len(knob) > 1:
            out.append(f"- **cyclesPerPixel** at {named}, c = " + " / ".join(str(c) for c, _ in knob) +
                       ": slice LUTs " + " / ".join(fmt(num(r, "LUT") + (num(r, "LUTRAM_sites") or 0)) for _, r in knob) +
                       ", FF " + " / ".join(fmt(r["FF"]) for _, r in knob) +
                       ", BRAM36eq " + " / ".join(fmt(r["BRAM36eq"]) for _, r in knob) +
                       ", fps at an assumed 200 MHz " + " / ".join(fmt(r["fps_200MHz"]) for _, r in knob) +
                       "; the lanes shrink with c, the rest of the design (post-processing, the pixel band, the "
                       "descriptor and grid stages) does not. Accuracy does not depend on c.")
    for res, pts in s20.items():
        pts = [r for r in pts if num(r, "BRAM36eq") is not None and num(r, "LUTRAM_sites") is not None]
        for a, b in zip(pts, pts[1:]):
            if num(b, "BRAM36eq") < num(a, "BRAM36eq") and num(b, "LUTRAM_sites") > num(a, "LUTRAM_sites"):
                out.append(f"- **BRAM is not monotonic** at {res}: dispMax {a['dispMax']} -> {b['dispMax']} takes "
                           f"BRAM36eq {fmt(a['BRAM36eq'])} -> {fmt(b['BRAM36eq'])} while LUT-RAM sites go "
                           f"{fmt(a['LUTRAM_sites'])} -> {fmt(b['LUTRAM_sites'])}: the support matcher's row banks "
                           "(more banks with more lanes, so fewer words each) became shallow enough for Yosys to map "
                           "them to LUT-RAM. Where block RAM is the scarcer resource this is the cheaper point.")
    for res, dnamed in (("kitti", 255), ("tsukuba", 127)):
        s10, s40 = by.get(f"{res}-d{dnamed}-s10-w5"), by.get(f"{res}-d{dnamed}-s40-w5")
        d63, d255 = by.get(f"{res}-d63-s20-w5"), by.get(f"{res}-d255-s20-w5")
        w3, w7 = by.get(f"{res}-d{dnamed}-s20-w3"), by.get(f"{res}-d{dnamed}-s20-w7")
        parts = []
        if s10 and s40 and num(s10, "BRAM36eq") is not None and num(s40, "BRAM36eq") is not None:
            parts.append(f"storedDisparities 10 -> 40 costs {num(s40, 'BRAM36eq') - num(s10, 'BRAM36eq'):+g} BRAM36 "
                         f"and {num(s40, 'LUT') - num(s10, 'LUT'):+g} LUT at dispMax {dnamed}")
        if s10 and s40 and num(s10, "robotics_bad3") is not None and num(s40, "robotics_bad3") is not None:
            lead_in = "and moves" if parts else "storedDisparities 10 -> 40 moves"
            parts.append(f"{lead_in} bad-3 by {num(s40, 'robotics_bad3') - num(s10, 'robotics_bad3'):+.2f} points "
                         f"(robotics) / {num(s40, 'middlebury_bad3') - num(s10, 'middlebury_bad3'):+.2f} (middlebury)")
        if d63 and d255 and num(d63, "LUT") is not None and num(d255, "LUT") is not None:
            parts.append(f"dispMax 63 -> 255 costs {num(d255, 'LUT') - num(d63, 'LUT'):+g} LUT and "
                         f"{num(d255, 'BRAM36eq') - num(d63, 'BRAM36eq'):+g} BRAM36")
        if d63 and d255 and num(d63, "robotics_bad3") is not None and num(d255, "robotics_bad3") is not None:
            parts.append(f"changes bad-3 from {num(d63, 'robotics_bad3'):.2f} to {num(d255, 'robotics_bad3'):.2f} "
                         f"(robotics; middlebury {num(d63, 'middlebury_bad3'):.2f} to "
                         f"{num(d255, 'middlebury_bad3'):.2f})")
        if w3 and w7 and num(w3, "LUT") is not None and num(w7, "LUT") is not None:
            parts.append(f"windowSize 3 -> 7 costs {num(w7, 'LUT') - num(w3, 'LUT'):+g} LUT and "
                         f"{num(w7, 'BRAM36eq') - num(w3, 'BRAM36eq'):+g} BRAM36 and moves robotics bad-3 from "
                         f"{num(w3, 'robotics_bad3'):.2f} to {num(w7, 'robotics_bad3'):.2f}")
        if parts:
            out.append(f"- **{res}**: " + "; ".join(parts) + ".")
        # Accuracy advice (from the golden model: final): the cheapest setting within a margin of the best.
        acc = []
        for pset in grid.PARAMETER_SETS:
            k = f"{pset}_bad3"
            ds = sorted((int(r["dispMax"]), num(r, k)) for r in rows if r["resolution"] == res and c1(r)
                        and r["storedDisparities"] == "20" and r["windowSize"] == "5" and num(r, k) is not None)
            ss = sorted((int(r["storedDisparities"]), num(r, k)) for r in rows if r["resolution"] == res and c1(r)
                        and r["dispMax"] == str(dnamed) and r["windowSize"] == "5" and num(r, k) is not None)
            if ds:
                lo = min(v for _, v in ds)
                d_ok = next(d for d, v in ds if v <= lo + 0.5)
                acc.append(f"{pset}: dispMax {d_ok} is the smallest within 0.5 points of the best bad-3 "
                           f"({lo:.2f} %; " + ", ".join(f"d{d} {v:.2f}" for d, v in ds) + ")")
            if ss:
                lo = min(v for _, v in ss)
                s_ok = next(x for x, v in ss if v <= lo + 0.1)
                acc.append(f"storedDisparities {s_ok} is the smallest within 0.1 points of the best at dispMax "
                           f"{dnamed} (" + ", ".join(f"s{x} {v:.2f}" for x, v in ss) + ")")
        if acc:
            out.append(f"  Accuracy ({res}, golden model, final for these configurations): " + "; ".join(acc) + ".")
        best = [r for r in rows if r["resolution"] == res and c1(r) and num(r, "robotics_bad3") is not None]
        if best:
            for pset in grid.PARAMETER_SETS:
                b = min(best, key=lambda r: num(r, f"{pset}_bad3"))
                out.append(f"  Lowest {pset} bad-3 at {res}: {b['point']} ({num(b, f'{pset}_bad3'):.2f} %).")
    text = "\n".join(out) if out else "(no measured points yet)"
    if provisional:
        text = (f"> {MARK} The sentences below are computed from the current rows, but the `IElas` top does not yet "
                "hold every stage, so the resource and cycle deltas describe the partial top only. Rewrite this "
                "paragraph (the advice, not the numbers) once the whole accelerator is in the top and the full "
                "sweep has run.\n\n") + text
    return text


def markdown(rows, agreement, plot_files, grid_name, wall, outdir, hwcheck=None, runs=None):
    missing = missing_stages([r for r in rows if r.get("top_stages")])
    provisional = bool(missing)
    stages = sorted({r.get("top_stages", "") for r in rows if r.get("top_stages")})
    n_ok = sum(r["status"] == "ok" for r in rows)
    n_synth = sum(num(r, "LUT") is not None for r in rows)
    expected = [p.name for p in grid.points(grid_name)]
    absent = [p for p in expected if p not in {r["point"] for r in rows}]
    L = []
    L += ["# Parameter sweep: resources, throughput, memory and accuracy per configuration", "",
          "<!-- generated by scripts/sweep/report.py from docs/sweep/results.csv and docs/sweep/agreement.json; "
          "edit the script, not this file -->", ""]
    if grid_name == "quick":
        L += ["**SWEEP=quick** (CI): small configurations only; this file lives in build/sweep-quick/.", ""]
    if provisional:
        L += [f"> {MARK}: the `IElas` top of these runs holds only `{' / '.join(stages) or '?'}`; stages not yet in "
              f"it: {', '.join(missing)}. LUT, FF, BRAM, LUT levels, memory bits, cycles and latency below are for "
              "that partial top, not for iELAS as a whole. Accuracy columns come from the golden `ielas` model of "
              "the whole algorithm and are final for their configuration. Rerun `make sweep SWEEP=full` when the "
              "top is complete: every point whose Verilog changed is redone, accuracy comes from the cache.", ""]
    current = common.generator_hash()
    stale = [r["point"] for r in rows if r.get("generator_hash") and r["generator_hash"] != current]
    if stale and grid_name == "full":
        L += [f"> **STALE ROWS**: {len(stale)} of the rows below ({', '.join(stale)}) were measured with older "
              "generator sources than the ones in this tree (their `generator_hash` differs); the next `make sweep "
              "SWEEP=full` re-elaborates them and redoes every point whose Verilog changed.", ""]
    L += [f"Points: {len(rows)} of {len(expected)} recorded, {n_ok} ok, {n_synth} with synthesis figures"
          + (f"; not yet run: {', '.join(absent)}" if absent else "") + ".",
          f"Sum of the recorded points' wall times: {fmt(sum(num(r, 'wall_seconds') or 0 for r in rows), 0)} s "
          "(2 cores shared with other jobs; the synthesis and accuracy caches make reruns cheap)."
          + (f" This `make sweep` run: {wall} s." if wall else ""), ""]
    if runs:
        L += ["`make sweep SWEEP=full` runs (wall time, whole command: configurations, points, check, page):", "",
              "| date (UTC) | commit | wall s | points run (the others were up to date) |", "|---|---|---:|---:|"]
        L += [f"| {r['date']} | {r['commit']} | {r['wall_seconds']} | {r.get('points_run', '?')} |" for r in runs] + [""]

    L += ["## Commands", "",
          "```",
          "make sweep SWEEP=full          # every point (make -j N works), then the sum-vs-top check and this page",
          "make sweep-point POINT=kitti-d255-s20-w5   # one point: one row of docs/sweep/results.csv",
          "make sweep SWEEP=quick         # CI: 3 small points, everything under build/sweep-quick/, every step",
          "make test-sweep                # the sweep scripts' unit tests, then SWEEP=quick",
          "python3 scripts/sweep/grid.py names full   # the point names (for GNU parallel / a Slurm array)",
          "```", "",
          "A point is a configuration JSON written by the generator itself (`sbt \"run config DIR NAME:BASE:KEY=VALUE,...\"`,"
          " from `ElasParams`: SAD lanes and every other value derived there). For a batch scheduler: run "
          "`make sweep-configs` once, then `make sweep-point POINT=$NAME` per task, then `make sweep SWEEP=full` "
          "(it skips every recorded point) for the check and this page.", "",
          "Memory: `SYNTH_MEM_MB` caps each Yosys run (default 8192). The largest single run is the dense stage's "
          "glue at dispMax 255: about 7.4 GB at storedDisparities 20 and about 12 GB at 40. On a 23 GB, 2-core "
          "machine the grid ran as `make -j2 sweep SWEEP=full SYNTH_MEM_MB=10000`; the two d255-s40 points, "
          "recorded as failed at that cap, were then rerun one at a time with `make sweep-point POINT=... FORCE=1 "
          "SYNTH_MEM_MB=16000`.", ""]

    L += ["## Results", ""]
    cols = [("point", "point"), ("size", None), ("dispMax", "dispMax"), ("stored", "storedDisparities"),
            ("win", "windowSize"), ("lanes s/d", None), ("LUT", "LUT"), ("LUT-RAM", "LUTRAM_sites"), ("FF", "FF"), ("RAMB36", "RAMB36E1"),
            ("RAMB18", "RAMB18E1"), ("BRAM36eq", "BRAM36eq"), ("DSP", "DSP48E1"), ("LUT lvl", "lut_levels"),
            ("gen. memory bits", "gen_memory_bits"), ("gen. BRAM36 (capacity)", "gen_memory_bram36"),
            ("cycles/px", "cycles_per_pixel"), ("fps@200MHz (assumed)", "fps_200MHz"), ("latency rows", "latency_rows"),
            ("rob. bad-3", "robotics_bad3"), ("rob. D1", "robotics_d1"), ("rob. density", "robotics_density"),
            ("mb. bad-3", "middlebury_bad3"), ("mb. D1", "middlebury_d1"), ("mb. density", "middlebury_density"),
            ("commit", "commit"), ("status", "status")]
    L.append("| " + " | ".join(c for c, _ in cols) + " |")
    L.append("|---|---|" + "---:|" * (len(cols) - 4) + "---|---|")
    for r in rows:
        cells = []
        for c, k in cols:
            if c == "size":
                cells.append(f"{r['maxWidth']}x{r['maxHeight']}")
            elif c == "lanes s/d":
                cells.append(f"{r['supportLanes']}/{r['denseLanes']}")
            elif k in ("robotics_bad3", "robotics_d1", "robotics_density", "middlebury_bad3", "middlebury_d1",
                       "middlebury_density"):
                cells.append(fmt(r.get(k), 2) if r.get(k) else "-")
            elif k == "status":
                cells.append("ok" if r["status"] == "ok" else f"failed: {r['reason']}")
            elif k == "commit":  # the design a row was measured on (a partial rerun mixes commits)
                cells.append(r.get("commit") or "-")
            else:
                cells.append(fmt(r.get(k, "")))
        L.append("| " + " | ".join(cells) + " |")
    L.append("")
    L += ["Accuracy pairs: " + "; ".join(sorted({f"{r['resolution']}: {r['accuracy_pairs']}" for r in rows
                                                 if r.get("accuracy_pairs")})) + ".", ""]

    per_pair = []
    cache = os.path.join(ROOT, "sweep-cache", "accuracy") if grid_name == "full" else None
    for point in (NAMED_POINTS.values() if cache and os.path.isdir(cache) else ()):
        for pset in grid.PARAMETER_SETS:
            cname = grid.by_name(point).config_name(pset)
            files = sorted((f for f in os.listdir(cache) if f.rsplit("-", 1)[0] == cname),
                           key=lambda f: os.path.getmtime(os.path.join(cache, f)))
            if files:
                with open(os.path.join(cache, files[-1])) as fh:
                    a = json.load(fh)
                per_pair += [f"| {point} | {pset} | {x['pair']} | {x['region']} | {x['bad3']:.2f} | {x['d1']:.2f} | "
                             f"{x['density']:.2f} |" for x in a["pairs"]]
    if per_pair:
        L += ["Per pair at the named points (bad-3 and D1 with invalid = bad, %):", "",
              "| point | parameter set | pair | region | bad-3 | D1 | density |", "|---|---|---|---|---:|---:|---:|"]
        L += per_pair + [""]

    if grid_name == "full":
        L += ["## Against the iELAS paper", "",
              "The paper's figures are for the whole accelerator (Vivado, Virtex-7 XC7VX485T; Table II resources, "
              "Tables III-IV speed); ours are Yosys `synth_xilinx` (another mapper: compare orders of magnitude) "
              "and the cycle model at an assumed 200 MHz.", "",
              "| | size | LUT | FF | BRAM36eq | fps | latency |", "|---|---|---:|---:|---:|---:|---|"]
        lut_note = []
        for res, point in NAMED_POINTS.items():
            pp = PAPER[res]
            L.append(f"| iELAS paper, {res} | {pp['size']} | {fmt(pp['LUT'])} | {fmt(pp['FF'])} | {pp['BRAM36eq']} "
                     f"| {pp['fps']} | over a frame (whole-frame buffers) |")
            r = by_point(rows, point)
            if r:
                if num(r, "LUT") is not None and num(r, "LUTRAM_sites"):
                    lut_note.append(f"{point}: {fmt(r['LUT'])} logic + {fmt(r['LUTRAM_sites'])} as memory = "
                                    f"{fmt(num(r, 'LUT') + num(r, 'LUTRAM_sites'))}")
                L.append(f"| this generator, {point} | {r['maxWidth']}x{r['maxHeight']} | {fmt(r.get('LUT'))} | "
                         f"{fmt(r.get('FF'))} | {fmt(r.get('BRAM36eq'))} | {fmt(r.get('fps_200MHz'))} | "
                         f"{fmt(r.get('latency_rows'))} rows{' ' + MARK if provisional else ''} |")
            else:
                L.append(f"| this generator, {point} | | not run yet | | | | |")
        L.append("")
        if lut_note:
            L += ["Our LUT column counts LUTs used as logic; LUT sites used as memory (LUT-RAM, SRL) are the LUT-RAM "
                  "column. A Vivado slice-LUT count, as the paper's presumably is, includes both: "
                  + "; ".join(lut_note) + ".", ""]
        for res, point in NAMED_POINTS.items():
            r = by_point(rows, point)
            if r and r.get("lut_by_unit") and num(r, "LUT"):
                parts = []
                for item in r["lut_by_unit"].split():
                    unit, lut = item.rsplit(":", 1)
                    parts.append(f"{unit.replace('*', ' x ')}"
                                 f" {fmt(lut)} ({100 * float(lut) / num(r, 'LUT'):.0f} %)")
                L.append(f"Where the LUTs go at {point} (largest units, instances x one): " + ", ".join(parts) + ".")
                L.append("")

    L += ["## Sum of per-module runs vs whole-top runs", ""]
    if agreement and agreement.get("points"):
        L += [f"{agreement['criterion']} (scripts/sweep/agree.py, commit {agreement.get('commit', '?')}, "
              f"{agreement.get('date', '?')} UTC).", "",
              "| point | stages | LUT sum / top | FF sum / top | RAMB36 sum / top | RAMB18 sum / top | Yosys s top / modules | verdict |",
              "|---|---|---|---|---|---|---|---|"]
        for e in agreement["points"]:
            if "error" in e:
                L.append(f"| {e['point']} | | | | | | | failed: {e['error']} |")
                continue
            c, t, m = e["comparison"], e["top"], e["modules"]
            L.append(f"| {e['point']} | {', '.join(e['stages'])} | {m['LUT']} / {t['LUT']} ({c['LUT_diff_pct']:+.2f} %) | "
                     f"{m['FF']} / {t['FF']} ({c['FF_diff_pct']:+.2f} %) | {m['RAMB36E1']} / {t['RAMB36E1']} | "
                     f"{m['RAMB18E1']} / {t['RAMB18E1']} | {e['top_seconds']} / {e['modules_seconds']} | "
                     f"{'agree' if c['agree'] else '**DISAGREE**'} |")
        L.append("")
    else:
        L += ["Not run yet (`python3 scripts/sweep/agree.py --grid full`).", ""]

    L += ["## Hardware against the golden model and the cycle model", ""]
    if hwcheck and hwcheck.get("points"):
        stages_checked = sorted({e["stage"] for e in hwcheck["points"]})
        L += [f"`make sweep-hwcheck` (scripts/sweep/hwcheck.py, commit {hwcheck.get('commit', '?')}, "
              f"{hwcheck.get('date', '?')} UTC): a full-size pair through the Verilator model of the point's "
              f"configuration up to stage `{', '.join(stages_checked)}`, compared value for value with the golden "
              "dump of the same configuration, and its cycles beside the cycle model.", ""]
        if "top" not in stages_checked:
            L += [f"> {MARK}: checked up to `{', '.join(stages_checked)}`, not the disparity output (`top`): the "
                  "accuracy columns are not yet confirmed on the hardware.", ""]
        L += ["| point | pair | stage | values compared | bit-exact | cycles measured | cycles model | |",
              "|---|---|---|---:|---|---:|---:|---|"]
        for e in hwcheck["points"]:
            if "error" in e:
                L.append(f"| {e['point']} | {e.get('pair', '')} | {e['stage']} | | | | | failed: {e['error']} |")
                continue
            rel = "equal" if e["cycles_measured"] == e["cycles_model"] else (
                "within" if e["within_model"] else "**ABOVE the model**")
            L.append(f"| {e['point']} | {e['pair']} ({e['size']}) | {e['stage']} | {fmt(e['values_compared'])} | "
                     f"{'yes' if e['bit_exact'] else '**NO**'} | {fmt(e['cycles_measured'])} | "
                     f"{fmt(e['cycles_model'])} | {rel} |")
        L.append("")
    else:
        L += ["Not run yet (`make sweep-hwcheck`).", ""]

    if plot_files:
        L += ["## Plots", ""]
        for p in plot_files:
            rel = os.path.relpath(p, outdir)
            L += [f"![{os.path.basename(p)}]({rel})", ""]

    L += ["## How to choose", "", how_to_choose(rows, provisional), ""]
    failed = [r for r in rows if r["status"] != "ok"]
    if failed:
        L += ["## Failures", ""] + [f"- {r['point']}: {r['reason']}" for r in failed] + [""]

    L += ["## What each column means", "",
          "- **Grid**: `kitti` (1242x376) and `tsukuba` (640x480) x dispMax 63/127/255 x storedDisparities 10/20/40 at "
          "windowSize 5 (18 points), plus windowSize 3 and 7 at the named configurations (kitti dispMax 255, tsukuba "
          "dispMax 127, storedDisparities 20): 22 points, named `<resolution>-d<dispMax>-s<stored>-w<window>`. "
          "Everything else is the named configuration's default. The hardware is the robotics configuration; the "
          "middlebury twin (same card parameters) is used for its accuracy columns.",
          "- **lanes s/d**: support / dense SAD lanes, the lowest counts that keep 1 pixel per clock (`ElasParams."
          "supportLanesUsed` / `denseLanesUsed`).",
          "- **commit**: the commit the row was measured on (`make sweep-point` reruns one point, so after a partial "
          "rerun the rows can come from different designs).",
          "- **LUT, FF, RAMB36, RAMB18, DSP, LUT lvl**: Yosys 0.23 `synth_xilinx -family xc7 -flatten` (docs/"
          "synthesis.md), unit by unit down the module hierarchy (each module's own logic with its submodules as "
          "black boxes; a replicated unit such as the dense stage's `DescriptorSad` synthesised once and counted "
          "per instance) and summed; results cached by module Verilog hash in `sweep-cache/`, so points "
          "share units. LUT counts LUT1..LUT6 used as logic; LUT-RAM counts the LUT sites of LUT-RAM and SRL "
          "primitives (RAM64M = 4, RAM128X1D = 4, SRLC32E = 1, ...), so LUT + LUT-RAM is a Vivado-style slice-LUT "
          "count. BRAM36eq = "
          "RAMB36 + RAMB18/2. LUT lvl = the deepest module's longest combinational path in LUT levels (a clock "
          "proxy). Each Yosys run has a time limit (SYNTH_TIMEOUT, default 3600 s) and an address-space limit "
          "(SYNTH_MEM_MB, default 8192).",
          "- **gen. memory bits**: the generator's own accounting (`IElas.memorySummary`, printed by `make verilog`); "
          "gen. BRAM36 = bits / 36864, a capacity lower bound that ignores the port width (a 96-bit-wide buffer "
          "uses more blocks than its bits need).",
          "- **Cycle model** (analytic): one W x H frame at 1 pixel per clock with no input gaps and no "
          "back-pressure takes the no-stall bound of docs/interfaces.md section 4, cycles = W*H + latencyRows*W + c, "
          "with latencyRows and c from `IElas.latencyRows` / `IElas.cycleSlack` (the same figures the stage tests "
          "check as a bound). cycles/px = cycles / (W*H); fps = 200 MHz / cycles at an assumed 200 MHz clock (no blanking "
          "counted; measured clocks: docs/timing.md). "
          "At least two points per resolution, kitti d255 among them, go through the Verilator hardware "
          "(`make sweep-hwcheck`, section above).",
          "- **Accuracy**: the golden `ielas` model with the point's configuration (robotics and its middlebury "
          "twin), fresh process per pair, scored as docs/evaluation.md defines it: bad-3 = % of ground-truth pixels "
          "with |d - gt| > 3, invalid counted as bad; D1 = |err| > 3 px and > 5 % of gt, invalid = bad; density = % "
          "with a valid prediction. Mean over pairs. kitti: KITTI 2012 #70 (noc) and KITTI 2015 #46 (all). "
          "tsukuba: centred 640x480 crops of Middlebury 2006 Reindeer and Wood2 (all) and 2014 Motorcycle (noc). "
          "Cached by configuration bytes + golden binary hash (`sweep-cache/accuracy/`).",
          "- **Rerun rule**: a point is skipped when results.csv holds its configuration hash, its design hash "
          "(sha256 of the emitted Verilog; before elaborating, the generator-source hash stands in) and the golden "
          "binary hash. `FORCE=1` reruns. A point that fails (a `require` at elaboration, a Yosys time or memory "
          "limit, a golden error) is recorded with the reason and the sweep goes on.", ""]
    return "\n".join(L)


def by_point(rows, name):
    return next((r for r in rows if r["point"] == name), None)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", choices=["full", "quick"], required=True)
    ap.add_argument("--wall", help="wall seconds of the sweep run, for the page")
    ap.add_argument("--no-plots", action="store_true")
    args = ap.parse_args()
    if args.grid == "full":
        data_dir, md_path = os.path.join(ROOT, "docs", "sweep"), os.path.join(ROOT, "docs", "sweep.md")
    else:
        data_dir = os.path.join(ROOT, "build", "sweep-quick")
        md_path = os.path.join(data_dir, "sweep.md")
    rows = common.Results(os.path.join(data_dir, "results.csv")).read()
    if not rows:
        print(f"report: no rows in {os.path.join(data_dir, 'results.csv')}", file=sys.stderr)
        return 1
    agreement = None
    if os.path.exists(os.path.join(data_dir, "agreement.json")):
        with open(os.path.join(data_dir, "agreement.json")) as fh:
            agreement = json.load(fh)
    hwcheck = None
    if args.grid == "full" and os.path.exists(os.path.join(data_dir, "hwcheck.json")):
        with open(os.path.join(data_dir, "hwcheck.json")) as fh:
            hwcheck = json.load(fh)
    runs = []
    if args.grid == "full":  # the wall time of every full sweep run, kept across sessions
        runs_csv = os.path.join(data_dir, "runs.csv")
        if args.wall:
            new = not os.path.exists(runs_csv)
            # Points (re)run by this invocation: rows dated from its start on (minute resolution).
            since = time.strftime("%Y-%m-%d %H:%M", time.gmtime(time.time() - float(args.wall) - 59))
            ran = sum(r.get("date", "") >= since for r in rows)
            with open(runs_csv, "a", newline="") as fh:
                w = csv.writer(fh, lineterminator="\n")
                if new:
                    w.writerow(["date", "commit", "wall_seconds", "points_run"])
                w.writerow([time.strftime("%Y-%m-%d %H:%M", time.gmtime()), subprocess.run(
                    ["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip(),
                    args.wall, ran])
        if os.path.exists(runs_csv):
            with open(runs_csv, newline="") as fh:
                runs = list(csv.DictReader(fh))
    plot_files = [] if args.no_plots else plots(rows, data_dir)
    text = markdown(rows, agreement, plot_files, args.grid, args.wall, os.path.dirname(md_path), hwcheck, runs)
    with open(md_path, "w") as fh:
        fh.write(text)
    print(f"report: wrote {os.path.relpath(md_path, ROOT)}" +
          (f" and {len(plot_files)} plots in {os.path.relpath(data_dir, ROOT)}" if plot_files else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
