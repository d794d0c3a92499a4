#!/usr/bin/env bash
# Accuracy evaluation of the golden model on every ground-truth pair of docs/evaluation.md (`make eval`).
#
# Usage (positional MODE, then a preset or a configuration; everything after passes through to `match`):
#   scripts/eval.sh MODE --preset robotics|middlebury [MATCH ARGS...]
#   scripts/eval.sh MODE --config NAME|FILE.json      [MATCH ARGS...]
#   scripts/eval.sh MODE=ielas PRESET=robotics [MATCH ARGS...]     (make-style, same meaning)
#   e.g. scripts/eval.sh ielas --preset robotics --interp paper
#
# MODE is elas or ielas. Each pair runs in a fresh `ielas-golden match` process (with --preset, disp_max per
# family as in docs/evaluation.md; with --config the configuration fixes it) and is scored by `ielas-eval`.
# Output: build/eval/<mode>-<preset|config>[-<match args>]/ with results.csv (one line per pair and region),
# results.md (per-pair metrics, family means, goal families first), <pair>-disp.png (colourised) and
# <pair>-<region>-error.png. With --config, pairs larger than the configuration are skipped and listed; a
# tsukuba* (or any 640x480) configuration also scores centred 640x480 crops of Reindeer, Wood2 and Motorcycle,
# cut at run time into the output directory (never commit them).
#
# Environment: IELAS_DATA (default <repo>/../shared/data), IELAS_GOLDEN / IELAS_EVAL (binaries, default
# golden/build/ielas-golden and golden/build/ielas-eval), EVAL_OUT (output directory override).
set -euo pipefail

die() { echo "eval.sh: $*" >&2; exit 1; }

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DATA="${IELAS_DATA:-$ROOT/../shared/data}"
GOLDEN="${IELAS_GOLDEN:-$ROOT/golden/build/ielas-golden}"
EVAL="${IELAS_EVAL:-$ROOT/golden/build/ielas-eval}"

MODE="" PRESET="" CONFIG=""
PASS=()
while [ $# -gt 0 ]; do
  case "$1" in
    MODE=*) MODE="${1#MODE=}" ;;
    PRESET=*) PRESET="${1#PRESET=}" ;;
    CONFIG=*) CONFIG="${1#CONFIG=}" ;;
    --preset) [ $# -ge 2 ] || die "--preset needs a value"; PRESET="$2"; shift ;;
    --config) [ $# -ge 2 ] || die "--config needs a value"; CONFIG="$2"; shift ;;
    -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
    *) if [ -z "$MODE" ] && [ "${1#-}" = "$1" ]; then MODE="$1"; else PASS+=("$1"); fi ;;
  esac
  shift
done
[ -n "$MODE" ] || die "no MODE given (elas or ielas); see scripts/eval.sh --help"
case "$MODE" in elas|ielas) ;; *) die "MODE must be elas or ielas, not '$MODE'" ;; esac
[ -n "$PRESET" ] || [ -n "$CONFIG" ] || die "give --preset robotics|middlebury or --config NAME|FILE.json"
[ -z "$PRESET" ] || [ -z "$CONFIG" ] || die "give either --preset or --config, not both"
[ -z "$PRESET" ] || case "$PRESET" in robotics|middlebury) ;; *) die "unknown preset '$PRESET'" ;; esac
[ -d "$DATA" ] || die "ground-truth data not found at $DATA (set IELAS_DATA, or see data/README.md and data/fetch_datasets.sh)"
[ -x "$GOLDEN" ] || die "$GOLDEN not built (run make golden)"
[ -x "$EVAL" ] || die "$EVAL not built (run make golden)"

# Configuration limits, read from its JSON (the same file `match --config` reads).
MAX_W=0 MAX_H=0 CROPS=0
if [ -n "$CONFIG" ]; then
  if [[ "$CONFIG" == *.json ]]; then CONFIG_FILE="$CONFIG"; else CONFIG_FILE="$ROOT/golden/configs/$CONFIG.json"; fi
  [ -f "$CONFIG_FILE" ] || die "configuration not found: $CONFIG_FILE"
  json_int() { grep -o "\"$1\"[[:space:]]*:[[:space:]]*[0-9]*" "$CONFIG_FILE" | head -1 | grep -o '[0-9]*$'; }
  MAX_W="$(json_int maxWidth)"; MAX_H="$(json_int maxHeight)"
  [ -n "$MAX_W" ] && [ -n "$MAX_H" ] || die "no maxWidth/maxHeight in $CONFIG_FILE"
  SETTING="$(basename "$CONFIG" .json)"
  # New Tsukuba-sized configurations score the centred 640x480 crops (docs/evaluation.md).
  if [[ "$SETTING" == tsukuba* ]] || { [ "$MAX_W" = 640 ] && [ "$MAX_H" = 480 ]; }; then CROPS=1; fi
  SELECT=(--config "$CONFIG")
else
  SETTING="$PRESET"
  SELECT=(--preset "$PRESET")
fi

SUFFIX=""
if [ ${#PASS[@]} -gt 0 ]; then
  SUFFIX="-$(printf '%s-' "${PASS[@]}" | tr -s -c 'A-Za-z0-9.\n' '-' | sed 's/^-*//; s/-*$//')"
fi
OUT="${EVAL_OUT:-$ROOT/build/eval/$MODE-$SETTING$SUFFIX}"
mkdir -p "$OUT"
CSV="$OUT/results.csv"
echo "family,$("$EVAL" header)" > "$CSV"
SKIPPED=() FAILED=()

# Seconds per frame: the number `match --time` prints (in s or ms), else the wall clock of the process.
parse_time() {
  local log="$1" wall="$2" line value unit
  line="$(grep -i -m1 -E 'time|ms|[0-9] ?s\b' "$log" || true)"
  if [[ "$line" =~ ([0-9]+(\.[0-9]+)?)[[:space:]]*(ms|s)([^A-Za-z]|$) ]]; then
    value="${BASH_REMATCH[1]}"; unit="${BASH_REMATCH[3]}"
    if [ "$unit" = ms ]; then awk -v v="$value" 'BEGIN { printf "%.4f", v / 1000 }'; else echo "$value"; fi
  else
    echo "$wall"
  fi
}

# run_pair FAMILY NAME LEFT RIGHT DISPMAX REGION GT SCALE MASKOPT [REGION GT SCALE MASKOPT ...]
#   MASKOPT: "-" (none), "keep:<png>" (score where 255) or "drop:<png>" (skip where non-zero).
run_pair() {
  local family="$1" name="$2" left="$3" right="$4" dispmax="$5"; shift 5
  local size w h
  size="$("$EVAL" size "$left")"; w="${size% *}"; h="${size#* }"
  if [ -n "$CONFIG" ] && { [ "$w" -gt "$MAX_W" ] || [ "$h" -gt "$MAX_H" ]; }; then
    SKIPPED+=("$name (${w}x${h} > ${MAX_W}x${MAX_H})"); return 0
  fi
  local range=()
  [ -n "$CONFIG" ] || range=(--disp-max "$dispmax")
  local disp="$OUT/$name-disp.pfm" log="$OUT/$name-match.log" start end wall
  rm -f "$OUT/$name-disp.png"
  start="$(date +%s.%N)"
  if ! "$GOLDEN" match --mode "$MODE" "${SELECT[@]}" "${range[@]}" --left "$left" --right "$right" \
         --out "$disp" --time "${PASS[@]}" > "$log" 2>&1; then
    FAILED+=("$name: $(tail -1 "$log")"); echo "  $name: match failed: $(tail -1 "$log")" >&2; return 0
  fi
  end="$(date +%s.%N)"
  wall="$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.4f", b - a }')"
  local seconds; seconds="$(parse_time "$log" "$wall")"
  while [ $# -gt 0 ]; do
    local region="$1" gt="$2" scale="$3" maskopt="$4"; shift 4
    local mask=() colour=()
    [ -f "$OUT/$name-disp.png" ] || colour=(--colour "$OUT/$name-disp.png")
    case "$maskopt" in
      keep:*) mask=(--mask "${maskopt#keep:}") ;;
      drop:*) mask=(--exclude-mask "${maskopt#drop:}") ;;
    esac
    local line
    line="$("$EVAL" score --disp "$disp" --gt "$gt" --gt-scale "$scale" "${mask[@]}" --name "$name" \
              --region "$region" --time "$seconds" --error "$OUT/$name-$region-error.png" "${colour[@]}" 2>/dev/null)" \
      || { FAILED+=("$name/$region: scoring failed"); continue; }
    echo "$family,$line" >> "$CSV"
    echo "  $family $name $region: bad-3 $(echo "$line" | cut -d, -f7) %, ${seconds} s"
  done
}

echo "eval: mode $MODE, ${SELECT[*]} ${PASS[*]:-} -> $OUT"
K12="$DATA/kitti2012/training"; K15="$DATA/kitti2015/training"
run_pair K12 kitti2012-000070 "$K12/image_0/000070_10.png" "$K12/image_1/000070_10.png" 255 \
  noc "$K12/disp_noc/000070_10.png" 256 - all "$K12/disp_occ/000070_10.png" 256 -
run_pair K15 kitti2015-000046 "$K15/image_2/000046_10.png" "$K15/image_3/000046_10.png" 255 \
  all "$K15/disp_occ_0/000046_10.png" 256 -
for scene in tsukuba venus barn2 bull poster sawtooth teddy cones; do
  case "$scene" in tsukuba) scale=16 ;; teddy|cones) scale=4 ;; *) scale=8 ;; esac
  dir="$DATA/middlebury/$scene"
  run_pair MB0103 "mb-$scene" "$dir/im2.png" "$dir/im6.png" 63 all "$dir/disp2.png" "$scale" -
done
for scene in cones teddy tsukuba venus; do
  dir="$DATA/middlebury_v2_eval/$scene"
  scale="$(head -1 "$dir/info.txt" | tr -d '[:space:]')"
  run_pair MBV2 "mbv2-$scene" "$dir/imL.png" "$dir/imR.png" 63 \
    noc "$dir/groundtruth.png" "$scale" "keep:$dir/nonocc.png" all "$dir/groundtruth.png" "$scale" "keep:$dir/all.png"
done
for scene in Cloth3 Reindeer Wood2; do
  dir="$DATA/middlebury2006/$scene"
  run_pair MB06 "mb06-$scene" "$dir/view1.png" "$dir/view5.png" 127 all "$dir/disp1.png" 2 -
done
MB14="$DATA/middlebury2014/trainingQ/Motorcycle"
run_pair MB14Q mb14q-Motorcycle "$MB14/im0.png" "$MB14/im1.png" 127 \
  noc "$MB14/disp0GT.pfm" 1 "keep:$MB14/mask0nocc.png" all "$MB14/disp0GT.pfm" 1 -
FT="$DATA/sceneflow_flyingthings3d"
run_pair FT ft-A-0032-0006 "$FT/RGB_cleanpass/left/A-0032-0006.png" "$FT/RGB_cleanpass/right/A-0032-0006.png" 255 \
  noc "$FT/disparity/left/A-0032-0006.pfm" 1 "drop:$FT/occlusion/left/A-0032-0006.png" \
  all "$FT/disparity/left/A-0032-0006.pfm" 1 -

if [ "$CROPS" = 1 ]; then
  crop() { "$EVAL" crop --in "$1" --out "$2" --width 640 --height 480; }
  CROPDIR="$OUT/crops"; mkdir -p "$CROPDIR"
  for scene in Reindeer Wood2; do
    dir="$DATA/middlebury2006/$scene" c="$CROPDIR/mb06-$scene"
    crop "$dir/view1.png" "$c-left.png"; crop "$dir/view5.png" "$c-right.png"; crop "$dir/disp1.png" "$c-gt.png"
    run_pair MB06-crop "mb06-$scene-640x480" "$c-left.png" "$c-right.png" 127 all "$c-gt.png" 2 -
  done
  c="$CROPDIR/mb14q-Motorcycle"
  crop "$MB14/im0.png" "$c-left.png"; crop "$MB14/im1.png" "$c-right.png"
  crop "$MB14/disp0GT.pfm" "$c-gt.pfm"; crop "$MB14/mask0nocc.png" "$c-mask.png"
  run_pair MB14Q-crop mb14q-Motorcycle-640x480 "$c-left.png" "$c-right.png" 127 \
    noc "$c-gt.pfm" 1 "keep:$c-mask.png" all "$c-gt.pfm" 1 -
fi

# ---------------------------------------------------------------- results.md
MD="$OUT/results.md"
{
  echo "# Accuracy: mode \`$MODE\`, ${SELECT[*]}${PASS[*]:+, match args \`${PASS[*]}\`}"
  echo
  echo "Written by scripts/eval.sh on $(date -u '+%Y-%m-%d %H:%M UTC') at commit $(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)."
  echo "Percentages of region pixels; bad-k counts an invalid prediction as bad unless marked \"valid\" (over valid"
  echo "predictions only); \`ipol\` = after the KITTI devkit background fill; EPE in px and rel in % over valid"
  echo "predictions; time = seconds per frame. Family rows are plain means over pairs."
  echo
  awk -F, -v goal=1 -f /dev/stdin "$CSV" <<'AWK'
# Family means per (family, region); the goal families of docs/evaluation.md first.
NR == 1 { next }
{
  key = $1 "," $3
  if (!(key in n)) order[++keys] = key
  n[key]++
  for (c = 5; c <= 19; c++) sum[key, c] += $c
}
function row(key,   parts, c, line) {
  split(key, parts, ",")
  line = "| " parts[1] " | " parts[2] " | " n[key]
  for (c = 5; c <= 19; c++) {
    if (c == 9 || c == 10 || c == 11) continue
    line = line sprintf(" | %.2f", sum[key, c] / n[key])
  }
  return line " |"
}
function header() {
  print "| family | region | pairs | density | bad-1 | bad-2 | bad-3 | D1 | bad-1 ipol | bad-2 ipol | bad-3 ipol | D1 ipol | EPE | rel | time s |"
  print "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
}
END {
  split("K12,noc K15,all MBV2,noc MB06,all", goals, " ")
  print "## Goal families"
  print ""
  header()
  total = 0; found = 0
  for (g = 1; g <= 4; g++) if (goals[g] in n) { print row(goals[g]); total += sum[goals[g], 8] / n[goals[g]]; found++; isgoal[goals[g]] = 1 }
  print ""
  if (found == 4) printf "goal mean bad-3: %.2f\n\n", total / 4
  print "## Other families"
  print ""
  header()
  for (i = 1; i <= keys; i++) if (!(order[i] in isgoal)) print row(order[i])
  print ""
  print "Over valid predictions only, per family:"
  print ""
  print "| family | region | bad-1 valid | bad-2 valid | bad-3 valid |"
  print "|---|---|---|---|---|"
  for (i = 1; i <= keys; i++) {
    split(order[i], parts, ",")
    printf "| %s | %s | %.2f | %.2f | %.2f |\n", parts[1], parts[2], sum[order[i], 9] / n[order[i]], sum[order[i], 10] / n[order[i]], sum[order[i], 11] / n[order[i]]
  }
  print ""
}
AWK
  echo "## Per pair"
  echo
  echo "| family | pair | region | pixels | density | bad-1 | bad-2 | bad-3 | bad-1 v | bad-2 v | bad-3 v | D1 | bad-1 i | bad-2 i | bad-3 i | D1 i | EPE | rel | time s |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
  tail -n +2 "$CSV" | awk -F, '{ line = "| " $1 " | " $2 " | " $3 " | " $4; for (c = 5; c <= 19; c++) line = line sprintf(" | %.2f", $c); print line " |" }'
  echo
  if [ ${#SKIPPED[@]} -gt 0 ]; then
    echo "## Skipped (larger than the configuration)"; echo
    for s in "${SKIPPED[@]}"; do echo "- $s"; done; echo
  fi
  if [ ${#FAILED[@]} -gt 0 ]; then
    echo "## Failed"; echo
    for s in "${FAILED[@]}"; do echo "- $s"; done; echo
  fi
} > "$MD"

sed -n '/^## Goal families/,/^## Per pair/p' "$MD" | sed '$d'
for s in "${SKIPPED[@]}"; do echo "skipped: $s"; done
echo "eval: wrote $CSV and $MD"
if [ ${#FAILED[@]} -gt 0 ]; then
  die "${#FAILED[@]} pair(s) failed; see $MD"
fi
