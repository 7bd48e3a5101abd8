#!/usr/bin/env bash
# The main job (README): installs what is missing, builds, then runs `tsf run`: the bundled sinus
# scene (scenes/sinus.yaml) on the sample cranium CT — import, segment, surface, lattice, scripted
# press/ablate/cut, meshes and a Markdown report with plots (docs/run.md).
# Outputs go to ./out/sinus (or $TSF_OUT/sinus). Extra arguments go to `tsf run`
# (e.g. scripts/main.sh scenes/sinus-ci.yaml).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${TSF_OUT:-$ROOT/out}"
"$ROOT/scripts/setup.sh"
TSF="${TSF_BUILD_DIR:-$ROOT/build}/bin/tsf"
case "$TSF" in /*) ;; *) TSF="$ROOT/$TSF" ;; esac
mkdir -p "$OUT"
cd "$ROOT"  # tsf run finds scenes/sinus.yaml and the sample CT from the checkout
scene_name="sinus"
for a in "$@"; do
  case "$a" in *.yaml) scene_name="$(basename "$a" .yaml)" ;; esac
done
echo "== tsf run $* =="
# --force: a second main job replaces the first one's files (only in a folder a tsf run wrote).
"$TSF" run "$@" --force -o "$OUT/$scene_name"
echo "Outputs in $OUT/$scene_name (report: $OUT/$scene_name/run-report.md):"
ls -l "$OUT/$scene_name"
