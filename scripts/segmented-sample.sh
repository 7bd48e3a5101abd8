#!/usr/bin/env bash
# Makes the committed segmented sample data-samples/ct-head-cranium/segmented/: the sample CT
# segmented with the sinus preset (`tsf segment`), cropped to the face around the nose and nasal
# cavity (73 × 75 × 84 voxels of 0.957 mm, the region of scenes/sinus.yaml and
# scenes/cut-cranium.yaml with a margin), with the segment report whose anatomy places those
# scenes. Builds without ITK (the GPU machine's) read it with the core's NRRD reader
# (tissue/include/tsf/io/nrrd_volume.h): scripts/gpu-check.sh simulates, tests and benchmarks it.
#   scripts/segmented-sample.sh [TSF]      (default build/bin/tsf)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TSF="${1:-$ROOT/build/bin/tsf}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
(cd "$ROOT" && "$TSF" segment data-samples/ct-head-cranium/cranium.nrrd --preset "$ROOT/segment/presets/sinus.yaml" \
   -o "$work/cranium" >/dev/null)
out="$ROOT/data-samples/ct-head-cranium/segmented"
mkdir -p "$out"
# Voxel box [60,133) × [170,245) × [0,84) of the segmentation (its ROI starts at the CT's voxel
# (32, 5, 0)): x 88–158 mm, y 167–239 mm, z 0–80 mm around the nose tip (122, 231, 34) mm.
python3 "$ROOT/scripts/crop-nrrd.py" 60:133 170:245 0:84 \
  "$work/cranium-density.nrrd" "$out/cranium-density.nrrd" \
  "$work/cranium-labels.nrrd" "$out/cranium-labels.nrrd" \
  "$work/cranium-weights.nrrd" "$out/cranium-weights.nrrd"
cp "$work/cranium-report.json" "$out/cranium-report.json"
ls -la "$out"
