#!/usr/bin/env bash
# Effects on demand, end to end: runs scenes/sinus.yaml and scenes/sinus-effects.yaml (the same
# scene but for its `effects:` section) with `tsf run`, and writes their comparison — per-stage
# cost, effects active, step cost with the scene's effects vs all off, bytes per node — into
# docs/run.md between the `effects-pair` markers, with the command and the machine next to it.
#   scripts/effects-pair.sh                      # short script: --duration 0.012
#   scripts/effects-pair.sh --duration 0.04      # extra arguments go to both `tsf run` calls
# Outputs: $TSF_OUT/effects-pair/{sinus,sinus-effects}/ (default out/). Needs jq.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TSF="${TSF_BUILD_DIR:-$ROOT/build}/bin/tsf"
case "$TSF" in /*) ;; *) TSF="$ROOT/$TSF" ;; esac
OUT="${TSF_OUT:-$ROOT/out}/effects-pair"
DOC="${EFFECTS_PAIR_DOC:-$ROOT/docs/run.md}"
command -v jq >/dev/null || { echo "effects-pair.sh: needs jq (apt-get install jq)" >&2; exit 1; }
[ -x "$TSF" ] || { echo "effects-pair.sh: no tsf executable at $TSF (build first)" >&2; exit 1; }
args=("$@")
[ ${#args[@]} -eq 0 ] && args=(--duration 0.012)
cd "$ROOT"
for scene in sinus sinus-effects; do
  echo "== tsf run scenes/$scene.yaml ${args[*]} =="
  "$TSF" run "scenes/$scene.yaml" -q --force "${args[@]}" -o "$OUT/$scene"
done

read -r -d '' JQ <<'PROGRAM' || true
def s(x): if x >= 1 then "\(x * 1000 | round / 1000) s" elif x >= 0.001 then "\(x * 1e5 | round / 100) ms" else "\(x * 1e8 | round / 100) µs" end;
def g(x): x * 100 | round / 100;
def stage(r; p): [r.stages[] | select(.stage | startswith(p)) | .seconds] | add // 0;
"| scene | effects active | dt | steps | surface + lattice + coupler | scripted interaction | stepping | time per step (run) | bytes per node | run total |",
"| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
(.[] | . as $r | .instances[0] as $i |
  "| \($r.scene.name) | \(if ($i.effects_active | length) == 0 then "none" else ($i.effects_active | join(", ")) end) | \(s($i.dt_s)) | \($i.steps) | \(s(stage($r; "surface + lattice"))) | \(s(stage($r; "scripted interaction"))) | \(s($i.timings_s.stepping)) | \(s($i.timings_s.stepping / $i.steps)) | \($i.bytes_per_node) | \(s($r.total_seconds)) |"),
"",
"Step cost on each run's final lattice (after the script), interleaved repetitions; median (min – max):",
"",
"| scene | configuration | time per step | ratio to off (medians) | ratio to off (minima) | bytes per node |",
"| --- | --- | ---: | ---: | ---: | ---: |",
(.[] | . as $r | .instances[0].effect_cost as $c | $c.configurations[] |
  "| \($r.scene.name) | \(.name) | \(s(.median_us_per_step * 1e-6)) (\(s(.min_us_per_step * 1e-6)) – \(s(.max_us_per_step * 1e-6))) | \(g(.ratio_to_off)) | \(g(.ratio_to_off_min)) | \(.bytes_per_node) |"),
"",
(.[] | .instances[0].effect_cost as $c |
  "Noise band, \(.scene.name): \"off\" vs \"off again\" \(g($c.noise_off_vs_off_again * 100)) % (medians), largest spread of the repetitions \(g($c.noise_largest_spread * 100)) % (\($c.alive_nodes) nodes, \($c.repetitions) × \($c.steps_per_repetition) steps, \($c.backend)).")
PROGRAM
table="$(jq -r -s "$JQ" "$OUT/sinus/run-report.json" "$OUT/sinus-effects/run-report.json")"
machine="$(nproc) cores, load average $(cut -d' ' -f1 /proc/loadavg) at the end, $(date -u +%Y-%m-%d)"
block="$(printf '<!-- effects-pair:begin (written by scripts/effects-pair.sh; do not edit by hand) -->\nCommand: `scripts/effects-pair.sh%s` = `tsf run scenes/sinus.yaml %s` and the same on `scenes/sinus-effects.yaml` (%s; tsf %s).\n\n%s\n<!-- effects-pair:end -->' \
  "${*:+ $*}" "${args[*]}" "$machine" "$(jq -r .tsf_version "$OUT/sinus/run-report.json")" "$table")"
if ! grep -q '<!-- effects-pair:begin' "$DOC"; then
  printf '\n%s\n' "$block" >>"$DOC"
else
  BLOCK="$block" python3 - "$DOC" <<'PY'
import os, re, sys
path = sys.argv[1]
text = open(path, encoding="utf-8").read()
new = re.sub(r"<!-- effects-pair:begin.*?<!-- effects-pair:end -->", lambda m: os.environ["BLOCK"],
             text, count=1, flags=re.S)
tmp = path + ".tmp"
open(tmp, "w", encoding="utf-8").write(new)
os.replace(tmp, path)
PY
fi
echo "effects-pair.sh: wrote the comparison into $DOC"
echo "$table"
