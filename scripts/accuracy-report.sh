#!/usr/bin/env bash
# Regenerates docs/accuracy-vs-time.md and docs/images/accuracy-*.png (the accuracy-vs-time
# report, bench/accuracy/). Builds the report app in build-accuracy/ (or $TSF_BUILD_DIR) if needed.
#   scripts/accuracy-report.sh            full report into docs/ (a few minutes on 2 cores)
#   scripts/accuracy-report.sh --quick    CI-sized run into build-accuracy/accuracy-quick/
# Extra arguments go to accuracy_report (e.g. --only crms-spacing, --threads 2).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"  # relative paths: the report prints its command line
build="${TSF_BUILD_DIR:-build-accuracy}"
jobs="${TSF_JOBS:-2}"
if [[ ! -x "$build/bench/accuracy_report" ]]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DTSF_WITH_CUDA=OFF \
    -DTSF_WITH_ITK=OFF -DTSF_WITH_VTK=OFF -DTSF_WITH_ASSIMP=OFF -DTSF_BUILD_BENCH=ON >/dev/null
fi
cmake --build "$build" -j "$jobs" --target accuracy_report
commit="$(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)"
if [[ "${1:-}" == "--quick" ]]; then
  shift
  out="$build/accuracy-quick"
  "$build/bench/accuracy_report" --quick --commit "$commit" --markdown "$out/accuracy-vs-time.md" \
    --images "$out/images" --data "$out" "$@"
  "$build/bench/accuracy_report" --verify "$out/accuracy-vs-time.json"
else
  "$build/bench/accuracy_report" --commit "$commit" --markdown docs/accuracy-vs-time.md \
    --images docs/images --data "$build/accuracy-data" "$@"
  "$build/bench/accuracy_report" --verify "$build/accuracy-data/accuracy-vs-time.json"
fi
