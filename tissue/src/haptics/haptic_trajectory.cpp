#include "tsf/haptics/haptic_trajectory.h"

#include <cmath>
#include <string>

#include "tsf/common/error.h"

namespace tsf::haptics {
namespace {

void check_speed(double speed_mm_s) {
  require(std::isfinite(speed_mm_s) && speed_mm_s > 0,
          "trajectory speed: expected a finite number > 0 mm/s, got " + std::to_string(speed_mm_s));
}

/// Appends a keyframe reached from the last one at `speed` (a zero-length leg takes 1 ms).
void leg_to(std::vector<interaction::Keyframe>& k, const Vec3d& p, double speed,
            interaction::ToolMode mode) {
  const double t =
      k.empty() ? 0.0
                : k.back().time_s + std::max(1e-3, length(p - k.back().pose.position) / speed);
  interaction::Keyframe f;
  f.time_s = t;
  f.pose.position = p;
  f.mode = mode;
  k.push_back(f);
}

Vec3d unit_normal(const Vec3d& n) {
  const Vec3d u = normalized_or_zero(n);
  require(length(u) > 0.5, "trajectory normal: expected a non-zero vector");
  return u;
}

}  // namespace

interaction::Trajectory straight_pass(const Vec3d& from, const Vec3d& to, double speed_mm_s,
                                      interaction::ToolMode mode) {
  check_speed(speed_mm_s);
  require(length(to - from) > 0, "straight pass: 'from' and 'to' are the same point");
  std::vector<interaction::Keyframe> k;
  leg_to(k, from, speed_mm_s, mode);
  leg_to(k, to, speed_mm_s, mode);
  return interaction::Trajectory(std::move(k));
}

interaction::Trajectory press_and_hold(const Vec3d& surface_point, const Vec3d& outward_normal,
                                       double stylus_radius_mm, double depth_mm, double approach_mm,
                                       double speed_mm_s, double hold_s,
                                       interaction::ToolMode mode) {
  check_speed(speed_mm_s);
  require(stylus_radius_mm >= 0 && depth_mm > 0 && approach_mm >= 0 && hold_s >= 0,
          "press and hold: expected radius ≥ 0, depth > 0, approach ≥ 0 mm and hold ≥ 0 s");
  const Vec3d n = unit_normal(outward_normal);
  std::vector<interaction::Keyframe> k;
  const Vec3d outside = surface_point + n * (stylus_radius_mm + approach_mm);
  const Vec3d inside = surface_point + n * (stylus_radius_mm - depth_mm);
  leg_to(k, outside, speed_mm_s, mode);
  leg_to(k, inside, speed_mm_s, mode);
  if (hold_s > 0) {
    interaction::Keyframe hold = k.back();
    hold.time_s += hold_s;
    k.push_back(hold);
  }
  leg_to(k, outside, speed_mm_s, mode);
  return interaction::Trajectory(std::move(k));
}

interaction::Trajectory surface_sweep(const Vec3d& start, const Vec3d& end,
                                      const Vec3d& outward_normal, double stylus_radius_mm,
                                      double depth_mm, double approach_mm, double speed_mm_s,
                                      interaction::ToolMode mode) {
  check_speed(speed_mm_s);
  require(stylus_radius_mm >= 0 && depth_mm > 0 && approach_mm >= 0,
          "surface sweep: expected radius ≥ 0, depth > 0 and approach ≥ 0 mm");
  require(length(end - start) > 0, "surface sweep: 'start' and 'end' are the same point");
  const Vec3d n = unit_normal(outward_normal);
  const double out = stylus_radius_mm + approach_mm, in = stylus_radius_mm - depth_mm;
  std::vector<interaction::Keyframe> k;
  leg_to(k, start + n * out, speed_mm_s, mode);
  leg_to(k, start + n * in, speed_mm_s, mode);
  leg_to(k, end + n * in, speed_mm_s, mode);
  leg_to(k, end + n * out, speed_mm_s, mode);
  return interaction::Trajectory(std::move(k));
}

}  // namespace tsf::haptics
