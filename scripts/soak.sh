#!/usr/bin/env bash
# The soak run (`make soak`, docs/simulation.md): many frames of random sizes back to back through one Verilated
# IElas, with random input gaps and output stalls and one malformed frame in ten, every good frame bit-exact
# against the golden model.
#
# Usage: scripts/soak.sh CONFIG [--stub] [--frames N] [--seed S] [--data DIR] [--out DIR] [--malformed-every K]
#   CONFIG    a configuration name or JSON file (the Verilog is build/verilog/<config>/, as scripts/sim.sh builds it)
#   --frames  frames to stream (default 200)          --seed  the plan's and the run's seed (default 1)
#   --data    the dataset folder cropped for good frames (default $IELAS_DATA or ../shared/data; missing = synthetic
#             frames only)
#   --out     the work directory (default build/soak/<config>): manifest.txt, frames/, golden/, soak.log
#   --malformed-every K  one malformed frame in K (default 10; 0 = none)
#   --stub    the stand-in top (scripts/sim.sh --stub): plumbing only, its output is not the accelerator's
# Steps: scripts/sim.sh build; ielas_sim soak-plan (crops and synthetic pairs, the manifest); the golden model's
# disparity.npy for every distinct good frame; ielas_sim soak. Exit code: ielas_sim soak's (0 = passed).
# Environment: IELAS_GOLDEN (default golden/build/ielas-golden), IELAS_CONFIG_DIR, SIM_JOBS (scripts/sim.sh).
set -euo pipefail

die() { echo "soak.sh: $*" >&2; exit 1; }

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
[ $# -ge 1 ] || { sed -n '2,/^set -euo/p' "$0" | sed '$d' >&2; exit 1; }
CONFIG="$1"; shift
STUB=() FRAMES=200 SEED=1 DATA="${IELAS_DATA:-$ROOT/../shared/data}" OUT="" EVERY=10
while [ $# -gt 0 ]; do
  case "$1" in
    --stub) STUB=(--stub) ;;
    --frames|--seed|--data|--out|--malformed-every)
      [ $# -ge 2 ] || die "$1 needs a value"
      case "$1" in
        --frames) FRAMES="$2" ;; --seed) SEED="$2" ;; --data) DATA="$2" ;; --out) OUT="$2" ;; --malformed-every) EVERY="$2" ;;
      esac
      shift ;;
    *) die "unknown option $1" ;;
  esac
  shift
done
case "$FRAMES" in ''|*[!0-9]*) die "--frames wants a positive integer, got '$FRAMES'" ;; esac
[ "$FRAMES" -ge 1 ] || die "--frames wants a positive integer, got '$FRAMES'"
case "$SEED" in ''|*[!0-9]*) die "--seed wants a non-negative integer, got '$SEED'" ;; esac

NAME="$(basename "$CONFIG")"; NAME="${NAME%.json}"
CONFIG_FILE="$("$ROOT/scripts/sim.sh" config "$CONFIG")" || exit 1
GOLDEN="${IELAS_GOLDEN:-$ROOT/golden/build/ielas-golden}"
[ -x "$GOLDEN" ] || die "no golden model $GOLDEN (make golden)"
[ -n "$OUT" ] || OUT="$ROOT/build/soak/$NAME$([ ${#STUB[@]} -gt 0 ] && echo -stub || true)"

t0=$(date +%s.%N)
"$ROOT/scripts/sim.sh" build "$CONFIG_FILE" "${STUB[@]}" || exit 1
BIN="$("$ROOT/scripts/sim.sh" path "$CONFIG_FILE" "${STUB[@]}")"

rm -rf "$OUT/frames" "$OUT/golden" "$OUT/manifest.txt" "$OUT/soak.log"
mkdir -p "$OUT/golden"
"$BIN" soak-plan --config "$CONFIG_FILE" --frames "$FRAMES" --seed "$SEED" --data "$DATA" --out "$OUT" \
  --malformed-every "$EVERY" || die "soak-plan failed"

# the golden model's output for every distinct good frame (fields: index kind W H gap stall a b source left right expected)
tg=$(date +%s.%N)
n=0
TMP="$OUT/golden/.dump"
while read -r left right expect; do
  [ -f "$OUT/$expect" ] && continue
  rm -rf "$TMP"
  "$GOLDEN" dump --mode ielas --config "$CONFIG_FILE" --left "$OUT/$left" --right "$OUT/$right" --out "$TMP" >/dev/null \
    || die "the golden model failed on $left"
  mv "$TMP/disparity.npy" "$OUT/$expect"
  n=$((n + 1))
done < <(awk '!/^#/ && $2 == "good" { print $10, $11, $12 }' "$OUT/manifest.txt")
rm -rf "$TMP"
awk -v n="$n" -v a="$tg" -v b="$(date +%s.%N)" 'BEGIN { printf "soak: golden model on %d distinct good frames: %.1f s\n", n, b - a }'

set +e
"$BIN" soak --manifest "$OUT/manifest.txt" --config "$CONFIG_FILE" --seed "$SEED" | tee "$OUT/soak.log"
code=${PIPESTATUS[0]}
set -e
awk -v a="$t0" -v b="$(date +%s.%N)" -v v="$(verilator --version | cut -d' ' -f2)" \
  'BEGIN { printf "soak: total wall time %.1f s (build, plan, golden model, simulation); Verilator %s\n", b - a, v }' \
  | tee -a "$OUT/soak.log"
exit "$code"
