#!/usr/bin/env bash
# Yosys resource flow for one configuration (docs/synthesis.md).
#   scripts/synth.sh CONFIG [VERILOG_DIR]
# CONFIG is a configuration name or a JSON file; VERILOG_DIR defaults to build/verilog/<config> (`make verilog`).
# Environment:
#   SYNTH_MODE=top|modules|both  whole flattened top (default), per-stage modules with cache, or both + comparison
#   SYNTH_CACHE=DIR              per-module result cache (default build/synth/cache)
#   SYNTH_OUT=DIR                output directory (default build/synth/<config>)
#   SYNTH_TIMEOUT=S              wall-clock limit per Yosys run (default 3600)
#   SYNTH_MEM_MB=MB              address-space limit per Yosys run (default 8192; 0 = none)
#   SYNTH_JOBS=N                 parallel Yosys runs in modules mode (default 1)
#   SYNTH_MAPPER=lut6|widelut|abc9  LUT mapping (default lut6: classic ABC, no MUXF7/F8 wide LUTs)
#   SYNTH_TOP=NAME               top module (default IElas)
#   SYNTH_STRICT=1               exit 3 when a line buffer (SyncReadMem) did not become block RAM
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
if [ $# -lt 1 ] || [ $# -gt 2 ]; then
  echo "usage: scripts/synth.sh CONFIG [VERILOG_DIR]" >&2; exit 2
fi
config="$1"
name="$(basename "${config%.json}")"
verilog="${2:-build/verilog/$name}"
if ! ls "$verilog"/*.sv >/dev/null 2>&1; then
  echo "synth: no Verilog in $verilog (run make verilog CONFIG=$config)" >&2; exit 1
fi
case "${SYNTH_MODE:-top}" in top|modules|both) ;; *) echo "synth: SYNTH_MODE must be top, modules or both" >&2; exit 2;; esac
case "${SYNTH_MAPPER:-lut6}" in lut6|widelut|abc9) ;; *) echo "synth: SYNTH_MAPPER must be lut6, widelut or abc9" >&2; exit 2;; esac
for v in SYNTH_TIMEOUT SYNTH_MEM_MB SYNTH_JOBS; do
  [[ -z "${!v:-}" || "${!v}" =~ ^[0-9]+$ ]] || { echo "synth: $v must be a whole number" >&2; exit 2; }
done
command -v yosys >/dev/null || { echo "synth: yosys not found (make deps-synth)" >&2; exit 1; }
exec python3 "$here/synth/flow.py" --config "$name" --verilog "$verilog" \
  --out "${SYNTH_OUT:-build/synth/$name}" --mode "${SYNTH_MODE:-top}" --cache "${SYNTH_CACHE:-build/synth/cache}" \
  --timeout "${SYNTH_TIMEOUT:-3600}" --mem-mb "${SYNTH_MEM_MB:-8192}" --jobs "${SYNTH_JOBS:-1}" \
  --top "${SYNTH_TOP:-IElas}" --mapper "${SYNTH_MAPPER:-lut6}" ${SYNTH_STRICT:+--strict}
