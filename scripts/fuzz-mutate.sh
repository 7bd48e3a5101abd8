#!/usr/bin/env bash
# Mutation campaigns with tsf_fuzz_mutate (docs/robustness.md, "Mutation campaigns"): every fuzz
# target, a fixed number of cases each, reproducible from --seed. Any build works; the sanitizer
# build (build-asan, as .ci/run configures it) finds memory errors and undefined behaviour, the
# release build measures peak memory per case (--memory).
#
#   scripts/fuzz-mutate.sh BUILD_DIR [DICOM_CASES] [OTHER_CASES] [SEED] [--memory]
#       defaults: 20000 DICOM cases, 5000 for each other target, seed 1
#
# DICOM seeds: fuzz/corpus/dicom, fuzz/regressions/dicom and, when ../shared/data is present, one
# file of each transfer syntax found there (every syntax the corpus holds). A summary per target
# goes to BUILD_DIR/fuzz-campaign/TARGET.txt, findings (inputs) to BUILD_DIR/fuzz-campaign/findings.
# Exit status 1 when any target had a finding. Runs under `nice -n 15`, one target at a time.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:?usage: scripts/fuzz-mutate.sh BUILD_DIR [DICOM_CASES] [OTHER_CASES] [SEED] [--memory]}"
DICOM_CASES="${2:-20000}"
OTHER_CASES="${3:-5000}"
SEED="${4:-1}"
MEMORY="${5:-}"
EXE="$BUILD/fuzz/tsf_fuzz_mutate"
[ -x "$EXE" ] || { echo "fuzz-mutate: build $EXE first (target tsf_fuzz_mutate)" >&2; exit 2; }
OUT="$BUILD/fuzz-campaign"
mkdir -p "$OUT/findings"
SHARED="${TSF_SHARED_DATA:-$ROOT/../shared/data}"

dicom_seeds=(--corpus "$ROOT/fuzz/corpus/dicom" --corpus "$ROOT/fuzz/regressions/dicom")
if [ -f "$SHARED/dicom/INDEX.tsv" ]; then
  # The smallest file of each transfer syntax in the shared corpus's index.
  while IFS= read -r f; do dicom_seeds+=(--corpus "$SHARED/dicom/$f"); done < <(
    awk -F'\t' 'NR > 1 && $15 ~ /^1\.2\.840/ { split($15, ts, " "); print $2 "\t" ts[1] "\t" $1 }' \
      "$SHARED/dicom/INDEX.tsv" | sort -t$'\t' -k2,2 -k1,1n | awk -F'\t' '!seen[$2]++ { print $3 }')
fi

status=0
for target in $("$EXE" 2>&1 | sed -n 's/^targets: //p'); do
  cases="$OTHER_CASES"
  args=()
  if [ "$target" = "dicom" ]; then
    cases="$DICOM_CASES"
    args=("${dicom_seeds[@]}")
  fi
  [ "$MEMORY" = "--memory" ] && args+=(--memory)
  nice -n 15 "$EXE" "$target" --cases "$cases" --seed "$SEED" --quiet --timeout 120 \
    --findings "$OUT/findings" --summary "$OUT/$target.txt" "${args[@]}" | tee "$OUT/$target.line" ||
    status=1
done
exit $status
