#!/usr/bin/env bash
# The whole product on the GPU machine, which has a GPU, CUDA and a compiler but none of tsf's
# other libraries (ITK, VTK, assimp, DCMTK, GDCM, yaml-cpp, …), no X server and no OpenGL
# loaders, and cannot install anything. Two halves:
#
#   scripts/gpu-product.sh bundle [DIR]   here (Debian): build tsf with every module and CUDA for
#                                         arch 90 (scripts/setup.sh), then write into DIR
#                                         (default out/product):
#     tsf-lib.tar.xz  PREFIX/lib/*: every shared library ldd names for tsf except glibc's,
#                  libstdc++ and libgcc_s, which the machine has (stripped)
#     tsf-bin.tar.xz  PREFIX/libexec/tsf (stripped), PREFIX/bin/tsf (a wrapper that finds the
#                  libraries beside it: relocatable), PREFIX/share/tsf (scenes, materials, presets;
#                  not the sample CTs or the docs: the checkout that travels with every call holds
#                  them)
#     x11.tar.xz   Xvfb, xkbcomp and the keymaps, the GL loaders (libglvnd) and glxinfo, with
#                  their libraries: the X server and OpenGL that Debian's VTK renders through
#                  (GLX only).
#     mesa.tar.xz, z3.tar.xz  Mesa's GLX provider (swrast_dri.so, with LLVM and LLVM's libz3
#                  apart) and its GLX client library: Xvfb offers the GLX extension only with it
#   scripts/gpu-product.sh run [DIR]      there: unpack DIR's bundles into /opt/tsf-product (kept
#                                         when already unpacked by an earlier call on a warm
#                                         machine), start Xvfb (:99 or the next free display) with the driver's GLX
#                                         (__GLX_VENDOR_LIBRARY_NAME=nvidia), and run
#     tsf run --backend cuda             the sinus scene on the sample CT (scenes/sinus.yaml)
#     tsf view --offscreen --backend cuda  a view script on the segmented cranium, saving frames
#     tsf view --backend cuda --frames 300  the live window, with and without the haptic loop
#                  (TSF_PRODUCT_WINDOW="default haptics-off cpu" adds the CPU backend)
#                  writing under $OUT: product-summary.txt (real-time factors, steps/s, frames per
#                  second, edit latencies), the run and view reports, and frames (PNG).
#   Parts and steps can be picked: TSF_PRODUCT_PARTS="tsf x11 mesa" (bundle; default all),
#   TSF_PRODUCT_STEPS="x11 run view" (run; default all three).
#
# Sizes: a call carries 64 MiB with the checkout (~30 MB). tsf-lib.tar.xz is ~32 MB,
# mesa.tar.xz ~30 MB, tsf-bin.tar.xz ~10 MB, z3.tar.xz ~7 MB and x11.tar.xz ~4 MB: too much for
# one call, so they travel in three calls in a row (files unpacked outside the checkout stay on a
# warm machine, ~30 s between calls):
#   1st call: carry a folder with tsf-lib.tar.xz, run `scripts/gpu-product.sh run DIR` with
#             TSF_PRODUCT_STEPS=unpack (it unpacks and stops)
#   2nd call: the same with mesa.tar.xz
#   3rd call: carry tsf-bin.tar.xz, x11.tar.xz and z3.tar.xz, run `scripts/gpu-product.sh run DIR`
# TSF_PRODUCT_BACKEND=cpu runs the same steps on a machine without a GPU (to check the script).
# TSF_PRODUCT_ROOT names the checkout whose scenes and data-samples `run` uses (default: the one
# holding the script; the bundles may travel in a folder of their own with a copy of it).
# (docs/run.md "The whole product on the GPU machine").
set -euo pipefail
# The checkout whose scenes and sample data `run` uses (default: the one holding this script).
ROOT="${TSF_PRODUCT_ROOT:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}"
MODE="${1:-}"
DIR="${2:-$ROOT/out/product}"
PREFIX=/opt/tsf-product
BACKEND="${TSF_PRODUCT_BACKEND:-cuda}"  # cpu: try the steps on a machine without a GPU
# glibc, the C++ runtime and the loader: the GPU machine has its own (newer) ones, and the NVIDIA
# driver's libraries must load the machine's.
SYSTEM_LIBS='^(ld-linux.*|libc|libm|libdl|libpthread|librt|libutil|libresolv|libstdc\+\+|libgcc_s|libGLX_nvidia.*|libnvidia.*|libcuda)\.so'

usage() {
  sed -n '2,30p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
  exit "${1:-0}"
}

# Copies the non-system libraries that ldd names for the given executables into $1.
copy_libraries() {
  local dest=$1
  shift
  mkdir -p "$dest"
  ldd "$@" 2>/dev/null | awk '/=> \// {print $3}' | sort -u | while read -r lib; do
    local name
    name=$(basename "$lib")
    [[ "$name" =~ $SYSTEM_LIBS ]] && continue
    [ -e "$dest/$name" ] || cp -L "$lib" "$dest/$name"
  done
  ldd "$@" 2>/dev/null | grep -q "not found" && { echo "gpu-product: missing libraries:" >&2;
    ldd "$@" | grep "not found" >&2; exit 1; }
  return 0
}

bundle() {
  mkdir -p "$DIR"
  DIR="$(cd "$DIR" && pwd)"
  local parts="${TSF_PRODUCT_PARTS:-tsf x11 mesa}"
  STAGE=$(mktemp -d)
  trap 'rm -rf "$STAGE"' EXIT
  if [[ " $parts " == *" tsf "* ]]; then bundle_tsf "$STAGE"; fi
  if [[ " $parts " == *" x11 "* ]]; then bundle_x11 "$STAGE"; fi
  if [[ " $parts " == *" mesa "* ]]; then bundle_mesa "$STAGE"; fi
  ls -la "$DIR"/*.tar.xz
}

bundle_tsf() {
  local stage=$1
  if [ "${TSF_PRODUCT_SKIP_BUILD:-0}" != "1" ]; then
    TSF_BUILD_TARGETS="tsf" "$ROOT/scripts/setup.sh"
  fi
  local build="${TSF_BUILD_DIR:-$ROOT/build}"
  grep -qE '^CMAKE_CUDA_ARCHITECTURES:[A-Z]+=.*90' "$build/CMakeCache.txt" ||
    { echo "gpu-product: $build is not configured with CUDA for arch 90" >&2; exit 1; }

  # tsf: the installation minus what the checkout carries anyway.
  cmake --install "$build" --prefix "$stage/tsf" >/dev/null
  rm -rf "$stage/tsf/share/tsf/data-samples" "$stage/tsf/share/doc" "$stage/tsf/share/man" \
    "$stage/tsf/share/bash-completion"
  mkdir -p "$stage/tsf/libexec"
  mv "$stage/tsf/bin/tsf" "$stage/tsf/libexec/tsf"
  strip --strip-unneeded "$stage/tsf/libexec/tsf"
  copy_libraries "$stage/tsf/lib" "$stage/tsf/libexec/tsf"
  strip --strip-unneeded "$stage/tsf/lib/"*.so* 2>/dev/null || true
  cat >"$stage/tsf/bin/tsf" <<'EOF'
#!/bin/sh
# tsf with the shared libraries bundled beside it (scripts/gpu-product.sh).
here=$(dirname "$(readlink -f "$0")")
LD_LIBRARY_PATH="$here/../lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" exec "$here/../libexec/tsf" "$@"
EOF
  chmod +x "$stage/tsf/bin/tsf"
  (cd "$stage" && tar -cf - tsf/lib | xz -9e -T2 >"$DIR/tsf-lib.tar.xz")
  (cd "$stage" && tar -cf - tsf/bin tsf/libexec tsf/share | xz -9e -T2 >"$DIR/tsf-bin.tar.xz")
  echo "gpu-product: tsf has $(ls "$stage/tsf/lib" | wc -l) bundled libraries" \
    "($(du -sh "$stage/tsf/lib" | cut -f1) unpacked)"
}

bundle_x11() {
  # The X server, keymaps, GL loaders and glxinfo.
  local stage=$1
  local x="$stage/x11"
  mkdir -p "$x/bin" "$x/lib" "$x/share/X11"
  cp -L /usr/bin/Xvfb /usr/bin/xkbcomp "$x/bin/"
  cp -rL /usr/share/X11/xkb "$x/share/X11/"
  # glxinfo (Debian's mesa-utils) is how `run` finds out whether the driver's GLX answers: without
  # it the run cannot tell and renders with Mesa's llvmpipe (2-3x slower frames).
  local glxinfo
  glxinfo=$(command -v glxinfo.x86_64-linux-gnu || command -v glxinfo || true)
  if [ -z "$glxinfo" ] && [ "${TSF_SKIP_INSTALL:-0}" != "1" ]; then
    DEBIAN_FRONTEND=noninteractive apt-get -q -y -o DPkg::Lock::Timeout=600 install \
      --no-install-recommends mesa-utils >/dev/null || true
    glxinfo=$(command -v glxinfo.x86_64-linux-gnu || command -v glxinfo || true)
  fi
  [ -n "$glxinfo" ] || { echo "gpu-product: no glxinfo (Debian's mesa-utils) to bundle" >&2; exit 1; }
  cp -L "$glxinfo" "$x/bin/glxinfo"
  for l in libGL.so.1 libGLX.so.0 libGLdispatch.so.0 libOpenGL.so.0; do
    cp -L "/usr/lib/x86_64-linux-gnu/$l" "$x/lib/" 2>/dev/null || true
  done
  copy_libraries "$x/lib" "$x/bin/"*
  strip --strip-unneeded "$x/bin/"* "$x/lib/"*.so* 2>/dev/null || true
  (cd "$stage" && tar -cf - x11 | xz -9e -T2 >"$DIR/x11.tar.xz")
  echo "gpu-product: the X server has $(ls "$x/lib" | wc -l) libraries ($(du -sh "$x" | cut -f1) unpacked)"
}

bundle_mesa() {
  # Mesa's GLX provider for Xvfb (swrast_dri.so: llvmpipe, with LLVM) and its GLX client library:
  # Xvfb offers the GLX extension only with it. Libraries the tsf and X bundles already carry
  # are left out (Xvfb's library path reaches both).
  local stage=$1 m="$1/x11/lib"
  mkdir -p "$m/dri" "$stage/have"
  copy_libraries "$stage/have" "${TSF_BUILD_DIR:-$ROOT/build}/bin/tsf" /usr/bin/Xvfb /usr/bin/xkbcomp
  cp -L /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so "$m/dri/"
  cp -L /usr/lib/x86_64-linux-gnu/libGLX_mesa.so.0 "$m/"
  copy_libraries "$stage/mesa-deps" "$m/dri/swrast_dri.so" "$m/libGLX_mesa.so.0"
  for l in "$stage/mesa-deps/"*; do
    [ -e "$stage/have/$(basename "$l")" ] || mv "$l" "$m/"
  done
  strip --strip-unneeded "$m/"*.so* "$m/dri/"*.so 2>/dev/null || true
  # libz3 (LLVM's) apart, so that each part travels with the checkout in one call.
  mkdir -p "$stage/z3/x11/lib"
  mv "$m/libz3.so"* "$stage/z3/x11/lib/"
  (cd "$stage" && tar -cf - x11/lib | xz -9e -T2 >"$DIR/mesa.tar.xz")
  (cd "$stage/z3" && tar -cf - x11/lib | xz -9e -T2 >"$DIR/z3.tar.xz")
  echo "gpu-product: Mesa's GLX with $(ls "$m" | wc -l) files ($(du -sh "$m" | cut -f1) unpacked)"
}

start_x() {
  local x=$PREFIX/x11
  [ -x "$x/bin/Xvfb" ] || { echo "gpu-product: no X bundle unpacked in $x" >&2; return 1; }
  # Xvfb runs xkbcomp by its built-in path.
  [ -x /usr/bin/xkbcomp ] || cp "$x/bin/xkbcomp" /usr/bin/xkbcomp
  mkdir -p /tmp/.X11-unix
  export LD_LIBRARY_PATH="$x/lib:$PREFIX/tsf/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  export LIBGL_DRIVERS_PATH="$x/lib/dri"
  local n=99  # the first display number no other server holds
  while [ -e "/tmp/.X11-unix/X$n" ] || [ -e "/tmp/.X$n-lock" ]; do n=$((n + 1)); done
  "$x/bin/Xvfb" ":$n" -screen 0 1280x1024x24 -xkbdir "$x/share/X11/xkb" -nolisten tcp \
    >"$OUT/xvfb.log" 2>&1 &
  XVFB_PID=$!
  for _ in $(seq 50); do [ -S "/tmp/.X11-unix/X$n" ] && break; sleep 0.1; done
  [ -S "/tmp/.X11-unix/X$n" ] || { echo "gpu-product: Xvfb did not start:"; cat "$OUT/xvfb.log"; return 1; }
  echo "== Xvfb :$n started"
  export DISPLAY=":$n"
  GLX_VENDOR=mesa  # the driver's GLX when it answers, else Mesa's (llvmpipe)
  [ -x "$x/bin/glxinfo" ] || echo "== no glxinfo in the X bundle: the driver's GLX is not tried"
  if [ -x "$x/bin/glxinfo" ]; then
    for vendor in nvidia mesa; do
      echo "== glxinfo -B, GLX vendor $vendor"
      __GLX_VENDOR_LIBRARY_NAME=$vendor timeout 20 "$x/bin/glxinfo" -B >"$OUT/glxinfo-$vendor.txt" 2>&1 || true
      grep -E "OpenGL (renderer|version)|Device|rror" "$OUT/glxinfo-$vendor.txt" | head -4 || true
      if [ "$vendor" = nvidia ] && grep -q "OpenGL renderer.*NVIDIA" "$OUT/glxinfo-$vendor.txt"; then
        GLX_VENDOR=nvidia
        break
      fi
    done
  fi
  echo "== GLX vendor for tsf view: $GLX_VENDOR"
}

# A figure from a JSON file (python3: the GPU machine's image has it).
json_get() {
  python3 -c "import json,sys; d=json.load(open(sys.argv[1]))
for k in sys.argv[2].split('.'): d=d[int(k)] if isinstance(d,list) else d.get(k, {})
print(d)" "$1" "$2" 2>/dev/null || echo "?"
}

run_product() {
  OUT="${OUT:-$ROOT/out/product-run}"
  mkdir -p "$OUT" "$PREFIX"
  local steps="${TSF_PRODUCT_STEPS:-x11 run view}"
  local work=/tmp/tsf-product-work
  rm -rf "$work" && mkdir -p "$work"
  # Each part once: a warm machine keeps what an earlier call unpacked.
  local part marker
  for part in tsf-lib:tsf/lib tsf-bin:tsf/libexec x11:x11/bin mesa:x11/lib/dri \
    z3:x11/lib/libz3.so.4; do
    marker="$PREFIX/${part#*:}"
    if [ -f "$DIR/${part%%:*}.tar.xz" ] && [ ! -e "$marker" ]; then
      xz -dc "$DIR/${part%%:*}.tar.xz" | tar -C "$PREFIX" -xf -
    fi
  done
  if [ "$steps" = "unpack" ]; then
    echo "gpu-product: unpacked into $PREFIX: $(ls "$PREFIX" "$PREFIX"/tsf 2>/dev/null | tr '\n' ' ')"
    return 0
  fi
  local summary="$OUT/product-summary.txt"
  : >"$summary"
  (nvidia-smi --query-gpu=name,driver_version --format=csv,noheader || true) >>"$summary" 2>&1
  if [[ " $steps " == *" x11 "* || " $steps " == *" view "* ]]; then start_x >>"$summary" 2>&1 || true; fi
  export __GLX_VENDOR_LIBRARY_NAME="${TSF_PRODUCT_GLX_VENDOR:-${GLX_VENDOR:-nvidia}}"
  local tsf=$PREFIX/tsf/bin/tsf
  # tsf runs in a scratch folder with the scenes, materials and presets installed with it (a
  # checkout's newer files may hold keys this tsf does not know); the sample data comes from the
  # checkout, where the bundle's scenes look for it (share/tsf/data-samples).
  local share=$PREFIX/tsf/share/tsf
  [ -d "$share/scenes" ] && ln -sfn "$ROOT/data-samples" "$share/data-samples"
  if [[ " $steps " == *" run "* ]]; then
    # The sinus scene as shipped (a node every 2 mm) and at a node every 1 mm (~100 k nodes).
    sed 's/node_spacing_mm: 2 .*/node_spacing_mm: 1/' "$share/scenes/sinus.yaml" \
      >"$share/scenes/sinus-1mm.yaml"
    for scene in sinus sinus-1mm; do
      local t0
      t0=$(date +%s)
      (cd "$work" && timeout 400 "$tsf" run "$share/scenes/$scene.yaml" --backend "$BACKEND" \
         -o "$work/$scene") \
        >"$OUT/run-$scene.log" 2>&1 || echo "tsf run scenes/$scene.yaml exited $?" >>"$summary"
      local r="$work/$scene/run-report.json"
      cp "$r" "$OUT/run-report-$scene.json" 2>/dev/null || true
      {
        echo "== tsf run scenes/$scene.yaml --backend $BACKEND: $(( $(date +%s) - t0 )) s wall"
        echo "   verdict $(json_get "$r" verdict); backend $(json_get "$r" backend)"
        echo "   steps $(json_get "$r" rates.steps), dt $(json_get "$r" rates.dt_s) s," \
             "steps/s $(json_get "$r" rates.steps_per_s), node-steps/s $(json_get "$r" rates.node_steps_per_s)"
        echo "   real-time factor of the script $(json_get "$r" rates.real_time_factor)"
        grep -E "edit → render buffer" "$OUT/run-$scene.log" | tail -1 || true
      } >>"$summary"
    done
    rm -f "$share/scenes/sinus-1mm.yaml"
  fi
  if [[ " $steps " == *" view "* ]]; then
    # scenes/cut-cranium.yaml reads ../out/cranium-*: tsf segment's output beside the scenes.
    (cd "$work" && "$tsf" segment "$ROOT/data-samples/ct-head-cranium/cranium.nrrd" \
       --preset sinus -o "$share/out/cranium") >"$OUT/segment.log" 2>&1 ||
      echo "tsf segment exited $?" >>"$summary"
    local t0
    t0=$(date +%s)
    (cd "$work" && timeout 300 "$tsf" view "$share/scenes/cut-cranium.yaml" --offscreen \
       --backend "$BACKEND" --script "$share/scenes/view-cranium.yaml" --out "$work/view") \
      >"$OUT/view.log" 2>&1 || echo "tsf view --offscreen exited $?" >>"$summary"
    local r="$work/view/view-report.json"
    {
      echo "== tsf view scenes/cut-cranium.yaml --offscreen --backend $BACKEND" \
           "--script scenes/view-cranium.yaml: $(( $(date +%s) - t0 )) s wall"
      tail -2 "$OUT/view.log"
      python3 -c "import json,sys; d=json.load(open(sys.argv[1])); r=d['mean_render_s']; s=d['mean_simulate_s']; f=d['frame_time_s']
print('   %d frames, %.1f ms render + %.1f ms simulation per frame: %.1f frames/s; simulation %.3gx real time' % (d['frames'], r*1e3, s*1e3, 1/(r+s), f/s if s>0 else 0))" "$r" 2>/dev/null
    } >>"$summary"
    cp "$r" "$OUT/view-report.json" 2>/dev/null || true
    for f in 0016 0060; do cp "$work/view/frame-$f.png" "$OUT/frame-$f.png" 2>/dev/null || true; done
    # The live window (not offscreen) for 300 frames: its real-time factor and frame rate, as it
    # opens (the haptic loop at 1 kHz on the lattice model) and in variants that tell what the
    # simulation thread waits for (TSF_PRODUCT_WINDOW: "default", "haptics-off": no haptic
    # loop, "cpu": the CPU backend on the host's threads, the render still on the GPU).
    local variant
    for variant in ${TSF_PRODUCT_WINDOW:-default haptics-off}; do
      local extra=() backend=$BACKEND
      case "$variant" in
        haptics-off) extra=(--haptics off) ;;
        cpu) backend=cpu ;;
      esac
      (cd "$work" && timeout 120 "$tsf" view "$share/scenes/cut-cranium.yaml" --backend "$backend" \
         --frames 300 "${extra[@]}" --report "$OUT/window-$variant.json" --out "$work/window-$variant") \
        >"$OUT/window-$variant.log" 2>&1 || echo "tsf view (window, $variant) exited $?" >>"$summary"
      { echo "== tsf view scenes/cut-cranium.yaml --backend $backend --frames 300 ${extra[*]} (window on Xvfb)";
        grep -E "closed after|haptics .* at" "$OUT/window-$variant.log"; } >>"$summary"
    done
  fi
  [ -n "${XVFB_PID:-}" ] && kill "$XVFB_PID" 2>/dev/null || true
  # The summary and the frames as files, the logs and reports in one archive (a device call
  # brings few files back).
  (cd "$OUT" && find . -maxdepth 1 -type f ! -name product-summary.txt ! -name 'frame-*.png' \
     ! -name product-logs.tgz -printf '%f\n' | tar -czf product-logs.tgz -T - --remove-files) || true
  cat "$summary"
}

case "$MODE" in
  bundle) bundle ;;
  run) run_product ;;
  -h | --help | help) usage 0 ;;
  *) usage 2 ;;
esac
