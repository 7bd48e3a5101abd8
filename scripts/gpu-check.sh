#!/usr/bin/env bash
# The one GPU-machine script: builds tissue/ (+ app, tests, benches) with CUDA and the
# ITK/VTK/assimp modules off, runs every test and the benchmarks, and writes the results under
# $OUT (the device tool's folder) as a few files: summary.txt, ctest.log, results.tgz.
#
#   scripts/gpu-check.sh                 build + all tests + all benchmarks
#   TSF_GPU_BENCH_FILTER=crms scripts/gpu-check.sh     only bench executables matching 'crms'
#   TSF_GPU_SKIP_BENCH=1 / TSF_GPU_SKIP_TESTS=1        skip a part
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${OUT:-$ROOT/out/gpu}"
mkdir -p "$OUT/raw"
BUILD="$ROOT/build-gpu"
JOBS="$(nproc)"
SUMMARY="$OUT/summary.txt"
: >"$SUMMARY"
note() { echo "$*" | tee -a "$SUMMARY"; }

note "== machine"; { nvidia-smi --query-gpu=name,memory.total,driver_version,clocks.max.sm --format=csv; nproc; } 2>&1 | tee -a "$SUMMARY"
note "== git: $(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null) $(git -C "$ROOT" status --porcelain 2>/dev/null | wc -l) uncommitted path(s)"

t0=$(date +%s)
cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DTSF_WITH_ITK=OFF -DTSF_WITH_VTK=OFF \
  -DTSF_WITH_ASSIMP=OFF -DTSF_WITH_CUDA=ON -DCMAKE_CUDA_ARCHITECTURES=90 >"$OUT/raw/configure.log" 2>&1 \
  || { note "configure FAILED"; tail -40 "$OUT/raw/configure.log" | tee -a "$SUMMARY"; exit 1; }
cmake --build "$BUILD" -j "$JOBS" >"$OUT/raw/build.log" 2>&1 \
  || { note "build FAILED"; grep -E 'error|Error' "$OUT/raw/build.log" | head -40 | tee -a "$SUMMARY"; exit 1; }
note "== build ok in $(( $(date +%s) - t0 )) s ($(grep -c warning "$OUT/raw/build.log") warning lines)"

if [ "${TSF_GPU_SKIP_TESTS:-0}" != "1" ]; then
  t0=$(date +%s)
  (cd "$BUILD" && ctest --output-on-failure -j 4 --timeout 600 --output-junit "$OUT/raw/ctest-junit.xml" \
     ${TSF_GPU_CTEST_ARGS:-}) >"$OUT/ctest.log" 2>&1
  rc=$?
  note "== ctest rc=$rc in $(( $(date +%s) - t0 )) s: $(grep -E 'tests passed|tests failed' "$OUT/ctest.log")"
  grep -E '^\s*[0-9]+ - |\*\*\*Failed|Not Run' "$OUT/ctest.log" | head -40 | tee -a "$SUMMARY"
  # Skipped tests and their reasons (a GPU test skipping here would be a problem).
  grep -B1 -A1 'Skipped' "$OUT/ctest.log" | grep -iE 'skip|not run' | sort | uniq -c | head -20 >>"$SUMMARY"
fi

if [ "${TSF_GPU_SKIP_BENCH:-0}" != "1" ]; then
  for b in "$BUILD"/bench/bench_*; do
    [ -x "$b" ] || continue
    name=$(basename "$b")
    [[ -n "${TSF_GPU_BENCH_FILTER:-}" && ! "$name" =~ ${TSF_GPU_BENCH_FILTER} ]] && continue
    t0=$(date +%s)
    timeout 300 "$b" --benchmark_out="$OUT/raw/$name.json" --benchmark_out_format=json \
      ${TSF_GPU_BENCH_ARGS:-} >"$OUT/raw/$name.txt" 2>&1
    note "== $name rc=$? in $(( $(date +%s) - t0 )) s"
    grep -vE '^\*\*\*|Library was built as DEBUG' "$OUT/raw/$name.txt" | tail -60 >>"$SUMMARY"
  done
fi
tar -C "$OUT" -czf "$OUT/results.tgz" raw && rm -rf "$OUT/raw"
note "== done"
