#!/usr/bin/env bash
# The main job on the bundled sample: installs what is missing, builds, then runs the pipeline.
# Outputs go to ./out (or $TSF_OUT).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${TSF_OUT:-$ROOT/out}"
"$ROOT/scripts/setup.sh"
TSF="${TSF_BUILD_DIR:-$ROOT/build}/bin/tsf"
mkdir -p "$OUT"
echo "== tsf import: bundled head CT (NRRD) =="
"$TSF" import "$ROOT/data-samples/ct-head-cranium/cranium.nrrd" -o "$OUT/cranium-hu.nrrd"
echo "== tsf import: bundled GE DICOM series (gantry tilt, uneven spacing) =="
"$TSF" import "$ROOT/data-samples/ct-head-ge-hispeed-tilt-varspacing" -o "$OUT/ge-head-hu.nrrd"
echo "== tsf segment: head CT with the sinus preset (density, labels, weights, report, preview) =="
"$TSF" segment "$OUT/cranium-hu.nrrd" --preset sinus -o "$OUT/cranium"
echo "Outputs in $OUT:"
ls -l "$OUT"
