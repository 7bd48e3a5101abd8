// Shared by the viewer tests: an X display (the one in $DISPLAY, else an Xvfb this process
// starts and stops) and a small tissue block to look at.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "tsf/viewer/simulation_session.h"
#include "tsf/viewer/viewer.h"

namespace tsf::test {

/// Empty when an X display is usable (starting Xvfb when $DISPLAY is unset and Xvfb is
/// installed); else why not.
std::string x_display_unavailable_reason();

/// Skips the test with the reason when there is no X server and none can be started.
#define TSF_X_DISPLAY_OR_SKIP()                                          \
  do {                                                                   \
    const std::string why = ::tsf::test::x_display_unavailable_reason(); \
    if (!why.empty()) GTEST_SKIP() << "not run: " << why;                \
  } while (0)

/// A 40 × 16 × 12 mm block of soft tissue (1 mm voxels, nodes every 2 mm) clamped at x < 2 mm,
/// without gravity (so it rests until a tool acts), with a ball, a wand and a scalpel. CPU.
std::unique_ptr<viewer::SimulationSession> make_block_session();

/// Options for test frames: small, offscreen, no HUD/plot/slices/tool (only the tissue moves).
viewer::ViewOptions bare_offscreen_options();

}  // namespace tsf::test
