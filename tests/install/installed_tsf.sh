#!/bin/sh
# An installed tsf finds its bundled files relative to itself: install the build into a fresh
# prefix, then from an unrelated folder (no source checkout above it) run `tsf run --materials`
# and `tsf run` (the bundled sinus scene, CI-sized) with nothing but PREFIX.
#   installed_tsf.sh BUILD_DIR CMAKE
set -eu
build=$1
cmake=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$cmake" --install "$build" --prefix "$tmp/prefix" >"$tmp/install.log"
tsf="$tmp/prefix/bin/tsf"
test -x "$tsf" || { echo "no executable at $tsf"; exit 1; }
for f in scenes/sinus.yaml materials/tissues.yaml presets/segment/sinus.yaml \
         data-samples/ct-head-cranium/cranium.nrrd; do
  test -e "$tmp/prefix/share/tsf/$f" || { echo "not installed: share/tsf/$f"; exit 1; }
done
test -e "$tmp/prefix/share/doc/tsf/README.md" || { echo "not installed: share/doc/tsf/README.md"; exit 1; }
mkdir "$tmp/elsewhere"
cd "$tmp/elsewhere"
"$tsf" run --materials >materials.txt
grep -q turbinate_soft_tissue materials.txt || { echo "tsf run --materials:"; cat materials.txt; exit 1; }
"$tsf" run -q --backend cpu --voxel-mm 2 --duration 0.004 -o out/sinus
test -s out/sinus/run-report.json || { echo "tsf run wrote no report"; exit 1; }
grep -q '"verdict"' out/sinus/run-report.json
echo "installed tsf ran from $tmp/elsewhere with prefix $tmp/prefix"
