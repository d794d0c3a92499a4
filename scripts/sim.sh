#!/usr/bin/env bash
# The C++ Verilator harness of the IElas top (src/test/cpp/ielas_sim.cpp): build it, run it, benchmark it.
#
# Usage:
#   scripts/sim.sh build CONFIG [--stub]                 build (or reuse) build/sim/<config>/ielas_sim
#   scripts/sim.sh run   CONFIG [--stub] HARNESS-ARGS... build if needed, then run ielas_sim --config CONFIG ...
#   scripts/sim.sh path  CONFIG [--stub]                 print the binary's path (no build)
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
# Environment: SIM_JOBS (default 2), IELAS_CONFIG_DIR (configurations, default golden/configs).
set -euo pipefail

die() { echo "sim.sh: $*" >&2; exit 1; }

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
JOBS="${SIM_JOBS:-2}"

[ $# -ge 2 ] || { sed -n '2,18p' "$0" >&2; exit 1; }
CMD="$1" CONFIG="$2"
shift 2
STUB=0
if [ "${1:-}" = "--stub" ]; then STUB=1; shift; fi
case "$CMD" in build|run|path) ;; *) die "unknown command '$CMD' (build, run, path)" ;; esac

NAME="$(basename "$CONFIG")"; NAME="${NAME%.json}"
case "$CONFIG" in
  */*|*.json) CONFIG_FILE="$CONFIG" ;;
  *) CONFIG_FILE="${IELAS_CONFIG_DIR:-$ROOT/golden/configs}/$CONFIG.json" ;;
esac
[ -f "$CONFIG_FILE" ] || die "unknown configuration '$CONFIG' (no file $CONFIG_FILE)"
CONFIG_FILE="$(cd "$(dirname "$CONFIG_FILE")" && pwd)/$(basename "$CONFIG_FILE")"

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
  [ -f "$VDIR/lint.vlt" ] && VERILOG=("$VDIR/lint.vlt" "${VERILOG[@]}")
fi
BIN="$DIR/ielas_sim"
if [ "$CMD" = path ]; then echo "$BIN"; exit 0; fi

HARNESS=("$ROOT/src/test/cpp/ielas_sim.cpp" "$ROOT/golden/src/image_io.cpp" "$ROOT/golden/src/npy.cpp")
HEADERS=("$ROOT/golden/include/ielas/image_io.hpp" "$ROOT/golden/include/ielas/npy.hpp" "$ROOT/golden/include/ielas/config.hpp")
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
  awk -v a="$t0" -v b="$t1" -v bin="${BIN#$ROOT/}" 'BEGIN { printf "sim build: %.1f s (%s)\n", b - a, bin }'
}

build
if [ "$CMD" = run ]; then
  exec "$BIN" --config "$CONFIG_FILE" "$@"
fi
