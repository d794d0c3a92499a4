#!/usr/bin/env bash
# `make bench`: the whole accelerator in Verilator (C++ harness, scripts/sim.sh bench) at the `kitti`, `kitti-c8`
# (one pixel every 8 clocks) and `tsukuba` presets, 3 frames back to back each, with no stalls and with 10 % gaps/stalls; writes
# docs/performance.md with the iELAS paper's figures beside ours. BENCH_CONFIGS overrides the presets.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DATA="${IELAS_DATA:-$ROOT/../shared/data}"
EVAL="${IELAS_EVAL:-$ROOT/golden/build/ielas-eval}"
OUT="$ROOT/build/bench"
mkdir -p "$OUT"
pair_for() { # the benchmark pair of a preset: KITTI 2012 #70 (1241x376), or a centred 640x480 Reindeer crop
  case "$1" in
    tsukuba*)
      R="$DATA/middlebury2006/Reindeer"
      [ -r "$R/view1.png" ] || return 0 # no data: sim.sh falls back to the synthetic scene
      "$EVAL" crop --in "$R/view1.png" --out "$OUT/reindeer-left.png" --width 640 --height 480
      "$EVAL" crop --in "$R/view5.png" --out "$OUT/reindeer-right.png" --width 640 --height 480
      echo "--left $OUT/reindeer-left.png --right $OUT/reindeer-right.png" ;;
    *) K="$DATA/kitti2012/training"
       [ -r "$K/image_0/000070_10.png" ] || return 0
       echo "--left $K/image_0/000070_10.png --right $K/image_1/000070_10.png" ;;
  esac
}
{
  echo "# Performance: the whole accelerator in Verilator"
  echo
  echo "Written by \`make bench\` ($(date -u +%Y-%m-%d)); every number below is measured by the C++ harness"
  echo "(\`docs/simulation.md\`) on the Verilog that \`make verilog\` emits. cycles/pixel is sustained over 3 frames back"
  echo "to back (total cycles / total pixels, the pipeline fill included once); latency is the largest, over rows y, of"
  echo "(cycle of the last output pixel of row y - cycle of the last input pixel of row y) / W, rounded up. fps is at an"
  echo "**assumed** 200 MHz clock, not a measured one: \`docs/timing.md\` has the place-and-route and static-timing"
  echo "figures (\`make timing\`). The iELAS paper reports 57.5 fps at 1242x375 and 57.6 fps at 640x480 (whole frames"
  echo "buffered, Virtex-7)."
  echo
} > "$OUT/performance.md"
for config in ${BENCH_CONFIGS:-kitti kitti-c8 tsukuba}; do
  make -C "$ROOT" --no-print-directory verilog CONFIG="$config" > "$OUT/verilog-$config.log"
  # shellcheck disable=SC2046
  "$ROOT/scripts/sim.sh" bench "$config" $(pair_for "$config")
  # Steady state: one more frame after the first costs (cycles of 3 frames - cycles of 1 frame) / 2.
  # shellcheck disable=SC2046
  "$ROOT/scripts/sim.sh" run "$config" $(pair_for "$config") --out "$OUT/$config/one" --frames 1 > "$OUT/$config/one.log"
  c1="$(sed -n 's/^cycles: //p' "$OUT/$config/one.log")"
  c3="$(sed -n 's/^| no stalls | [^|]* | 3 | \([0-9]*\) .*/\1/p' "$OUT/$config/performance.md")"
  px="$(sed -n 's/^ielas_sim: \([0-9]*\)x\([0-9]*\) .*/\1 \2/p' "$OUT/$config/one.log" | awk '{ print $1 * $2 }')"
  { echo "## \`$config\`"; echo; cat "$OUT/$config/performance.md"; echo
    awk -v c1="$c1" -v c3="$c3" -v n="$px" 'BEGIN { printf "Steady state (no stalls): one frame alone takes %d cycles, three take %d, so each further frame costs %d cycles = %.4f cycles/pixel = %.1f fps at an assumed 200 MHz.\n", c1, c3, (c3 - c1) / 2, (c3 - c1) / 2 / n, 200e6 / ((c3 - c1) / 2) }'
    echo; } >> "$OUT/performance.md"
done
sed "s|$ROOT/||g; s|build/bench/reindeer-left.png|build/bench/reindeer-left.png (centred 640x480 crop of Middlebury 2006 Reindeer view1)|" "$OUT/performance.md" > "$ROOT/docs/performance.md"
echo "wrote docs/performance.md"
