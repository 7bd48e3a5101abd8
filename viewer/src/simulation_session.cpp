#include "tsf/viewer/simulation_session.h"

#include <chrono>

#include "tsf/common/error.h"
#include "tsf/viewer/live_haptics.h"

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
  require(tools_.size() <= static_cast<std::size_t>(interaction::TissueModel::kMaxToolSlots),
          "viewer: at most " + std::to_string(interaction::TissueModel::kMaxToolSlots) +
              " tools act at once; the scene has " + std::to_string(tools_.size()));
  holding_.assign(tools_.size(), false);
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

void SimulationSession::step_hands(double dt_display, const std::vector<ToolCommand>& hands) {
  if (!stats_.error.empty()) return;
  const double now = wall_seconds();
  if (wall_start_ < 0) wall_start_ = now;
  try {
    std::vector<const ToolCommand*> by_tool(tools_.size(), nullptr);
    for (const ToolCommand& c : hands) {
      if (c.tool == -1) continue;
      if (c.tool < 0 || c.tool >= static_cast<int>(tools_.size()))
        throw Error("viewer: tool index " + std::to_string(c.tool) +
                    " out of range (the scene has " + std::to_string(tools_.size()) + " tools)");
      if (c.mode != interaction::ToolMode::kIdle) by_tool[static_cast<std::size_t>(c.tool)] = &c;
    }
    for (std::size_t t = 0; t < tools_.size(); ++t) {
      const int slot = static_cast<int>(t);
      if (by_tool[t] == nullptr) {
        if (holding_[t]) model_->release_tool(slot);
        holding_[t] = false;
        continue;
      }
      const interaction::EditReport r =
          model_->apply_tool(slot, tools_[t].tool, by_tool[t]->pose, by_tool[t]->mode);
      holding_[t] = true;
      if (r.edited) edited_since_publish_ = true;
      for (const interaction::ExposureEvent& e : r.exposures)
        stats_.warning = interaction::describe_exposure(e.hit, tools_[t].name, e.time_s);
    }
    const interaction::AdvanceReport a = model_->advance(dt_display);
    if (a.tear.layers.edited) edited_since_publish_ = true;  // a tear re-meshed the surface
    if (a.instability) stats_.error = "unstable: " + a.instability->describe();
    if (haptics_ != nullptr && !hands.empty()) {
      const ToolCommand& h = hands.front();
      haptics_->publish(*model_, h.pose, h.tool < 0 ? 0 : h.tool);
    }
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

SimulationThread::SimulationThread(SimulationSession& session, double frame_s,
                                   std::function<void()> on_start)
    : session_(session), frame_s_(frame_s), on_start_(std::move(on_start)) {
  require(frame_s > 0, "viewer: simulation frame must be > 0 s");
  thread_ = std::thread([this] { run(); });
}

SimulationThread::~SimulationThread() {
  stop();
}

void SimulationThread::set_hands(const std::vector<ToolCommand>& hands) {
  std::lock_guard<std::mutex> lock(mutex_);
  hands_ = hands;
}

std::vector<ToolCommand> SimulationThread::applied_hands() {
  std::lock_guard<std::mutex> lock(mutex_);
  return applied_;
}

void SimulationThread::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void SimulationThread::run() {
  if (on_start_) on_start_();
  const double start = wall_seconds();
  double simulated = 0;
  while (!stop_) {
    std::vector<ToolCommand> hands;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      hands = hands_;
    }
    // The device holds the first hand: its pose (and button) as of the loop's latest tick.
    if (LiveHaptics* h = session_.haptics(); h != nullptr && !hands.empty() && h->ticks() > 0) {
      const haptics::DeviceState d = h->device_state();
      hands.front().pose = d.pose;
      if (!d.pressing) hands.front().mode = interaction::ToolMode::kIdle;
    }
    session_.step_hands(frame_s_, hands);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      applied_ = hands;
    }
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
