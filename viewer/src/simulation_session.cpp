#include "tsf/viewer/simulation_session.h"

#include <chrono>

#include "tsf/common/error.h"

namespace tsf::viewer {
namespace {

double wall_seconds() {
  using clock = std::chrono::steady_clock;
  static const clock::time_point start = clock::now();
  return std::chrono::duration<double>(clock::now() - start).count();
}

}  // namespace

SimulationSession::SimulationSession(std::unique_ptr<interaction::TissueModel> model,
                                     std::vector<NamedTool> tools)
    : model_(std::move(model)), tools_(std::move(tools)) {
  require(model_ != nullptr, "viewer: no tissue model");
  require(!tools_.empty(), "viewer: the scene has no tools (add a `tools` section)");
  for (const NamedTool& t : tools_) t.tool.validate();
  const crms::Solver& solver = model_->solver();
  stats_.backend = solver.backend_name();
  stats_.lattice_dims = solver.lattice().geometry().dims;
  stats_.alive_nodes = model_->alive_nodes();
  stats_.dt_s = model_->dt();
  stats_.live_triangles = model_->surface().live_triangle_count();
  stats_.stability = crms::to_string(model_->stability().verdict);
  stats_.dt_over_estimate = model_->time_step_choice().ratio();
}

void SimulationSession::publish_initial() {
  exchange_.publish(*model_, true, stats_);
  edited_since_publish_ = false;
}

void SimulationSession::step(double dt_display, const ToolCommand& command) {
  if (!stats_.error.empty()) return;
  const double now = wall_seconds();
  if (wall_start_ < 0) wall_start_ = now;
  try {
    if (command.tool < 0 || command.tool >= static_cast<int>(tools_.size()))
      throw Error("viewer: tool index " + std::to_string(command.tool) +
                  " out of range (the "
                  "scene has " +
                  std::to_string(tools_.size()) + " tools)");
    if (command.mode == interaction::ToolMode::kIdle) {
      if (holding_) model_->release_tool();
      holding_ = false;
    } else {
      const interaction::EditReport r = model_->apply_tool(
          tools_[static_cast<std::size_t>(command.tool)].tool, command.pose, command.mode);
      holding_ = true;
      if (r.edited) edited_since_publish_ = true;
      for (const interaction::ExposureEvent& e : r.exposures)
        stats_.warning = interaction::describe_exposure(
            e.hit, tools_[static_cast<std::size_t>(command.tool)].name, e.time_s);
    }
    const interaction::AdvanceReport a = model_->advance(dt_display);
    if (a.tear.layers.edited) edited_since_publish_ = true;  // a tear re-meshed the surface
    if (a.instability) stats_.error = "unstable: " + a.instability->describe();
  } catch (const std::exception& e) {
    stats_.error = e.what();
  }
  const interaction::InteractionTotals& tot = model_->totals();
  ++stats_.frames;
  stats_.simulated_s = tot.simulated_s;
  stats_.alive_nodes = model_->alive_nodes();
  stats_.tool_force_un = model_->contact().force_un;
  stats_.removed_mm3 = tot.removed_mm3;
  stats_.live_triangles = model_->surface().live_triangle_count();
  stats_.stability = crms::to_string(model_->stability().verdict);
  stats_.dt_over_estimate = model_->time_step_choice().ratio();
  // Rates over the last ~1 s of wall time.
  const double wall = wall_seconds();
  recent_.push_back({wall, tot.steps, tot.simulated_s});
  while (recent_.size() > 2 && recent_.front().wall_s < wall - 1.0) recent_.pop_front();
  const Sample& first = recent_.front();
  if (recent_.size() >= 2 && wall > first.wall_s) {
    stats_.steps_per_s = static_cast<double>(tot.steps - first.steps) / (wall - first.wall_s);
    stats_.realtime = (tot.simulated_s - first.simulated_s) / (wall - first.wall_s);
  }
  exchange_.publish(*model_, edited_since_publish_, stats_);
  edited_since_publish_ = false;
  if (on_published_) on_published_(*model_);
}

SimulationThread::SimulationThread(SimulationSession& session, double frame_s)
    : session_(session), frame_s_(frame_s) {
  require(frame_s > 0, "viewer: simulation frame must be > 0 s");
  thread_ = std::thread([this] { run(); });
}

SimulationThread::~SimulationThread() {
  stop();
}

void SimulationThread::set_tool(const ToolCommand& command) {
  std::lock_guard<std::mutex> lock(mutex_);
  command_ = command;
}

void SimulationThread::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void SimulationThread::run() {
  const double start = wall_seconds();
  double simulated = 0;
  while (!stop_) {
    ToolCommand c;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      c = command_;
    }
    session_.step(frame_s_, c);
    simulated += frame_s_;
    if (!session_.stats().error.empty()) {
      // Stopped: keep the window alive, idle.
      while (!stop_) std::this_thread::sleep_for(std::chrono::milliseconds(20));
      break;
    }
    const double ahead = simulated - (wall_seconds() - start);
    if (ahead > 0)
      std::this_thread::sleep_for(std::chrono::duration<double>(ahead));
    else if (ahead < -0.25)
      simulated = wall_seconds() - start;  // behind: do not try to catch up
  }
}

}  // namespace tsf::viewer
