// Offscreen frames: `tsf view SCENE --offscreen --script FILE --frames N --out DIR`. Simulates
// and renders N frames on the calling thread (reproducible: the same script gives the same
// frames), writing DIR/frame-0000.png, DIR/frame-0001.png, … Every hand of the script acts; with
// live haptics attached to the session, each frame takes one haptic tick after its step (a
// scripted device is set to the frame's time first).
#pragma once

#include <filesystem>
#include <functional>

#include "tsf/viewer/view_script.h"
#include "tsf/viewer/viewer.h"

namespace tsf::viewer {

struct OffscreenResult {
  int frames = 0;
  double mean_render_s = 0;    ///< upload + draw per frame
  double mean_simulate_s = 0;  ///< one simulated frame
  SimulationStats last;        ///< stats after the last frame
  double max_force_un = 0;     ///< largest |force| shown (haptic force with live haptics)
};

/// Renders `frames` frames into `out_dir` (created when missing). `on_frame(i)` runs after each
/// frame is written (progress). Throws tsf::Error when the folder cannot be written or the
/// simulation stopped (after writing the frames so far).
OffscreenResult render_offscreen(SimulationSession& session, const SliceVolume* slices,
                                 const ViewScript& script, int frames,
                                 const std::filesystem::path& out_dir,
                                 const std::function<void(int)>& on_frame = {});

}  // namespace tsf::viewer
