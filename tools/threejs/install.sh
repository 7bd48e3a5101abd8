#!/usr/bin/env bash
# Installs three.js for the browser test of exported glTF (tests/export/test_browser_render.cpp)
# exactly as package-lock.json pins it (npm ci), into tools/threejs/node_modules. Idempotent: does
# nothing when the pinned version is already there. Needs npm (Node.js) and the npm registry.
#   tools/threejs/install.sh          exit 0 installed (or already), 1 failed, 2 npm missing
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
want="$(sed -n 's/.*"three": "\([0-9.]*\)".*/\1/p' "$HERE/package.json" | head -1)"
have="$(sed -n 's/.*"version": "\([0-9.]*\)".*/\1/p' "$HERE/node_modules/three/package.json" 2>/dev/null | head -1 || true)"
if [ -n "$want" ] && [ "$have" = "$want" ]; then exit 0; fi
if ! command -v npm >/dev/null; then
  echo "tools/threejs/install.sh: npm is not installed (it comes with Node.js), cannot install three.js $want" >&2
  exit 2
fi
cd "$HERE"
npm ci --no-audit --no-fund --loglevel=error >/dev/null
echo "tools/threejs/install.sh: three.js $want installed in $HERE/node_modules"
