#!/usr/bin/env bash
# The C++ Verilator harness of the IElas top (src/test/cpp/ielas_sim.cpp): build it, run it, benchmark it.
#
# Usage:
#   scripts/sim.sh build CONFIG [--stub]                 build (or reuse) build/sim/<config>/ielas_sim
#   scripts/sim.sh run   CONFIG [--stub] HARNESS-ARGS... build if needed, then run ielas_sim --config CONFIG ...
#   scripts/sim.sh path  CONFIG [--stub]                 print the binary's path (no build)
#   scripts/sim.sh config CONFIG                          print the configuration file's absolute path (no build)
#   scripts/sim.sh bench CONFIG [--stub] [--left L --right R] [--frames N]
#                        the `make bench` numbers: N frames (default 3) of a pair (default KITTI 2012 000070) with no
#                        stalls, then with 10 % input gaps and 10 % output stalls (seed 1); writes
#                        build/bench/<config>/performance.md (a Markdown table) and the two runs' logs
#   scripts/sim.sh demo  CONFIG [--stub] [--left L --right R] [--gt G [--gt-scale S]] [--out DIR]
#                        the `make run` job: the golden model's dump of the pair (default KITTI 2012 000070 with
#                        its disp_noc ground truth; without ../shared/data, the synthetic scene of ielas-synth
#                        at up to 640x360) into DIR/golden, the harness with --expect and --images into
#                        DIR/hardware, then the report lines mismatches / cycles/pixel / fps@200MHz / latency rows
#                        / bad-3 (invalid = bad; with ground truth) and DIR/disparity.png (colourised). DIR
#                        defaults to build/run. Exit code: the harness's (5 = mismatches).
#   e.g. scripts/sim.sh run kitti --left L.png --right R.png --out build/simulate/kitti-top --frames 3
#
# CONFIG is a configuration name or a JSON file (its base name names the build directory), as in the Makefile.
# The model is the Verilog that `make verilog CONFIG=` wrote to build/verilog/<config>/ (every *.sv, plus lint.vlt).
# --stub uses the hand-written stand-in top src/test/cpp/stub/IElas.sv instead (sized from the configuration's
# maxWidth/maxHeight), built into build/sim/stub-<config>/; it exists to develop and test the harness.
#
# A rebuild happens only when the hash of its inputs changes: the Verilog, the harness sources, the Verilator
# version and this script's build command. The build time is printed on its own line ("sim build: ..."), so
# the harness's own report (wall time of the simulation) never includes it.
# Environment: SIM_JOBS (default 2), IELAS_CONFIG_DIR (configurations, default golden/configs), IELAS_DATA
# (default ../shared/data), IELAS_GOLDEN / IELAS_EVAL (default golden/build/ielas-golden, ielas-eval).
set -euo pipefail

die() { echo "sim.sh: $*" >&2; exit 1; }

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
JOBS="${SIM_JOBS:-2}"

[ $# -ge 2 ] || { sed -n '2,/^set -euo/p' "$0" | sed '$d' >&2; exit 1; }
CMD="$1" CONFIG="$2"
shift 2
STUB=0
if [ "${1:-}" = "--stub" ]; then STUB=1; shift; fi
case "$CMD" in build|run|path|bench|demo|config) ;; *) die "unknown command '$CMD' (build, run, path, bench, demo, config)" ;; esac

NAME="$(basename "$CONFIG")"; NAME="${NAME%.json}"
case "$CONFIG" in
  */*|*.json) CONFIG_FILE="$CONFIG" ;;
  *) CONFIG_FILE="${IELAS_CONFIG_DIR:-$ROOT/golden/configs}/$CONFIG.json" ;;
esac
[ -f "$CONFIG_FILE" ] || die "unknown configuration '$CONFIG' (no file $CONFIG_FILE)"
CONFIG_FILE="$(cd "$(dirname "$CONFIG_FILE")" && pwd)/$(basename "$CONFIG_FILE")"
if [ "$CMD" = config ]; then echo "$CONFIG_FILE"; exit 0; fi

if [ "$STUB" = 1 ]; then
  DIR="$ROOT/build/sim/stub-$NAME"
  read -r MAXW MAXH < <(python3 -c 'import json,sys; c=json.load(open(sys.argv[1])); print(c["maxWidth"], c["maxHeight"])' "$CONFIG_FILE") \
    || die "configuration $CONFIG_FILE: cannot read maxWidth/maxHeight"
  VERILOG=("$ROOT/src/test/cpp/stub/IElas.sv")
  VFLAGS=("-GMAX_W=$MAXW" "-GMAX_H=$MAXH")
else
  DIR="$ROOT/build/sim/$NAME"
  VDIR="$ROOT/build/verilog/$NAME"
  mapfile -t VERILOG < <(ls "$VDIR"/*.sv 2>/dev/null | sort)
  [ ${#VERILOG[@]} -gt 0 ] || die "no Verilog in build/verilog/$NAME (run make verilog CONFIG=$CONFIG first)"
  VFLAGS=()
  # The harness drives the full top's ports; a top without them (e.g. the descriptor-only IElas) cannot build.
  [ -f "$VDIR/IElas.sv" ] || die "no IElas.sv in build/verilog/$NAME"
  for port in io_in_valid io_in_ready io_in_bits_left io_in_bits_right io_in_bits_sof io_in_bits_eol io_frameWidth \
              io_frameHeight io_error io_clearError io_out_valid io_out_ready io_out_bits_data io_out_bits_sof \
              io_out_bits_eol io_out_bits_eof io_errorCauses io_frameAborted; do
    grep -qw "$port" "$VDIR/IElas.sv" \
      || die "build/verilog/$NAME/IElas.sv has no port $port: the harness needs the full top's ports (docs/simulation.md)"
  done
  [ -f "$VDIR/lint.vlt" ] && VERILOG=("$VDIR/lint.vlt" "${VERILOG[@]}")
fi
BIN="$DIR/ielas_sim"
if [ "$CMD" = path ]; then echo "$BIN"; exit 0; fi

HARNESS=("$ROOT/src/test/cpp/ielas_sim.cpp" "$ROOT/src/test/cpp/soak.cpp" "$ROOT/golden/src/image_io.cpp" "$ROOT/golden/src/npy.cpp")
HEADERS=("$ROOT/src/test/cpp/harness.hpp" "$ROOT/golden/include/ielas/image_io.hpp" "$ROOT/golden/include/ielas/npy.hpp" "$ROOT/golden/include/ielas/config.hpp")
OPENCV_CFLAGS="$(pkg-config --cflags opencv4)" || die "OpenCV 4 not found (make deps-golden)"
OPENCV_LIBS="$(pkg-config --libs opencv4)"

build() {
  mkdir -p "$DIR"
  # Compile-time defaults of the harness: the configuration it was built for, and where configurations live.
  cat > "$DIR/sim_config.h" <<EOF
#define IELAS_SIM_CONFIG "$NAME"
#define IELAS_SIM_CONFIG_DIR "$(dirname "$CONFIG_FILE")"
EOF
  VCMD=(verilator --cc --exe --build -O3 --x-assign fast --x-initial fast -Wno-fatal --top-module IElas -j "$JOBS"
        -Mdir "$DIR/obj" -o "$BIN" "${VFLAGS[@]}"
        -CFLAGS "-std=c++17 -O2 -I$ROOT/golden/include $OPENCV_CFLAGS -include $DIR/sim_config.h"
        -LDFLAGS "$OPENCV_LIBS"
        -MAKEFLAGS "OPT_FAST=-O2 OPT_GLOBAL=-O2 OPT_SLOW=-O1"
        "${HARNESS[@]}" "${VERILOG[@]}")
  local hash
  hash="$( { verilator --version; printf '%s\n' "${VCMD[@]}"; cat "$DIR/sim_config.h" "${HARNESS[@]}" "${HEADERS[@]}" "${VERILOG[@]}"; } \
          | sha256sum | cut -d' ' -f1)"
  if [ -x "$BIN" ] && [ "$(cat "$DIR/hash" 2>/dev/null)" = "$hash" ]; then
    echo "sim build: up to date (${BIN#$ROOT/})"
    return
  fi
  rm -f "$DIR/hash" "$BIN"
  local t0 t1
  t0=$(date +%s.%N)
  if ! "${VCMD[@]}" > "$DIR/build.log" 2>&1; then
    tail -n 30 "$DIR/build.log" >&2
    die "Verilator build failed (log: ${DIR#$ROOT/}/build.log)"
  fi
  t1=$(date +%s.%N)
  echo "$hash" > "$DIR/hash"
  awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f\n", b - a }' > "$DIR/build_seconds"
  awk -v a="$t0" -v b="$t1" -v bin="${BIN#$ROOT/}" 'BEGIN { printf "sim build: %.1f s (%s)\n", b - a, bin }'
}

BUILD_LINE="$(build)"
echo "$BUILD_LINE"
if [ "$CMD" = run ]; then
  exec "$BIN" --config "$CONFIG_FILE" "$@"
fi
[ "$CMD" = build ] && exit 0

DATA="${IELAS_DATA:-$ROOT/../shared/data}"
LEFT="$DATA/kitti2012/training/image_0/000070_10.png"
RIGHT="$DATA/kitti2012/training/image_1/000070_10.png"
GT="" GT_SCALE="" RUN_OUT="$ROOT/build/run"
[ -r "$LEFT" ] && GT="$DATA/kitti2012/training/disp_noc/000070_10.png"
FRAMES=3
while [ $# -gt 0 ]; do
  case "$1" in
    --left) [ $# -ge 2 ] || die "--left needs a value"; LEFT="$2"; GT=""; shift ;;
    --right) [ $# -ge 2 ] || die "--right needs a value"; RIGHT="$2"; shift ;;
    --frames) [ "$CMD" = bench ] && [ $# -ge 2 ] || die "$CMD: --frames is a bench option with a value"; FRAMES="$2"; shift ;;
    --gt) [ "$CMD" = demo ] && [ $# -ge 2 ] || die "$CMD: --gt is a demo option with a value"; GT="$2"; shift ;;
    --gt-scale) [ "$CMD" = demo ] && [ $# -ge 2 ] || die "$CMD: --gt-scale is a demo option with a value"; GT_SCALE="$2"; shift ;;
    --out) [ "$CMD" = demo ] && [ $# -ge 2 ] || die "$CMD: --out is a demo option with a value"; RUN_OUT="$2"; shift ;;
    *) die "$CMD: unknown option $1" ;;
  esac
  shift
done
if [ "$LEFT" = "$DATA/kitti2012/training/image_0/000070_10.png" ] && [ ! -r "$LEFT" ]; then
  # no ../shared/data (a user's machine): the project's synthetic scene, cut to the configuration's maximum
  SYNTH="$(dirname "${IELAS_GOLDEN:-$ROOT/golden/build/ielas-golden}")/ielas-synth"
  [ -x "$SYNTH" ] || die "$CMD: no KITTI pair in $DATA and no $SYNTH (make golden)"
  read -r MAXW MAXH < <(python3 -c 'import json,sys; c=json.load(open(sys.argv[1])); print(c["maxWidth"], c["maxHeight"])' "$CONFIG_FILE")
  SDIR="$ROOT/build/run/synth-$NAME"
  mkdir -p "$SDIR"
  "$SYNTH" --out "$SDIR" --width $(( MAXW < 640 ? MAXW : 640 )) --height $(( MAXH < 360 ? MAXH : 360 )) >/dev/null \
    || die "$CMD: $SYNTH failed"
  LEFT="$SDIR/left.pgm" RIGHT="$SDIR/right.pgm" GT="$SDIR/disp_noc.png"
fi
[ -r "$LEFT" ] && [ -r "$RIGHT" ] || die "$CMD: cannot read the pair $LEFT | $RIGHT (give --left and --right)"

if [ "$CMD" = demo ]; then
  GOLDEN="${IELAS_GOLDEN:-$ROOT/golden/build/ielas-golden}"
  EVAL="${IELAS_EVAL:-$ROOT/golden/build/ielas-eval}"
  [ -x "$GOLDEN" ] && [ -x "$EVAL" ] || die "demo: $GOLDEN or $EVAL missing (make golden)"
  mkdir -p "$RUN_OUT"
  echo "run: $NAME, pair $LEFT | $RIGHT"
  "$GOLDEN" dump --mode ielas --config "$CONFIG_FILE" --left "$LEFT" --right "$RIGHT" --out "$RUN_OUT/golden" >/dev/null \
    || die "demo: the golden model failed"
  set +e
  "$BIN" --config "$CONFIG_FILE" --left "$LEFT" --right "$RIGHT" --out "$RUN_OUT/hardware" \
    --expect "$RUN_OUT/golden/disparity.npy" --images
  code=$?
  set -e
  [ -f "$RUN_OUT/hardware/disparity.npy" ] || exit "$code"
  if [ -n "$GT" ]; then
    [ -r "$GT" ] || die "demo: cannot read ground truth $GT"
    line="$("$EVAL" score --disp "$RUN_OUT/hardware/disparity.npy" --gt "$GT" ${GT_SCALE:+--gt-scale "$GT_SCALE"} --colour "$RUN_OUT/disparity.png")" \
      || die "demo: scoring against $GT failed"
    echo "$line" | awk -F, '{ printf "bad-3: %.2f\n", $7 }'   # column bad3: invalid pixels count as bad
  else
    "$EVAL" colour --disp "$RUN_OUT/hardware/disparity.npy" --out "$RUN_OUT/disparity.png" \
      || die "demo: colourising failed"
  fi
  echo "wrote ${RUN_OUT#$ROOT/}/disparity.png, hardware/ (disparity.npy, .pfm, _kitti.png, cycles.txt), golden/"
  exit "$code"
fi
OUT="$ROOT/build/bench/$NAME$( [ "$STUB" = 1 ] && echo -stub || true)"  # `|| true`: set -e
mkdir -p "$OUT"
val() { sed -n "s|^$1: \([^ ]*\).*|\1|p" "$2" | head -n 1; }
ROWS=()
for mode in "no stalls:" "10 % gaps, 10 % stalls:--gaps 0.1 --stalls 0.1 --seed 1"; do
  label="${mode%%:*}" args="${mode#*:}"
  log="$OUT/$(echo "$label" | tr -c 'a-z0-9\n' '-' | tr -s '-' | sed 's/-$//').log"
  # shellcheck disable=SC2086
  "$BIN" --config "$CONFIG_FILE" --left "$LEFT" --right "$RIGHT" --out "$OUT/out" --frames "$FRAMES" $args > "$log" \
    || { cat "$log"; die "bench: the $label run failed (log: ${log#$ROOT/})"; }
  size="$(sed -n 's/^ielas_sim: \([0-9]*x[0-9]*\).*/\1/p' "$log")"
  w="${size%x*}" h="${size#*x}"
  cycles="$(val cycles "$log")" rows="$(val "latency rows" "$log")"
  wall="$(sed -n 's/^sim wall time: \([0-9.]*\) s .* \([0-9]*\) cycles\/s)/\1 s, \2 cycles\/s/p' "$log")"
  # the throughput bound (docs/interfaces.md §4) holds only without stalls
  if [ -z "$args" ]; then slack=$(( cycles - FRAMES * w * h - rows * w )); else slack="-"; fi
  ROWS+=("| $label | $size | $FRAMES | $cycles | $(val cycles/pixel "$log") | $(val fps@200MHz "$log") | $rows | $slack | $wall |")
done
{
  echo "Configuration \`$NAME\`$([ "$STUB" = 1 ] && echo ' (stand-in top src/test/cpp/stub/IElas.sv, not the accelerator)'),"
  echo "pair \`${LEFT#$DATA/}\`, \`$(basename "$RIGHT")\`; Verilator $(verilator --version | cut -d' ' -f2);"
  echo "harness build $(cat "$DIR/build_seconds" 2>/dev/null || echo '?') s (not included in the simulation times); $(nproc) cores."
  echo
  echo "| run | frame | frames | cycles | cycles/pixel | fps@200MHz (assumed) | latency rows | c = cycles - (pixels + rows*W) | simulation (wall, speed) |"
  echo "|---|---|---|---|---|---|---|---|---|"
  printf '%s\n' "${ROWS[@]}"
} > "$OUT/performance.md"
cat "$OUT/performance.md"
echo "wrote ${OUT#$ROOT/}/performance.md"
