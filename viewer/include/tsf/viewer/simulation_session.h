// The simulation side of the viewer: a TissueModel, the scene's tools, and the loop that applies
// the tool the user (or a script) holds, advances one display frame and publishes the surface.
//
// SimulationSession::step() is the whole frame; the interactive window runs it on its own thread
// (SimulationThread, paced to real time where the solver is fast enough), the offscreen renderer
// calls it in line so frames are reproducible. The model runs on CUDA when the solver was built
// with it and a device is present, else on the CPU (crms::SolverConfig backend "auto").
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

/// What the hand holds: which tool, where (deformed world, mm) and in which mode.
struct ToolCommand {
  int tool = 0;  ///< index into the session's tools
  ToolPose pose;
  interaction::ToolMode mode = interaction::ToolMode::kIdle;
};

class SimulationSession {
 public:
  /// Throws tsf::Error when `tools` is empty or a tool is invalid.
  SimulationSession(std::unique_ptr<interaction::TissueModel> model, std::vector<NamedTool> tools);

  /// Applies `command` (an idle command lifts the tool), advances `dt_display` simulated seconds
  /// and publishes the surface and stats. A tool error (e.g. cut with a sphere) or an instability
  /// is reported in stats().error and the model stops advancing; never throws for those.
  void step(double dt_display, const ToolCommand& command);

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
  bool holding_ = false;
  bool edited_since_publish_ = true;
  // Recent (wall time, steps, simulated s) for the rates.
  struct Sample {
    double wall_s;
    std::int64_t steps;
    double simulated_s;
  };
  std::deque<Sample> recent_;
  double wall_start_ = -1;
};

/// Runs a session's step() on its own thread until stopped; the render thread sets the tool.
class SimulationThread {
 public:
  /// `frame_s`: simulated seconds per step; the loop sleeps so that simulated time does not run
  /// ahead of wall-clock time (it runs behind when the solver is slower than real time).
  SimulationThread(SimulationSession& session, double frame_s);
  ~SimulationThread();  ///< stops and joins
  SimulationThread(const SimulationThread&) = delete;
  SimulationThread& operator=(const SimulationThread&) = delete;

  void set_tool(const ToolCommand& command);
  void stop();

 private:
  void run();
  SimulationSession& session_;
  double frame_s_;
  std::mutex mutex_;
  ToolCommand command_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace tsf::viewer
