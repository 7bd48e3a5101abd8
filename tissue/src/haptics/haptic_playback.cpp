#include "tsf/haptics/haptic_playback.h"

#include <chrono>
#include <cmath>
#include <sstream>
#include <string>

#include "tsf/common/error.h"
#include "tsf/haptics/moving_average.h"

namespace tsf::haptics {

void PlaybackOptions::validate() const {
  require(std::isfinite(haptic_rate_hz) && haptic_rate_hz > 0 && haptic_rate_hz <= 20000,
          "haptic rate: expected (0, 20000] Hz, got " + std::to_string(haptic_rate_hz));
  require(std::isfinite(sim_rate_hz) && sim_rate_hz > 0 && sim_rate_hz <= haptic_rate_hz,
          "simulation rate: expected (0, haptic rate] Hz, got " + std::to_string(sim_rate_hz));
  require(filter_window >= 1 && filter_window <= 1000,
          "filter window: expected 1..1000 samples, got " + std::to_string(filter_window));
  require(std::isfinite(max_force_un) && max_force_un >= 0,
          "max force: expected a finite number ≥ 0 µN, got " + std::to_string(max_force_un));
}

std::int64_t playback_ticks(const interaction::Trajectory& trajectory,
                            const PlaybackOptions& options) {
  options.validate();
  require(!trajectory.empty(), "haptic playback: the trajectory has no keyframes");
  const double duration = trajectory.end_time() - trajectory.start_time();
  const double ticks = std::floor(duration / (1.0 / options.haptic_rate_hz) + 1e-9) + 1;
  if (!(ticks >= 1 && ticks <= static_cast<double>(kMaxPlaybackTicks))) {
    std::ostringstream s;
    s << "haptic playback: the trajectory lasts " << duration << " s, " << ticks << " ticks at "
      << options.haptic_rate_hz << " Hz; expected at most " << kMaxPlaybackTicks << " ticks";
    throw Error(s.str());
  }
  return static_cast<std::int64_t>(ticks);
}

std::vector<HapticSample> play_trajectory(const interaction::Trajectory& trajectory,
                                          FrameSource& source, const ForceModel& model,
                                          const PlaybackOptions& options,
                                          const std::function<void(double)>& progress) {
  const std::int64_t ticks = playback_ticks(trajectory, options);
  const double tick = 1.0 / options.haptic_rate_hz, sim_dt = 1.0 / options.sim_rate_hz;
  const double t0 = trajectory.start_time();
  std::vector<HapticSample> out;
  out.reserve(static_cast<std::size_t>(ticks));
  MovingAverageFilter filter(options.filter_window);
  HapticFrame frame;
  double next_sim = t0;
  bool have_frame = false;
  for (std::int64_t k = 0; k < ticks; ++k) {
    const double t = t0 + static_cast<double>(k) * tick;
    const interaction::TrajectorySample pose = trajectory.sample(t);
    const bool press = pose.started && pose.mode == interaction::ToolMode::kPress;
    // The simulation steps when its next frame is due (a live session: the pump's cadence).
    if (t + 1e-12 >= next_sim) {
      source.step(have_frame ? sim_dt : 0.0, pose.pose, press, frame);
      frame.time_s = t;  // the frame shows the state at this tick's time
      have_frame = true;
      next_sim += sim_dt;
    }
    const auto c0 = std::chrono::steady_clock::now();
    const HapticForce raw = model.evaluate(frame.view(), pose.pose);
    Vec3d f = filter.filter(pose.started ? raw.force_un : Vec3d{0, 0, 0});
    const double fm = length(f);
    if (options.max_force_un > 0 && fm > options.max_force_un) f = f * (options.max_force_un / fm);
    const auto c1 = std::chrono::steady_clock::now();
    HapticSample s;
    s.time_s = t;
    s.position_mm = pose.pose.position;
    s.raw_force_un = raw.force_un;
    s.force_un = f;
    s.intersection_mm3 = raw.intersection_mm3;
    s.contacts = raw.contacts;
    s.frame_age_s = t - frame.time_s;
    s.compute_us = static_cast<float>(std::chrono::duration<double, std::micro>(c1 - c0).count());
    out.push_back(s);
    if (progress && (k % 256 == 0 || k + 1 == ticks))
      progress(static_cast<double>(k + 1) / static_cast<double>(ticks));
  }
  return out;
}

}  // namespace tsf::haptics
