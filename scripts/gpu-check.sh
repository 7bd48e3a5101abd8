#!/usr/bin/env bash
# The one GPU-machine script: builds tissue/ (+ app, tests, benches) with CUDA and the
# ITK/VTK/assimp modules off, runs every test and the benchmarks, and writes the results under
# $OUT (the device tool's folder) as a few files: summary.txt, ctest.log, results.tgz.
#
#   scripts/gpu-check.sh                 build + all tests + all benchmarks
#   TSF_GPU_BENCH_FILTER=crms scripts/gpu-check.sh     only bench executables matching 'crms'
#   TSF_GPU_SKIP_BENCH=1 / TSF_GPU_SKIP_TESTS=1        skip a part
#   TSF_GPU_BUILD_DIR=/opt/build-gpu                   build there (default: build-gpu in the
#                                                      checkout; outside it, a warm machine keeps
#                                                      it between calls that carry the checkout)
#   TSF_GPU_BUILD_TARGETS="bench_crms_throughput"      build only these targets
#   TSF_GPU_SKIP_SCENES=1                             skip the scenes on the segmented cranium
#   TSF_GPU_PROFILE=1                                  also profile the default (symmetric) kernel
#                                                      at 256³ and the node-parallel kernel on the
#                                                      sinus lattice with Nsight Compute
#                                                      (profile.txt; reports in results.tgz;
#                                                      TSF_GPU_PROFILE_KERNELS="nodes": one)
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OUT="${OUT:-$ROOT/out/gpu}"
mkdir -p "$OUT/raw"
BUILD="${TSF_GPU_BUILD_DIR:-$ROOT/build-gpu}"
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
targets=()
for t in ${TSF_GPU_BUILD_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build "$BUILD" -j "$JOBS" "${targets[@]}" >"$OUT/raw/build.log" 2>&1 \
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
if [ "${TSF_GPU_SKIP_SCENES:-0}" != "1" ] && [ -x "$BUILD/bin/tsf" ]; then
  # The segmented cranium (data-samples/ct-head-cranium/segmented, read by the core's NRRD reader:
  # this build has no ITK) through the product's command: the sinus scene at 2 and 1 mm, and the
  # cut-cranium scene on it as `tsf segment` would have written it to out/cranium.
  mkdir -p "$ROOT/out"
  for f in density labels weights; do
    cp "$ROOT/data-samples/ct-head-cranium/segmented/cranium-$f.nrrd" "$ROOT/out/cranium-$f.nrrd"
  done
  cp "$ROOT/data-samples/ct-head-cranium/segmented/cranium-report.json" "$ROOT/out/cranium-report.json"
  for scene in sinus-segmented sinus-segmented-fine cut-cranium; do
    t0=$(date +%s)
    rm -rf "/tmp/tsf-scene-$scene"
    (cd "$ROOT" && timeout 300 "$BUILD/bin/tsf" simulate "scenes/$scene.yaml" --backend cuda \
       --out "/tmp/tsf-scene-$scene" --report "$OUT/raw/scene-$scene.json") \
      >"$OUT/raw/scene-$scene.log" 2>&1
    note "== tsf simulate scenes/$scene.yaml --backend cuda: rc=$? in $(( $(date +%s) - t0 )) s"
    grep -vE '^tsf: warning' "$OUT/raw/scene-$scene.log" | tail -3 >>"$SUMMARY"
  done
fi

if [ "${TSF_GPU_PROFILE:-0}" = "1" ] && command -v ncu >/dev/null; then
  # One launch each (--clock-control none: the card's clocks as found). The symmetric kernel at
  # 256³ (graphs launch it per step) and the node-parallel persistent kernel on the sinus scene's
  # lattice (1024 steps in one launch).
  t0=$(date +%s)
  b="$BUILD/bench/bench_crms_throughput"
  [[ "${TSF_GPU_PROFILE_KERNELS:-symmetric nodes}" == *symmetric* ]] &&
  timeout 240 ncu --clock-control none --set full -k regex:"(staged|shared)_step_kernel" --launch-skip 20 \
    --launch-count 1 -o "$OUT/raw/symmetric-256" "$b" \
    --benchmark_filter='BM_CrmsNodeSteps/256/1/1/0/' --benchmark_min_time=0.01 \
    >"$OUT/raw/ncu-256.log" 2>&1
  [[ "${TSF_GPU_PROFILE_KERNELS:-symmetric nodes}" == *nodes* ]] &&
  timeout 120 ncu --clock-control none --set full -k regex:node_step_kernel \
    --launch-skip 2 --launch-count 1 -o "$OUT/raw/nodes-sinus" "$b" \
    --benchmark_filter='BM_CrmsSinusLatticeStep/2/3' --benchmark_min_time=0.01 \
    >"$OUT/raw/ncu-nodes.log" 2>&1
  for r in symmetric-256 nodes-sinus; do
    [ -f "$OUT/raw/$r.ncu-rep" ] || continue
    { echo "== $r"; ncu --import "$OUT/raw/$r.ncu-rep" --page details --print-units base 2>&1 \
        | grep -E 'Duration|Throughput|Registers|Achieved Occupancy|Theoretical Occupancy|Executed Ipc|Issue Slots Busy|Warp Cycles Per Issued|No Eligible|Executed Instructions|L1/TEX Hit|L2 Hit|Block Size|Grid Size|Stall|DRAM' ; } >>"$OUT/profile.txt"
    ncu --import "$OUT/raw/$r.ncu-rep" --page source --csv --print-source sass \
      >"$OUT/raw/$r-sass.csv" 2>/dev/null || true
  done
  note "== profile in $(( $(date +%s) - t0 )) s (profile.txt)"
  head -80 "$OUT/profile.txt" >>"$SUMMARY" 2>/dev/null
fi
tar -C "$OUT" -czf "$OUT/results.tgz" raw && rm -rf "$OUT/raw"
note "== done"
