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
#                                                      TSF_GPU_PROFILE_KERNELS="nodes": one;
#                                                      "folded": the node-parallel kernel with
#                                                      the volumetric term folded in, 2 and 1 mm)
#
# Without a build there (it takes ~3.5 of the session's device minutes on 16 cores), from binaries
# built here:
#   scripts/gpu-check.sh pack [BUILD] [DIR]   here: the tissue test suite and the tissue
#        benchmarks of a CUDA arch-90 build (default build/, e.g. scripts/setup.sh with
#        TSF_CMAKE_ARGS=-DCMAKE_CUDA_ARCHITECTURES=90), stripped, with the shared libraries ldd
#        names for them beyond glibc's, libstdc++ and libgcc_s, into DIR/gpu-binaries.tar.xz
#        (default .gpu/, ignored by git: carry it); TSF_GPU_PACK="bench_crms_throughput" packs
#        only the executables it names; TSF_GPU_PACK_TSF=BUILD2 adds BUILD2/bin/tsf (a CUDA
#        arch-90 build with ITK, VTK and assimp off) and the run there then runs the scenes
#   TSF_GPU_PREBUILT=DIR scripts/gpu-check.sh  there: unpack them instead of configuring and
#        building, run the suite in TSF_GPU_SHARDS parallel shards (default 8; gtest sharding),
#        the benchmarks and, with a tsf at TSF_GPU_TSF (e.g. the product's,
#        /opt/tsf-product/tsf/bin/tsf, scripts/gpu-product.sh), the scenes
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

# Libraries the GPU machine has of its own (newer) and the driver's.
SYSTEM_LIBS='^(ld-linux.*|libc|libm|libdl|libpthread|librt|libutil|libresolv|libstdc\+\+|libgcc_s|libcuda|libnvidia.*)\.so'
if [ "${1:-}" = "pack" ]; then
  set -e
  build="$(cd "${2:-$ROOT/build}" && pwd)"
  dir="$(mkdir -p "${3:-$ROOT/.gpu}" && cd "${3:-$ROOT/.gpu}" && pwd)"
  grep -qE '^CMAKE_CUDA_ARCHITECTURES:[A-Z]+=.*90' "$build/CMakeCache.txt" ||
    { echo "gpu-check pack: $build is not configured with CUDA for arch 90" >&2; exit 1; }
  stage=$(mktemp -d)
  trap 'rm -rf "$stage"' EXIT
  mkdir -p "$stage/p/bin" "$stage/p/bench" "$stage/p/lib" "$dir"
  # TSF_GPU_PACK: the executables to pack (default the suite and every tissue benchmark).
  wanted=" ${TSF_GPU_PACK:-all} "
  if [[ "$wanted" == " all " || "$wanted" == *" tsf_tissue_tests "* ]]; then
    cp "$build/tests/tsf_tissue_tests" "$stage/p/bin/"
  fi
  # TSF_GPU_PACK_TSF=DIR: also DIR/bin/tsf, from a CUDA arch-90 build without ITK, VTK and
  # assimp (it needs no library the GPU machine lacks but yaml-cpp, packed below), so that the
  # scenes on the segmented sample run there too (the whole product: scripts/gpu-product.sh).
  if [ -n "${TSF_GPU_PACK_TSF:-}" ]; then
    grep -qE '^TSF_WITH_ITK:BOOL=OFF' "$TSF_GPU_PACK_TSF/CMakeCache.txt" ||
      { echo "gpu-check pack: $TSF_GPU_PACK_TSF is not a build without ITK" >&2; exit 1; }
    cp "$TSF_GPU_PACK_TSF/bin/tsf" "$stage/p/bin/"
  fi
  for b in "$build"/bench/bench_*; do
    [ -x "$b" ] && [ -f "$b" ] || continue
    [[ "$wanted" == " all " || "$wanted" == *" $(basename "$b") "* ]] || continue
    # The tissue benchmarks only (the others need ITK, VTK or assimp).
    [ -f "$ROOT/bench/tissue/$(basename "$b").cpp" ] || [ -f "$ROOT/bench/tissue/$(basename "$b").cu" ] || continue
    cp "$b" "$stage/p/bench/"
  done
  shopt -s nullglob
  exes=("$stage/p/bin/"* "$stage/p/bench/"*)
  [ ${#exes[@]} -gt 0 ] || { echo "gpu-check pack: nothing to pack (TSF_GPU_PACK=$wanted)" >&2; exit 1; }
  strip --strip-unneeded "${exes[@]}"
  ldd "${exes[@]}" | awk '/=> \// {print $3}' | sort -u | while read -r lib; do
    [[ "$(basename "$lib")" =~ $SYSTEM_LIBS ]] || cp -L "$lib" "$stage/p/lib/"
  done
  strip --strip-unneeded "$stage/p/lib/"* 2>/dev/null || true
  # The source dir compiled into the binaries (sample data paths): linked to the checkout there.
  sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$build/CMakeCache.txt" >"$stage/p/source-dir.txt"
  git -C "$ROOT" describe --always --dirty >"$stage/p/git.txt" 2>/dev/null || true
  (cd "$stage" && tar -cf - p | xz -9 -T2 >"$dir/gpu-binaries.tar.xz")
  echo "gpu-check pack: ${#exes[@]} executables," \
    "$(ls "$stage/p/lib" | wc -l) libraries: $dir/gpu-binaries.tar.xz ($(du -h "$dir/gpu-binaries.tar.xz" | cut -f1))"
  exit 0
fi

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
if [ -n "${TSF_GPU_PREBUILT:-}" ]; then
  BUILD=/tmp/tsf-gpu-prebuilt
  rm -rf "$BUILD" && mkdir -p "$BUILD"
  xz -dc "$TSF_GPU_PREBUILT/gpu-binaries.tar.xz" | tar -C "$BUILD" --strip-components=1 -xf - ||
    { note "unpacking $TSF_GPU_PREBUILT/gpu-binaries.tar.xz FAILED"; exit 1; }
  export LD_LIBRARY_PATH="$BUILD/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  src=$(cat "$BUILD/source-dir.txt")
  if [ -n "$src" ] && [ "$src" != "$ROOT" ] && [ ! -e "$src" ]; then
    mkdir -p "$(dirname "$src")" && ln -s "$ROOT" "$src"
  fi
  note "== prebuilt binaries of $(cat "$BUILD/git.txt" 2>/dev/null) (source dir $src), unpacked in $(( $(date +%s) - t0 )) s"
  [ -n "${TSF_GPU_TSF:-}" ] && [ -x "$TSF_GPU_TSF" ] && mkdir -p "$BUILD/bin" && ln -sf "$TSF_GPU_TSF" "$BUILD/bin/tsf"
else
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DTSF_WITH_ITK=OFF -DTSF_WITH_VTK=OFF \
    -DTSF_WITH_ASSIMP=OFF -DTSF_WITH_CUDA=ON -DCMAKE_CUDA_ARCHITECTURES=90 >"$OUT/raw/configure.log" 2>&1 \
    || { note "configure FAILED"; tail -40 "$OUT/raw/configure.log" | tee -a "$SUMMARY"; exit 1; }
  targets=()
  for t in ${TSF_GPU_BUILD_TARGETS:-}; do targets+=(--target "$t"); done
  cmake --build "$BUILD" -j "$JOBS" "${targets[@]}" >"$OUT/raw/build.log" 2>&1 \
    || { note "build FAILED"; grep -E 'error|Error' "$OUT/raw/build.log" | head -40 | tee -a "$SUMMARY"; exit 1; }
  note "== build ok in $(( $(date +%s) - t0 )) s ($(grep -c warning "$OUT/raw/build.log") warning lines)"
fi

if [ "${TSF_GPU_SKIP_TESTS:-0}" != "1" ] && [ -n "${TSF_GPU_PREBUILT:-}" ]; then
  # gtest's own sharding: every test in exactly one shard, the shards in parallel.
  t0=$(date +%s)
  shards=${TSF_GPU_SHARDS:-8}
  for i in $(seq 0 $((shards - 1))); do
    GTEST_TOTAL_SHARDS=$shards GTEST_SHARD_INDEX=$i timeout 580 "$BUILD/bin/tsf_tissue_tests" \
      --gtest_output="xml:$OUT/raw/shard-$i.xml" ${TSF_GPU_GTEST_ARGS:-} >"$OUT/raw/shard-$i.log" 2>&1 &
  done
  wait
  cat "$OUT/raw"/shard-*.log >"$OUT/ctest.log"
  python3 - "$OUT/raw" >>"$SUMMARY" <<'PY'
import glob, sys, xml.etree.ElementTree as ET
run = failed = skipped = 0
bad, skips = [], {}
for f in sorted(glob.glob(sys.argv[1] + "/shard-*.xml")):
    for case in ET.parse(f).getroot().iter("testcase"):
        name = case.get("classname") + "." + case.get("name")
        if case.get("status") == "notrun": continue
        run += 1
        if case.find("failure") is not None: failed += 1; bad.append(name)
        elif case.find("skipped") is not None or case.get("result") == "skipped":
            skipped += 1; s = case.find("skipped"); skips[(s.get("message") if s is not None else "")[:120]] = skips.get((s.get("message") if s is not None else "")[:120], 0) + 1
print("== tsf_tissue_tests: %d run, %d passed, %d failed, %d skipped" % (run, run - failed - skipped, failed, skipped))
for b in bad: print("   FAILED " + b)
for m, n in skips.items(): print("   skipped %d: %s" % (n, m))
PY
  note "== tests in $(( $(date +%s) - t0 )) s ($shards shards; logs in ctest.log)"
  grep -h -B2 -A12 '\[  FAILED  \]' "$OUT/raw"/shard-*.log | head -60 >>"$SUMMARY"
elif [ "${TSF_GPU_SKIP_TESTS:-0}" != "1" ]; then
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
  [[ " ${TSF_GPU_PROFILE_KERNELS:-symmetric nodes} " == *" nodes "* ]] &&
  timeout 120 ncu --clock-control none --set full -k regex:node_step_kernel \
    --launch-skip 2 --launch-count 1 -o "$OUT/raw/nodes-sinus" "$b" \
    --benchmark_filter='BM_CrmsSinusLatticeStep/2/3/0/' --benchmark_min_time=0.01 \
    >"$OUT/raw/ncu-nodes.log" 2>&1
  # "folded": the node-parallel kernel with the volumetric term folded in (ν = 0.45, the shipped
  # sinus scenes), 2 and 1 mm. The benchmark first steps the effect-pass form 2 × 1024 times
  # (2,048 one-step launches of the same kernel): the folded launch is the 2,049th.
  if [[ " ${TSF_GPU_PROFILE_KERNELS:-symmetric nodes} " == *" folded "* ]]; then
    for k in 2 1; do
      timeout 150 ncu --clock-control none --set full -k regex:node_step_kernel \
        --launch-skip 2048 --launch-count 1 -o "$OUT/raw/folded-sinus-$k" "$b" \
        --benchmark_filter="BM_CrmsSinusLatticeStep/$k/3/1/" --benchmark_min_time=0.01 \
        >"$OUT/raw/ncu-folded-$k.log" 2>&1
    done
  fi
  for r in symmetric-256 nodes-sinus folded-sinus-2 folded-sinus-1; do
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
