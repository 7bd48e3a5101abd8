// A scripted tool trajectory: keyframed poses with a mode, sampled at display rate.
//
// Keyframe i holds a time (s), a pose in the deformed world and the mode the tool runs in from
// that keyframe to the next. Between keyframes the position is interpolated linearly and the
// orientation by slerp; after the last keyframe the tool stays at the last pose in its mode.
// Before the first keyframe the tool is idle.
#pragma once

#include <vector>

#include "tsf/interaction/tool.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::interaction {

struct Keyframe {
  double time_s = 0;
  ToolPose pose;
  ToolMode mode = ToolMode::kPress;
};

struct TrajectorySample {
  ToolPose pose;
  ToolMode mode = ToolMode::kIdle;
  bool started = false;  ///< false before the first keyframe
};

class Trajectory {
 public:
  Trajectory() = default;
  /// Keyframes with strictly increasing, finite times and finite poses; throws tsf::Error
  /// naming the keyframe index otherwise.
  explicit Trajectory(std::vector<Keyframe> keyframes);

  const std::vector<Keyframe>& keyframes() const { return keyframes_; }
  bool empty() const { return keyframes_.empty(); }
  double start_time() const { return keyframes_.empty() ? 0.0 : keyframes_.front().time_s; }
  double end_time() const { return keyframes_.empty() ? 0.0 : keyframes_.back().time_s; }

  TrajectorySample sample(double time_s) const;

 private:
  std::vector<Keyframe> keyframes_;
};

}  // namespace tsf::interaction
