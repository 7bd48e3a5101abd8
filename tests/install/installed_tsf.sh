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
# The manual page and the completion, generated from the commands' definitions.
man="$tmp/prefix/share/man/man1/tsf.1"
grep -q '^\.TH TSF 1' "$man" || { echo "no manual page at $man"; exit 1; }
for c in import info segment simulate haptics export view run; do
  grep -q "^\.SS \"tsf $c\"" "$man" || { echo "the manual page lacks tsf $c"; exit 1; }
done
completion="$tmp/prefix/share/bash-completion/completions/tsf"
words=$(bash -c ". '$completion'; COMP_WORDS=(tsf i); COMP_CWORD=1; _tsf; echo \${COMPREPLY[*]}")
[ "$words" = "import info" ] || { echo "completion of 'tsf i': '$words'"; exit 1; }
words=$(bash -c ". '$completion'; COMP_WORDS=(tsf run --c); COMP_CWORD=2; _tsf; echo \${COMPREPLY[*]}")
case " $words " in *" --ct "*) ;; *) echo "completion of 'tsf run --c': '$words'"; exit 1 ;; esac
mkdir "$tmp/elsewhere"
cd "$tmp/elsewhere"
"$tsf" run --materials >materials.txt
grep -q turbinate_soft_tissue materials.txt || { echo "tsf run --materials:"; cat materials.txt; exit 1; }
"$tsf" run -q --backend cpu --voxel-mm 2 --duration 0.004 -o out/sinus
test -s out/sinus/run-report.json || { echo "tsf run wrote no report"; exit 1; }
grep -q '"verdict"' out/sinus/run-report.json
echo "installed tsf ran from $tmp/elsewhere with prefix $tmp/prefix"
