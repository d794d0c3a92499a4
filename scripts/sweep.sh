#!/usr/bin/env bash
# The parameter sweep (docs/sweep.md). `make sweep SWEEP=full|quick` calls this; `make -j N sweep` works too (each
# point is its own make target, `make sweep-point POINT=<name>`).
#   scripts/sweep.sh configs full|quick   write the grid's configuration JSONs (one sbt run) into build/sweep*/configs
#   scripts/sweep.sh quick                the CI sweep: small configurations, everything under build/sweep-quick/,
#                                         every step every time (fresh cache), then the report and the checks
#   scripts/sweep.sh report full|quick    docs/sweep.md and docs/sweep/*.png (full) or build/sweep-quick/ (quick)
# Environment: as scripts/sweep/point.py (SYNTH_TIMEOUT, SYNTH_MEM_MB, SWEEP_ELAB_TIMEOUT, IELAS_GOLDEN, ...),
# SWEEP_PYTHON (the venv's python for the plots; default build/sweep-venv/bin/python).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
die() { echo "sweep: $*" >&2; exit 1; }
grid_dir() { case "$1" in full) echo build/sweep ;; quick) echo build/sweep-quick ;; *) die "SWEEP must be full or quick, not '$1'" ;; esac; }
PY="${SWEEP_PYTHON:-build/sweep-venv/bin/python}"

case "${1:-}" in
  configs)
    dir="$(grid_dir "${2:-}")/configs"
    specs="$(python3 scripts/sweep/grid.py specs "$2")"
    rm -rf "$dir.tmp"
    mkdir -p "$(dirname "$dir")"
    # One sbt run writes every JSON of the grid (ElasParams derives the rest); replaced only when it succeeds.
    # An illegal point leaves NAME.error (its require message) and exit 1; sweep-point records it as a failure.
    flock build/sweep-sbt.lock ./sbt "run config $dir.tmp $specs" </dev/null \
      || ls "$dir.tmp"/*.error >/dev/null 2>&1 || die "writing the configurations failed"
    rm -rf "$dir"; mv "$dir.tmp" "$dir"
    ;;
  quick)
    d=build/sweep-quick
    unset SWEEP_RESULTS SWEEP_CACHE SWEEP_WORK  # quick reads and writes only under $d
    rm -rf "$d"
    start=$(date +%s)
    # SWEEP=quick never touches docs/sweep/ or sweep-cache/ (committed): checked at the end.
    snapshot() { { find docs/sweep docs/sweep.md sweep-cache -type f -printf '%p %s %T@\n' 2>/dev/null || true; } | sort | sha256sum; }
    before="$(snapshot)"
    "$0" configs quick
    # Sum of per-module runs vs the whole top, on one quick point (the committed check runs on two full points).
    # Its whole-top Yosys run is the longest single step, so it runs beside the points (2 cores in CI).
    python3 scripts/sweep/agree.py --grid quick > "$d/agree.log" 2>&1 &
    agree_pid=$!
    trap 'kill "$agree_pid" 2>/dev/null || true' EXIT  # a failing point must not leave it running
    for p in $(python3 scripts/sweep/grid.py names quick); do
      python3 scripts/sweep/point.py "$p" --force
    done
    agree_rc=0
    wait "$agree_pid" || agree_rc=$?
    cat "$d/agree.log"
    [ "$agree_rc" -eq 0 ] || die "agree.py failed (exit $agree_rc): the sum of modules and the whole top disagree or a run failed"
    "$PY" scripts/sweep/report.py --grid quick --wall "$(( $(date +%s) - start ))"
    python3 scripts/sweep/check.py --grid quick
    [ "$(snapshot)" = "$before" ] || die "SWEEP=quick changed docs/sweep/ or sweep-cache/ (it must write only under $d)"
    echo "sweep quick: passed in $(( $(date +%s) - start )) s"
    ;;
  report)
    g="${2:-full}"; grid_dir "$g" >/dev/null
    "$PY" scripts/sweep/report.py --grid "$g"
    ;;
  *) sed -n '2,11p' "$0"; exit 2 ;;
esac
