// Shared set-ups for the haptics tests: analytic tissue volumes and straight stylus passes
// evaluated frame by frame as the playback does.
#pragma once

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "tsf/haptics/force_models.h"
#include "tsf/haptics/frame_capture.h"
#include "tsf/haptics/haptic_playback.h"
#include "tsf/haptics/haptic_trajectory.h"
#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::haptics::test {

/// What tsf does for a live loop (app/scene/haptic_devices.h), for the loop tests: the haptic
/// thread asks for SCHED_FIFO (unless TSF_TEST_NO_REALTIME is set), the simulation and renderer
/// threads step down to nice +5.
inline std::string request_realtime() {
  if (std::getenv("TSF_TEST_NO_REALTIME") == nullptr) {
    sched_param p{};
    p.sched_priority = 10;
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0) return "SCHED_FIFO";
  }
  return "normal scheduling";
}
inline void lower_priority() {
  (void)setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), 5);
}

/// A sphere of `radius` mm centred in a cube of `extent` mm of `voxel` mm voxels; the density
/// ramps over ±ramp mm (0: binary voxels).
inline VoxelVolume sphere_volume_of(double radius, double extent, double voxel, double ramp) {
  const int n = static_cast<int>(std::lround(extent / voxel));
  const Vec3d c{0.5 * (n - 1) * voxel, 0.5 * (n - 1) * voxel, 0.5 * (n - 1) * voxel};
  return make_sdf_volume(
      cube_geometry({n, n, n}, voxel),
      [c, radius](const Vec3d& p) { return length(p - c) - radius; }, ramp);
}

inline Vec3d volume_centre(const VoxelVolume& v) {
  const Int3 d = v.dims();
  return v.geometry().index_to_tissue({0.5 * (d.x - 1), 0.5 * (d.y - 1), 0.5 * (d.z - 1)});
}

/// Evaluates `model` at each point of a straight pass (a fresh static frame at every point).
inline std::vector<HapticForce> forces_along(const ForceModel& model, const VoxelVolume& volume,
                                             const imt::SurfaceMesh* mesh, double reach,
                                             const std::vector<Vec3d>& points) {
  StaticFrameSource source(volume, mesh, {reach, 1.0});
  HapticFrame frame;
  std::vector<HapticForce> out;
  for (const Vec3d& p : points) {
    StylusPose pose;
    pose.position = p;
    source.step(0.0, pose, false, frame);
    out.push_back(model.evaluate(frame.view(), pose));
  }
  return out;
}

inline std::vector<Vec3d> line_points(const Vec3d& from, const Vec3d& to, int count) {
  std::vector<Vec3d> p;
  for (int i = 0; i < count; ++i) p.push_back(from + (to - from) * (double(i) / (count - 1)));
  return p;
}

}  // namespace tsf::haptics::test
