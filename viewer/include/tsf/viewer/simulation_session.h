// The simulation side of the viewer: a TissueModel, the scene's tools, and the loop that applies
// the tool the user (or a script) holds, advances one display frame and publishes the surface.
//
// SimulationSession::step() is the whole frame; the interactive window runs it on its own thread
// (SimulationThread, paced to real time where the solver is fast enough), the offscreen renderer
// calls it in line so frames are reproducible. The model runs on CUDA when the solver was built
// with it and a device is present, else on the CPU (crms::SolverConfig backend "auto").
//
// Several hands act at once (two-handed work: an endoscope pushing the mucosa aside while a wand
// ablates): step() takes one ToolCommand per hand, and each tool acts in its own slot of the
// model (its index in the session's tools). With live haptics attached (live_haptics.h), the
// first hand's pose comes from the haptic device and a frame for the haptic loop is captured
// around it after every step.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "tsf/interaction/tissue_model.h"
#include "tsf/interaction/tool.h"
#include "tsf/viewer/surface_exchange.h"

namespace tsf::viewer {

struct NamedTool {
  std::string name;
  interaction::Tool tool;
};

/// What a hand holds: which tool, where (deformed world, mm) and in which mode.
struct ToolCommand {
  int tool = 0;  ///< index into the session's tools (−1: an empty hand)
  ToolPose pose;
  interaction::ToolMode mode = interaction::ToolMode::kIdle;
};

class LiveHaptics;

class SimulationSession {
 public:
  /// Throws tsf::Error when `tools` is empty or a tool is invalid.
  SimulationSession(std::unique_ptr<interaction::TissueModel> model, std::vector<NamedTool> tools);

  /// Applies the hands' commands (an idle command, or a tool no hand holds, lifts that tool),
  /// advances `dt_display` simulated seconds and publishes the surface and stats; with haptics
  /// attached, captures the haptic frame around the first hand's tool. A tool error (e.g. cut
  /// with a sphere) or an instability is reported in stats().error and the model stops
  /// advancing; never throws for those.
  void step_hands(double dt_display, const std::vector<ToolCommand>& hands);
  /// One hand.
  void step(double dt_display, const ToolCommand& command) {
    step_hands(dt_display, std::vector<ToolCommand>{command});
  }
  /// Live haptics for the first hand (null: none); it must outlive the session's stepping.
  void attach_haptics(LiveHaptics* haptics) { haptics_ = haptics; }
  LiveHaptics* haptics() const { return haptics_; }

  const std::vector<NamedTool>& tools() const { return tools_; }
  const interaction::TissueModel& model() const { return *model_; }
  interaction::TissueModel& model() { return *model_; }
  SurfaceExchange& exchange() { return exchange_; }
  /// Stats of the last step (simulation thread; others read them through exchange()).
  const SimulationStats& stats() const { return stats_; }
  /// Publishes the current surface without stepping (the first frame).
  void publish_initial();
  /// Called on the simulation thread after each step's surface is published (tsf view
  /// --igtl-port serves it over OpenIGTLink); null: nothing.
  void set_on_published(std::function<void(const interaction::TissueModel&)> f) {
    on_published_ = std::move(f);
  }

 private:
  std::function<void(const interaction::TissueModel&)> on_published_;
  std::unique_ptr<interaction::TissueModel> model_;
  std::vector<NamedTool> tools_;
  SurfaceExchange exchange_;
  SimulationStats stats_;
  std::vector<bool> holding_;  ///< per tool: its slot acts on the model
  bool edited_since_publish_ = true;
  LiveHaptics* haptics_ = nullptr;
  // Recent (wall time, steps, simulated s) for the rates.
  struct Sample {
    double wall_s;
    std::int64_t steps;
    double simulated_s;
  };
  std::deque<Sample> recent_;
  double wall_start_ = -1;
};

/// Runs a session's step() on its own thread until stopped; the render thread sets the hands.
/// With live haptics attached, the first hand's pose is the device's, read at every step.
class SimulationThread {
 public:
  /// `frame_s`: simulated seconds per step; the loop sleeps so that simulated time does not run
  /// ahead of wall-clock time (it runs behind when the solver is slower than real time).
  /// `on_start` runs first on the thread (the viewer lowers its priority below the haptic
  /// thread's there).
  SimulationThread(SimulationSession& session, double frame_s, std::function<void()> on_start = {});
  ~SimulationThread();  ///< stops and joins
  SimulationThread(const SimulationThread&) = delete;
  SimulationThread& operator=(const SimulationThread&) = delete;

  void set_tool(const ToolCommand& command) { set_hands({command}); }
  void set_hands(const std::vector<ToolCommand>& hands);
  void stop();
  /// The hands as the last step applied them (render thread: where to draw the tools).
  std::vector<ToolCommand> applied_hands();

 private:
  void run();
  SimulationSession& session_;
  double frame_s_;
  std::function<void()> on_start_;
  std::mutex mutex_;
  std::vector<ToolCommand> hands_, applied_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace tsf::viewer
