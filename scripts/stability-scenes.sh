#!/usr/bin/env bash
# The shipped scenes' stability verdicts (docs/stability.md "Shipped scenes"): runs the small and
# CI scenes with the command each is made for and prints one markdown table row per run, then the
# over-large step on sinus-ci (dt: 0.002 s) refused, and allowed by the scene.
#   scripts/stability-scenes.sh            (build/bin/tsf, or $TSF_EXE; a minute on 2 cores)
set -uo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
tsf="${TSF_EXE:-$root/build/bin/tsf}"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

row() {  # row SCENE COMMAND EXIT REPORT.json (with a .stability section at JQ path $5)
  local path="${5:-.stability}"
  if [[ -f "$4" ]]; then
    jq -r --arg s "$1" --arg c "$2" --arg e "$3" "$path"' |
      "| \($s) | `\($c)` | \($e) | \(.verdict) | \(.energy_nj.gain_fraction * 100 | . * 100 | round / 100)% | \(.velocity_limit.max_fraction_at_limit * 100 | . * 10 | round / 10)% | \(.period2.max_score * 100 | round / 100) | \(.reason | .[0:90])… |"' "$4"
  else
    echo "| $1 | \`$2\` | $3 | (no report) | | | | |"
  fi
}

echo "| scene | command | exit | verdict | gain / scale | max at limit | max period-2 | reason |"
echo "| --- | --- | ---: | --- | ---: | ---: | ---: | --- |"
for s in beam block-compress effects-beam; do
  "$tsf" simulate -q "$root/scenes/$s.yaml" --report "$tmp/$s.json" >/dev/null 2>&1
  row "$s" "tsf simulate" $? "$tmp/$s.json"
done
for s in cut-block effects-animation; do
  "$tsf" simulate -q "$root/scenes/$s.yaml" --out "$tmp/$s" --report "$tmp/$s.json" >/dev/null 2>&1
  row "$s" "tsf simulate" $? "$tmp/$s.json"
done
"$tsf" haptics -q --no-plot "$root/scenes/haptics-block.yaml" --model lattice \
  -t "$root/scenes/trajectories/haptics-press-hold.yaml" -o "$tmp/haptics" >/dev/null 2>&1
row "haptics-block" "tsf haptics --model lattice" $? "$tmp/haptics/metrics.json"
"$tsf" run -q "$root/scenes/sinus-ci.yaml" -o "$tmp/sinus-ci" >/dev/null 2>&1
row "sinus-ci" "tsf run" $? "$tmp/sinus-ci/run-report.json"
"$tsf" run -q "$root/scenes/sinus-layers.yaml" --voxel-mm 2 -o "$tmp/sinus-layers" >/dev/null 2>&1
row "sinus-layers (worst instance)" "tsf run --voxel-mm 2" $? "$tmp/sinus-layers/run-report.json"

# The over-large step: 0.002 s on sinus-ci, refused; then allowed by the scene.
sed -e "s|ct: ../data-samples|ct: $root/data-samples|" -e 's|  dt: auto|  dt: 0.002|' \
  "$root/scenes/sinus-ci.yaml" >"$tmp/sinus-ci-dt.yaml"
"$tsf" run -q "$tmp/sinus-ci-dt.yaml" -o "$tmp/refused" >"$tmp/refused.log" 2>&1
echo "| sinus-ci, dt: 0.002 | \`tsf run\` | $? | refused | | | | $(grep -o 'solver.dt = [^(]*' "$tmp/refused.log" | head -1)… |"
sed -e 's|kinetic_damping: 0.01|kinetic_damping: 0.01\n  allow_unsafe_dt: true|' \
  "$tmp/sinus-ci-dt.yaml" >"$tmp/sinus-ci-dt-allowed.yaml"
"$tsf" run -q "$tmp/sinus-ci-dt-allowed.yaml" -o "$tmp/allowed" >/dev/null 2>&1
row "sinus-ci, dt: 0.002, allow_unsafe_dt" "tsf run" $? "$tmp/allowed/run-report.json"
