// Playback of a scripted trajectory in simulated time (thesis §8.6's method, reproducible): the
// haptic ticks and the simulation steps interleave exactly as a live session schedules them (a
// simulation step every 1/sim_rate s, a tick every 1/haptic_rate s, each tick using the newest
// frame), but on one thread and without wall-clock noise, so two runs give the same samples.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "tsf/haptics/force_models.h"
#include "tsf/haptics/frame_capture.h"
#include "tsf/haptics/haptic_sample.h"
#include "tsf/interaction/trajectory.h"

namespace tsf::haptics {

struct PlaybackOptions {
  double haptic_rate_hz = 1000.0;
  double sim_rate_hz = 200.0;  ///< frame captures (and simulation steps) per second
  int filter_window = 1;
  double max_force_un = 0;  ///< device clamp; 0 = none

  void validate() const;
};

/// The most haptic ticks one playback records (an hour at 1 kHz, ~370 MB of samples).
constexpr std::int64_t kMaxPlaybackTicks = 3'600'000;

/// The number of haptic ticks that play `trajectory` at `options.haptic_rate_hz`, checked in
/// [1, kMaxPlaybackTicks] before anything is sized from it (an Error naming the duration and
/// rate otherwise: a very slow path speed makes a trajectory last for ages).
std::int64_t playback_ticks(const interaction::Trajectory& trajectory,
                            const PlaybackOptions& options);

/// Plays `trajectory` from its first keyframe to its last: press-mode keyframes press the tissue,
/// others only probe it. `progress(fraction)` is called now and then when given.
std::vector<HapticSample> play_trajectory(const interaction::Trajectory& trajectory,
                                          FrameSource& source, const ForceModel& model,
                                          const PlaybackOptions& options,
                                          const std::function<void(double)>& progress = {});

}  // namespace tsf::haptics
