#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test (ctest). Extra arguments go to ctest,
# e.g. scripts/test.sh -R Crms  or  scripts/test.sh -L gpu
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${TSF_BUILD_DIR:-$ROOT/build}"
"$ROOT/scripts/setup.sh"
cd "$BUILD_DIR"
# The viewer tests render through X (Debian's VTK has no OSMesa/EGL): give them a virtual display
# when there is none. -noreset: an X server resets when its last client disconnects and refuses
# connections while it does, so a viewer test starting just as another ends would fail at random.
XRUN=()
if [ -z "${DISPLAY:-}" ] && command -v xvfb-run >/dev/null; then
  XRUN=(xvfb-run -a -s "-screen 0 1280x1024x24 -noreset")
fi
"${XRUN[@]}" ctest --output-on-failure -j "${TSF_JOBS:-$(nproc)}" --timeout 1800 "$@"
