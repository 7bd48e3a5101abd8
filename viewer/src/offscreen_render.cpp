#include "tsf/viewer/offscreen_render.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/haptics/scripted_device.h"
#include "tsf/viewer/live_haptics.h"

namespace tsf::viewer {

OffscreenResult render_offscreen(SimulationSession& session, const SliceVolume* slices,
                                 const ViewScript& script, int frames,
                                 const std::filesystem::path& out_dir,
                                 const std::function<void(int)>& on_frame) {
  require(frames >= 1, "tsf view: --frames must be ≥ 1, got " + std::to_string(frames));
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec || !std::filesystem::is_directory(out_dir))
    throw Error(out_dir.string() + ": cannot create the output folder" +
                (ec ? ": " + ec.message() : std::string()));
  ViewOptions options = script.options;
  options.offscreen = true;
  Viewer viewer(session, slices, options);
  OffscreenResult r;
  double simulate_s = 0, render_s = 0;
  using Clock = std::chrono::steady_clock;
  LiveHaptics* haptics = session.haptics();
  auto* scripted =
      haptics != nullptr ? dynamic_cast<haptics::ScriptedDevice*>(&haptics->device()) : nullptr;
  for (int f = 0; f < frames; ++f) {
    const std::vector<ToolCommand> hands = script.commands_at(f);  // empty hands: tool −1
    const Clock::time_point t0 = Clock::now();
    session.step_hands(options.frame_s, hands);
    // Offscreen the haptic loop takes one tick per frame, on this thread: reproducible frames.
    if (haptics != nullptr) {
      if (scripted != nullptr) scripted->set_time(f);
      haptics->tick_now();
    }
    const Clock::time_point t1 = Clock::now();
    viewer.render_hands(hands);
    const Clock::time_point t2 = Clock::now();
    simulate_s += std::chrono::duration<double>(t1 - t0).count();
    render_s += std::chrono::duration<double>(t2 - t1).count();
    char name[32];
    std::snprintf(name, sizeof name, "frame-%04d.png", f);
    viewer.write_png(out_dir / name);
    r.frames = f + 1;
    r.max_force_un = std::max(r.max_force_un, viewer.shown_force_un());
    if (on_frame) on_frame(f);
    if (!session.stats().error.empty()) break;
  }
  r.mean_render_s = render_s / r.frames;
  r.mean_simulate_s = simulate_s / r.frames;
  r.last = session.stats();
  if (!r.last.error.empty())
    throw Error("tsf view: the simulation stopped at frame " + std::to_string(r.frames - 1) + ": " +
                r.last.error);
  return r;
}

}  // namespace tsf::viewer
