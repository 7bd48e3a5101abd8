#include "tsf/interaction/trajectory.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "tsf/common/error.h"

namespace tsf::interaction {

Trajectory::Trajectory(std::vector<Keyframe> keyframes) : keyframes_(std::move(keyframes)) {
  for (std::size_t i = 0; i < keyframes_.size(); ++i) {
    const Keyframe& k = keyframes_[i];
    const std::string at = "trajectory keyframe " + std::to_string(i);
    require(std::isfinite(k.time_s), at + ": time must be finite");
    require(all_finite(k.pose.position), at + ": position must be finite");
    const Rotation& r = k.pose.orientation;
    const double norm = std::sqrt(r.w * r.w + r.x * r.x + r.y * r.y + r.z * r.z);
    require(std::isfinite(norm) && norm > 1e-9, at + ": orientation must be a non-zero quaternion");
    keyframes_[i].pose.orientation = r.normalized();
    if (i > 0)
      require(k.time_s > keyframes_[i - 1].time_s,
              at + ": times must increase (got " + std::to_string(k.time_s) + " after " +
                  std::to_string(keyframes_[i - 1].time_s) + " s)");
  }
}

TrajectorySample Trajectory::sample(double t) const {
  TrajectorySample s;
  if (keyframes_.empty() || t < keyframes_.front().time_s) {
    if (!keyframes_.empty()) s.pose = keyframes_.front().pose;
    return s;
  }
  s.started = true;
  const auto it = std::upper_bound(keyframes_.begin(), keyframes_.end(), t,
                                   [](double v, const Keyframe& k) { return v < k.time_s; });
  const Keyframe& a = *(it - 1);
  s.mode = a.mode;
  if (it == keyframes_.end()) {
    s.pose = a.pose;
    return s;
  }
  const Keyframe& b = *it;
  const double f = (t - a.time_s) / (b.time_s - a.time_s);
  s.pose.position = a.pose.position + (b.pose.position - a.pose.position) * f;
  s.pose.orientation = Rotation::slerp(a.pose.orientation, b.pose.orientation, f);
  return s;
}

}  // namespace tsf::interaction
