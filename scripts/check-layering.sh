#!/usr/bin/env bash
# Checks that tissue/ keeps to its declared module layering (tissue/LAYERS.txt):
#   - every #include "tsf/<module>/..." names the including file's own module or one that the
#     table lets it depend on (directly or through its dependencies);
#   - every module folder under tissue/include/tsf/ and tissue/src/ is declared, and the declared
#     dependencies are declared modules and form no cycle;
#   - nothing in tissue/ includes ITK, VTK, assimp, DCMTK, GDCM, yaml-cpp, nlohmann-json, CLI11,
#     the import/segment/export/viewer/app layers, or a path with "..";
#   - a quoted include without "tsf/" is a private header next to the including file;
#   - tissue's CMake files find or link none of those libraries or layers.
# Prints one line per violation and exits 1 when there is any (2 when it cannot run).
#
# Usage: scripts/check-layering.sh [ROOT]    ROOT: the repository root (default: this script's).
set -euo pipefail
ROOT="${1:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}"
TISSUE="$ROOT/tissue"
LAYERS="$TISSUE/LAYERS.txt"
for need in "$LAYERS" "$TISSUE/include/tsf" "$TISSUE/src"; do
  [ -e "$need" ] || { echo "check-layering: $need not found" >&2; exit 2; }
done

work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# Files of tissue/ (relative to it), the module folders, and every #include line.
(cd "$TISSUE" && find include src -type f | LC_ALL=C sort) > "$work/files"
(cd "$TISSUE" && { find include/tsf -mindepth 1 -maxdepth 1 -type d -printf '%f\n'
                   find src -mindepth 1 -maxdepth 1 -type d -printf '%f\n'; } | LC_ALL=C sort -u) \
  > "$work/modules"
(cd "$TISSUE" && grep -rnE '^[[:space:]]*#[[:space:]]*include' include src || true) > "$work/includes"
(cd "$TISSUE" && find . -name CMakeLists.txt -o -name '*.cmake' | xargs -r grep -nHiE \
  'find_package[[:space:]]*\([[:space:]]*(ITK|VTK|assimp|DCMTK|GDCM|yaml-cpp|nlohmann_json|CLI11)|(tsf::|tsf_)(import|segment|export|viewer|app)\b' \
  || true) > "$work/cmake"

awk -v layers="$LAYERS" -v files="$work/files" -v modules="$work/modules" -v cmake="$work/cmake" '
function fail(msg) { print msg; ++violations }
BEGIN {
  # The table.
  while ((getline line < layers) > 0) {
    ++lineno
    sub(/#.*/, "", line)
    if (line ~ /^[[:space:]]*$/) continue
    if (line !~ /^[[:space:]]*[a-z_]+[[:space:]]*:/) {
      fail("tissue/LAYERS.txt:" lineno ": expected `module: dependencies`, got: " line); continue
    }
    m = line; sub(/:.*/, "", m); gsub(/[[:space:]]/, "", m)
    rest = line; sub(/^[^:]*:/, "", rest)
    if (m in declared) fail("tissue/LAYERS.txt:" lineno ": module " m " declared twice")
    declared[m] = 1; order[++n_modules] = m
    n = split(rest, ds, /[[:space:]]+/)
    for (i = 1; i <= n; ++i) if (ds[i] != "") { dep[m, ds[i]] = 1; reach[m, ds[i]] = 1; deps_of[m] = deps_of[m] " " ds[i] }
  }
  for (key in dep) {
    split(key, p, SUBSEP)
    if (!(p[2] in declared)) fail("tissue/LAYERS.txt: " p[1] " depends on undeclared module " p[2])
  }
  # Transitive closure (a few modules: plain fixed point), then cycles.
  do {
    changed = 0
    for (key in reach) {
      split(key, p, SUBSEP)
      for (j = 1; j <= n_modules; ++j) {
        e = order[j]
        if (((p[2], e) in dep) && !((p[1], e) in reach)) { reach[p[1], e] = 1; changed = 1 }
      }
    }
  } while (changed)
  for (j = 1; j <= n_modules; ++j)
    if ((order[j], order[j]) in reach)
      fail("tissue/LAYERS.txt: the declared dependencies of " order[j] " lead back to it (a cycle)")
  # Module folders on disk must be declared.
  while ((getline m < modules) > 0)
    if (!(m in declared)) fail("tissue/: module folder " m " is not declared in tissue/LAYERS.txt")
  while ((getline f < files) > 0) exists[f] = 1
  while ((getline line < cmake) > 0)
    fail("tissue/" substr(line, 3) "  <- tissue/ must not use this library or layer")
}
{
  # grep -rn: path:line:text
  path = $0; sub(/:.*/, "", path)
  rest = substr($0, length(path) + 2); ln = rest; sub(/:.*/, "", ln)
  text = substr(rest, length(ln) + 2)
  where = "tissue/" path ":" ln
  ++includes
  if (path ~ /^include\/tsf\//) { m = path; sub(/^include\/tsf\//, "", m); sub(/\/.*/, "", m) }
  else if (path ~ /^src\/[^\/]+\//) { m = path; sub(/^src\//, "", m); sub(/\/.*/, "", m) }
  else { fail(where ": file outside any module folder"); next }
  if (!(m in declared)) next  # reported once above
  if (match(text, /[<"][^>"]+[>"]/) == 0) { fail(where ": unreadable include: " text); next }
  target = substr(text, RSTART + 1, RLENGTH - 2)
  quoted = substr(text, RSTART, 1) == "\""
  lower = tolower(target)
  if (lower ~ /^(itk|vtk|gdcm)|^(assimp|dcmtk|gdcm[^\/]*|yaml-cpp|nlohmann|cli)\/|^yaml\.h$/) {
    fail(where ": " m " includes " target ": tissue/ must not use ITK, VTK, assimp, DCMTK, GDCM, yaml-cpp, nlohmann-json or CLI11"); next
  }
  if (target ~ /(^|\/)\.\.(\/|$)/) { fail(where ": " m " includes " target ": no relative paths out of a module"); next }
  if (target ~ /^tsf\/(import|segment|export|viewer|app)\//) {
    fail(where ": " m " includes " target ": tissue/ never includes the import, segment, export, viewer or app layers"); next
  }
  if (target ~ /^tsf\//) {
    t = target; sub(/^tsf\//, "", t); sub(/\/.*/, "", t)
    if (!(t in declared)) { fail(where ": " m " includes " target ": " t " is not a tissue module"); next }
    if (t != m && !((m, t) in reach))
      fail(where ": " m " includes " target ": " m " may depend on {" deps_of[m] " } (and theirs) only, not " t " (tissue/LAYERS.txt)")
    next
  }
  if (quoted) {
    dir = path; sub(/\/[^\/]*$/, "", dir)
    if (!((dir "/" target) in exists))
      fail(where ": " m " includes \"" target "\": a quoted include is tsf/<module>/... or a private header in " dir "/")
  }
}
END {
  if (violations) { print "check-layering: " violations " violation(s)"; exit 1 }
  print "check-layering: " includes " includes in tissue/ follow tissue/LAYERS.txt (" n_modules " modules)"
}' "$work/includes"
