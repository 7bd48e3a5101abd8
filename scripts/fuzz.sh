#!/usr/bin/env bash
# Fuzz campaigns (docs/robustness.md): builds the libFuzzer harnesses with clang + ASan + UBSan
# in build-fuzz, then runs each target for SECONDS on a working copy of its seed corpus.
#   scripts/fuzz.sh [SECONDS] [TARGET...]     default: 60 s each; dicom volume tsfmesh yaml
# (dicom_codec: the DICOM codecs inside the fuzzer's process, so its coverage reaches them; the
# dicom target decodes as tsf import does, compressed files in decoder processes.)
# Prints one line per target (runs, new corpus entries, findings). Findings (crash-*, leak-*,
# timeout-*, oom-*) land in build-fuzz/findings/TARGET: fix the cause, then keep the input in
# fuzz/regressions/TARGET, where FuzzCorpusRobustness replays it under ASan + UBSan in CI.
# Limits per input: 30 s (a slower input is a hang) and 2.5 GB of memory (the import's bound:
# 2 x a 2^24-voxel volume + 256 MB, with room for the sanitizers).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECONDS_PER_TARGET="${1:-60}"
shift || true
TARGETS=("$@")
[ ${#TARGETS[@]} -eq 0 ] && TARGETS=(dicom volume tsfmesh yaml)
BUILD="$ROOT/build-fuzz"
export TSF_SKIP_INSTALL="${TSF_SKIP_INSTALL:-0}"
for p in clang libclang-rt-14-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" ||
    { echo "fuzz: needs Debian package $p (apt-get install --no-install-recommends $p)" >&2; exit 1; }
done
if [ ! -f "$BUILD/CMakeCache.txt" ]; then
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DTSF_FUZZ=ON -DTSF_SANITIZE=ON \
    -DTSF_WITH_CUDA=OFF -DTSF_WITH_VTK=OFF -DTSF_WITH_ASSIMP=OFF -DTSF_BUILD_BENCH=OFF \
    -DTSF_BUILD_APP=OFF -DTSF_BUILD_TESTS=OFF >"$BUILD.configure.log"
fi
ninja -C "$BUILD" -j "${TSF_JOBS:-$(nproc)}" "${TARGETS[@]/#/tsf_fuzz_}" >/dev/null
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=1}"
# Leaks inside GDCM and ITK on inputs they reject are theirs (fuzz/lsan-third-party.supp).
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$ROOT/fuzz/lsan-third-party.supp}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
for t in "${TARGETS[@]}"; do
  work="$BUILD/corpus/$t"
  findings="$BUILD/findings/$t"
  mkdir -p "$work" "$findings"
  before=$(find "$work" -type f | wc -l)
  log="$BUILD/fuzz-$t.log"
  set +e
  seeds="$ROOT/fuzz/corpus/${t%_codec}"
  "$BUILD/fuzz/tsf_fuzz_$t" -max_total_time="$SECONDS_PER_TARGET" -timeout=30 \
    -rss_limit_mb=2560 -max_len=65536 -print_final_stats=1 -artifact_prefix="$findings/" \
    -ignore_crashes=1 -fork=1 "$work" "$seeds" >"$log" 2>&1
  set -e
  # The fork-mode status lines: "#RUNS: cov: ... oom/timeout/crash: O/T/C time: ...".
  last=$(grep -E '^#[0-9]+: cov' "$log" | tail -1)
  runs=$(echo "$last" | sed -E 's/^#([0-9]+):.*/\1/')
  otc=$(echo "$last" | sed -E 's/.*oom\/timeout\/crash: ([0-9]+\/[0-9]+\/[0-9]+).*/\1/')
  after=$(find "$work" -type f | wc -l)
  found=$(find "$findings" -type f | wc -l)
  echo "fuzz $t: ${SECONDS_PER_TARGET} s, ${runs:-0} inputs run, oom/timeout/crash ${otc:-?}," \
    "corpus $before -> $after, $found finding files in $findings"
done
