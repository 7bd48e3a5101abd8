#!/usr/bin/env bash
# Two builds of the same benchmarks and scenes run alternately in one GPU-machine call, so that a
# change is measured against the code before it on the same host at the same time (the host's
# speed varies from call to call by more than most changes).
#
# Here, for each build (CUDA arch 90; the one before the change, e.g. from a stash, and this one):
#   TSF_GPU_PACK="tsf_tissue_tests bench_collision" TSF_GPU_PACK_TSF=build-gpu-only \
#     scripts/gpu-check.sh pack build-gpu-only DIR           (DIR: .gpu-old, then .gpu)
# There (the device tool, carrying both DIRs):
#   scripts/gpu-ab.sh .gpu-old .gpu
# runs gpu-check.sh on the new pack (the suite, bench_collision on CUDA, the scenes), then
# TSF_AB_ROUNDS (default 2) rounds of: bench_collision --presses 60 --backend cuda and
# `tsf simulate scenes/sinus-segmented.yaml --backend cuda` with the old build, then the new;
# in the first round also scenes/sinus-segmented-fine.yaml. Results: $OUT/summary.txt (gpu-check)
# and $OUT/ab.tgz (ab/collision-{old,new}-R.txt, ab/{sinus-*,fine-*}.{json,log}).
set -u
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
old_pack="${1:?usage: scripts/gpu-ab.sh OLD_PACK_DIR NEW_PACK_DIR}"
new_pack="${2:?usage: scripts/gpu-ab.sh OLD_PACK_DIR NEW_PACK_DIR}"
OUT="${OUT:-$ROOT/out/gpu}"
TSF_GPU_PREBUILT="$new_pack" TSF_GPU_SHARDS="${TSF_GPU_SHARDS:-12}" TSF_GPU_BENCH_FILTER='^bench_collision$' \
  TSF_GPU_BENCH_ARGS="--presses 60 --backend cuda" OUT="$OUT" scripts/gpu-check.sh
rm -rf /tmp/tsf-ab-old && mkdir -p /tmp/tsf-ab-old
xz -dc "$old_pack/gpu-binaries.tar.xz" | tar -C /tmp/tsf-ab-old --strip-components=1 -xf -
mkdir -p "$OUT/ab"
for r in $(seq 1 "${TSF_AB_ROUNDS:-2}"); do
  for v in old new; do
    d=/tmp/tsf-ab-old
    [ "$v" = new ] && d=/tmp/tsf-gpu-prebuilt  # where gpu-check.sh unpacked the new pack
    LD_LIBRARY_PATH="$d/lib" timeout 200 "$d/bench/bench_collision" --presses 60 --backend cuda \
      >"$OUT/ab/collision-$v-$r.txt" 2>&1
    LD_LIBRARY_PATH="$d/lib" timeout 200 "$d/bin/tsf" simulate scenes/sinus-segmented.yaml \
      --backend cuda --out "/tmp/tsf-ab-s-$v-$r" --report "$OUT/ab/sinus-$v-$r.json" \
      >"$OUT/ab/sinus-$v-$r.log" 2>&1
    if [ "$r" = 1 ]; then
      LD_LIBRARY_PATH="$d/lib" timeout 200 "$d/bin/tsf" simulate scenes/sinus-segmented-fine.yaml \
        --backend cuda --out "/tmp/tsf-ab-f-$v" --report "$OUT/ab/fine-$v.json" \
        >"$OUT/ab/fine-$v.log" 2>&1
    fi
    echo "$v round $r done $(date +%T)" >>"$OUT/ab/progress.txt"
  done
done
rm -rf "$OUT/raw"  # gpu-check's raw files are in its results.tgz
tar -C "$OUT" -czf "$OUT/ab.tgz" ab && rm -rf "$OUT/ab"
