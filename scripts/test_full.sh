#!/usr/bin/env bash
# `make test-full` (not in CI): full-size frames through the whole accelerator in Verilator (the C++ harness),
# each compared with the golden model (0 mismatches required) and scored against its ground truth:
#   kitti   -- KITTI 2012 #70, 1241x376 (image_0/image_1, disp_noc)
#   tsukuba -- a centred 640x480 crop of Middlebury 2006 Reindeer (view1/view5, disp1 at scale 2)
# Writes build/test-full/<name>/ (the demo's outputs) and build/test-full/summary.txt.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DATA="${IELAS_DATA:-$ROOT/../shared/data}"
EVAL="${IELAS_EVAL:-$ROOT/golden/build/ielas-eval}"
OUT="$ROOT/build/test-full"
mkdir -p "$OUT"
[ -d "$DATA/kitti2012" ] && [ -d "$DATA/middlebury2006" ] || { echo "test-full: needs $DATA (kitti2012, middlebury2006)" >&2; exit 1; }

R="$DATA/middlebury2006/Reindeer"
for role in view1:left view5:right disp1:gt; do
  "$EVAL" crop --in "$R/${role%%:*}.png" --out "$OUT/reindeer-${role##*:}.png" --width 640 --height 480
done

status=0
: > "$OUT/summary.txt"
run() { # name config demo-args...
  local name="$1" config="$2"; shift 2
  echo "== $name ($config)" | tee -a "$OUT/summary.txt"
  make -C "$ROOT" --no-print-directory verilog CONFIG="$config" >/dev/null
  set +e
  "$ROOT/scripts/sim.sh" demo "$config" --out "$OUT/$name" "$@" 2>&1 | tee "$OUT/$name.log"
  local code=${PIPESTATUS[0]}
  set -e
  grep -E '^(mismatches|cycles/pixel|fps@200MHz|latency rows|bad-3|sim wall time|sim build)' "$OUT/$name.log" >> "$OUT/summary.txt" || true
  if [ "$code" -ne 0 ] || ! grep -q '^mismatches: 0$' "$OUT/$name.log"; then
    echo "test-full: $name FAILED (exit $code)" | tee -a "$OUT/summary.txt"; status=1
  fi
}
run kitti2012-000070 kitti
run reindeer-640x480 tsukuba --left "$OUT/reindeer-left.png" --right "$OUT/reindeer-right.png" --gt "$OUT/reindeer-gt.png" --gt-scale 2
echo "== summary (build/test-full/summary.txt)"; cat "$OUT/summary.txt"
[ "$status" -eq 0 ] && echo "make test-full: all passed"
exit "$status"
