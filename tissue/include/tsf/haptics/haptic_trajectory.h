// Scripted stylus paths for measuring haptic rendering (thesis §8.6): keyframes at constant
// speed, sampled by interaction::Trajectory. Positions in the deformed world, mm; speeds mm/s.
//
//   straight pass    from → to at constant speed (through a sphere or a chamfered cube)
//   press and hold   the stylus (radius r) from `approach` mm clear of the surface point along
//                    its outward normal until its surface is `depth` mm inside, hold `hold_s`,
//                    back out: the centre travels from p + n·(r + approach) to p + n·(r − depth)
//   surface sweep    the same approach at `start`, a slide to `end` at that depth (a path parallel
//                    to a flat surface), back out
#pragma once

#include "tsf/interaction/trajectory.h"

namespace tsf::haptics {

interaction::Trajectory straight_pass(const Vec3d& from, const Vec3d& to, double speed_mm_s,
                                      interaction::ToolMode mode = interaction::ToolMode::kIdle);

interaction::Trajectory press_and_hold(const Vec3d& surface_point, const Vec3d& outward_normal,
                                       double stylus_radius_mm, double depth_mm, double approach_mm,
                                       double speed_mm_s, double hold_s,
                                       interaction::ToolMode mode = interaction::ToolMode::kPress);

interaction::Trajectory surface_sweep(const Vec3d& start, const Vec3d& end,
                                      const Vec3d& outward_normal, double stylus_radius_mm,
                                      double depth_mm, double approach_mm, double speed_mm_s,
                                      interaction::ToolMode mode = interaction::ToolMode::kPress);

}  // namespace tsf::haptics
