#!/bin/sh
# The Debian package: cpack builds it from the build tree into a scratch folder; its file list
# holds the executable, the bundled files, the manual page and the completion under /usr, and
# its Depends names Debian's shared-library packages (dpkg-shlibdeps), e.g. ITK's and VTK's.
#   deb_package.sh BUILD_DIR CPACK
set -eu
build=$1
cpack=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
(cd "$build" && "$cpack" -G DEB -B "$tmp" >"$tmp/cpack.log" 2>&1) || { cat "$tmp/cpack.log"; exit 1; }
deb=$(ls "$tmp"/tsf_*.deb)
dpkg-deb -c "$deb" >"$tmp/files.txt"
for f in ./usr/bin/tsf ./usr/share/tsf/scenes/sinus.yaml ./usr/share/tsf/presets/segment/sinus.yaml \
         ./usr/share/tsf/materials/tissues.yaml ./usr/share/man/man1/tsf.1 \
         ./usr/share/bash-completion/completions/tsf ./usr/share/doc/tsf/README.md; do
  grep -q " $f\$" "$tmp/files.txt" || { echo "$deb lacks $f"; cat "$tmp/files.txt" | head -20; exit 1; }
done
depends=$(dpkg-deb -f "$deb" Depends)
echo "Depends: $depends"
case "$depends" in *libc6*) ;; *) echo "Depends names no shared-library package"; exit 1 ;; esac
case "$depends" in *libinsighttoolkit*|*libitk*) ;; *) echo "Depends lacks ITK"; exit 1 ;; esac
echo "$(basename "$deb"): $(wc -l <"$tmp/files.txt") files, $(du -h "$deb" | cut -f1)"
