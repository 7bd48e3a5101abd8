#!/bin/sh
# The cohort workflow (scripts/cohort/Snakefile) over the two bundled heads and a broken third
# patient, two jobs at a time: two models with their reports, previews and GLBs, and a summary
# that lists the failure with its reason; the broken patient does not stop the others.
#   cohort_test.sh SOURCE_DIR TSF
set -eu
src=$1
tsf=$2
command -v snakemake >/dev/null || { echo "snakemake is not installed (scripts/setup.sh installs it)"; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf 'patient\tct\nhead-cranium\t%s\nhead-ge\t%s\nbroken\t%s\n' \
  "$src/data-samples/ct-head-cranium/cranium.nrrd" \
  "$src/data-samples/ct-head-ge-hispeed-tilt-varspacing" "$src/data-samples/README.md" >"$tmp/patients.tsv"
snakemake -s "$src/scripts/cohort/Snakefile" -d "$tmp/work" -j2 -q \
  --config patients="$tmp/patients.tsv" out="$tmp/cohort" tsf="$tsf" \
  scene="$src/scenes/sinus-ci.yaml" "run_args=--backend cpu --duration 0.02" >"$tmp/snakemake.log" 2>&1 ||
  { cat "$tmp/snakemake.log"; exit 1; }
for p in head-cranium head-ge; do
  for f in run-report.json run-report.md sinus-ci-final.glb sinus-ci-preview.png; do
    test -s "$tmp/cohort/$p/run/$f" || { echo "missing $p/run/$f"; exit 1; }
  done
done
python3 - "$tmp/cohort/cohort.json" <<'PY'
import json, sys
c = json.load(open(sys.argv[1]))
assert c["completed"] == 2 and c["failed"] == 1, c
by = {p["patient"]: p for p in c["patients"]}
assert not by["broken"]["ok"] and "--ct" in by["broken"]["error"], by["broken"]
for p in ("head-cranium", "head-ge"):
    assert by[p]["ok"] and by[p]["verdict"] == "completed" and by[p]["removed_mm3"] > 0, by[p]
PY
grep -q "^| broken |" "$tmp/cohort/cohort.md" || { echo "the summary does not list the failure"; exit 1; }
grep -q "^# Cohort: 2 of 3 patients completed" "$tmp/cohort/cohort.md"
echo "cohort: 2 of 3 completed, the broken one listed"
