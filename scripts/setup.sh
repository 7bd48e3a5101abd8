#!/usr/bin/env bash
# Installs the Debian packages tsf needs (only those missing; quiet when all are present),
# then configures and builds. Idempotent: a second run only rebuilds what changed.
#
#   scripts/setup.sh                       full build in ./build
#   TSF_BUILD_DIR=build-asan TSF_CMAKE_ARGS="-DTSF_SANITIZE=ON" scripts/setup.sh
#   TSF_BUILD_TARGETS="tsf_import_tests" scripts/setup.sh     build only these targets
#   TSF_SKIP_INSTALL=1 scripts/setup.sh    never call apt-get (machines without root)
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${TSF_BUILD_DIR:-$ROOT/build}"
case "$BUILD_DIR" in /*) ;; *) BUILD_DIR="$ROOT/$BUILD_DIR" ;; esac
JOBS="${TSF_JOBS:-$(nproc)}"

# Debian 12 package names. Build tools, then one line per module.
PACKAGES=(
  cmake ninja-build g++ pkg-config
  libeigen3-dev libgtest-dev libgmock-dev libbenchmark-dev                      # tissue, tests, bench
  libcli11-dev nlohmann-json3-dev libyaml-cpp-dev libspdlog-dev libfmt-dev      # app
  libinsighttoolkit5-dev libgdcm-dev libgdcm-tools libdcmtk-dev                 # import, segment
  libvtk9-dev libtbb-dev xvfb xauth                                            # viewer
  libassimp-dev zlib1g-dev libmeshoptimizer-dev nodejs                         # export (nodejs runs the glTF validator in tests)
  chromium                                                                     # export: three.js renders exported glTF in tests
  gnuplot-nox                                                                  # report plots
  dpkg-dev file                                                                # the .deb (cpack: dpkg-shlibdeps)
  snakemake                                                                    # the cohort workflow (scripts/cohort)
  libopenigtlink-dev openigtlink-examples                                      # the live link (tsf link); its CI test builds the examples
)

install_missing_packages() {
  [ "${TSF_SKIP_INSTALL:-0}" = "1" ] && return 0
  local missing=()
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  # npm installs three.js for the browser test (install_threejs). Debian's nodejs leaves it to the
  # package npm; NodeSource's nodejs carries its own and conflicts with that package.
  command -v npm >/dev/null || missing+=(npm)
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "tsf setup: installing ${#missing[@]} missing Debian package(s): ${missing[*]}"
  local sudo=""
  if [ "$(id -u)" != "0" ]; then
    command -v sudo >/dev/null || { echo "tsf setup: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
    sudo="sudo"
  fi
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get -q -o DPkg::Lock::Timeout=600 update >/dev/null
  $sudo apt-get -q -y -o DPkg::Lock::Timeout=600 install --no-install-recommends "${missing[@]}" >/dev/null
  echo "tsf setup: packages installed"
}

configure_and_build() {
  local args=(-S "$ROOT" -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE="${TSF_BUILD_TYPE:-Release}")
  # shellcheck disable=SC2206
  [ -n "${TSF_CMAKE_ARGS:-}" ] && args+=(${TSF_CMAKE_ARGS})
  local stamp="$BUILD_DIR/.tsf-configure-args"
  if [ ! -f "$BUILD_DIR/CMakeCache.txt" ] || [ "$(cat "$stamp" 2>/dev/null)" != "${args[*]}" ]; then
    echo "tsf setup: configuring $BUILD_DIR"
    cmake "${args[@]}" >"$BUILD_DIR.configure.log" 2>&1 || { cat "$BUILD_DIR.configure.log" >&2; exit 1; }
    echo "${args[*]}" >"$stamp"
  fi
  local targets=()
  for t in ${TSF_BUILD_TARGETS:-}; do targets+=(--target "$t"); done
  echo "tsf setup: building in $BUILD_DIR with $JOBS job(s)"
  cmake --build "$BUILD_DIR" -j "$JOBS" "${targets[@]}"
}

# three.js for the browser test of exported glTF, pinned by tools/threejs/package-lock.json
# (npm ci). Without npm the test says it was not run; with TSF_REQUIRE_BROWSER_TEST=1 (CI) a
# failed install stops the setup.
install_threejs() {
  [ "${TSF_SKIP_INSTALL:-0}" = "1" ] && return 0
  local required="${TSF_REQUIRE_BROWSER_TEST:-0}"
  if ! command -v npm >/dev/null; then
    [ "$required" = "1" ] && { echo "tsf setup: npm not found: cannot install three.js for the browser test (TSF_REQUIRE_BROWSER_TEST=1)" >&2; exit 1; }
    echo "tsf setup: npm not found: three.js not installed (the browser test will say it was not run)"
    return 0
  fi
  if ! "$ROOT/tools/threejs/install.sh"; then
    [ "$required" = "1" ] && { echo "tsf setup: installing three.js failed (TSF_REQUIRE_BROWSER_TEST=1)" >&2; exit 1; }
    echo "tsf setup: installing three.js failed (the browser test will fail and say why)" >&2
  fi
}

install_missing_packages
install_threejs
mkdir -p "$BUILD_DIR"
configure_and_build
