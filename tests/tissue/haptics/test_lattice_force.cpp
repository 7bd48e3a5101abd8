// The lattice model on a soft anchored beam (thesis §8.6.3, Fig. 70–72): a sphere stylus moved
// down onto the beam near its free end feels the summed reactions of the nodes it holds, which
// grow with depth and turn as the beam bends under it.
#include <gtest/gtest.h>

#include <cmath>

#include "tsf/crms/lattice_builders.h"
#include "tsf/haptics/force_models.h"
#include "tsf/haptics/frame_capture.h"
#include "tsf/haptics/haptic_playback.h"
#include "tsf/haptics/haptic_trajectory.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/volume/analytic_volumes.h"

namespace tsf::haptics {
namespace {

TEST(LatticeForce, GrowsWithDepthAndTurnsAsTheBeamBends) {
  // Beam 20 × 8 × 8 mm (x from 2 to 22) in 1 mm voxels, 2 mm nodes, clamped at x < 5, soft
  // (E = 20 kPa: first bending mode ~14 Hz). A 4 mm stylus comes down at 20 mm/s on the top
  // (z = 10) at x = 17, 4 mm deep; the simulation runs at 500 Hz, the haptic loop at 1 kHz.
  const Vec3d lo{2, 2, 2}, hi{22, 10, 10};
  const Vec3d centre = (lo + hi) * 0.5, half = (hi - lo) * 0.5;
  VoxelVolume beam = make_sdf_volume(
      cube_geometry({24, 12, 12}, 1.0),
      [&](const Vec3d& p) { return box_distance_local(half, p - centre); }, 0.5);
  interaction::TissueModelOptions o;
  o.lattice.node_spacing_voxels = 2;
  o.solver.materials[0].youngs_modulus_pa = 20e3;
  o.solver.materials[0].viscosity_pa_s = 2.0;
  o.solver.materials[0].density_g_per_mm3 = 1e-3;
  o.solver.gravity = {0, 0, 0};
  o.solver.backend = crms::Backend::kCpu;
  o.solver.stability.kinetic_damping = 0.05;
  o.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {5.0, 1e9, 1e9});
  };
  interaction::TissueModel model(std::move(beam), o);

  const double r = 4.0, depth = 4.0;
  TissueFrameSource source(model, {r, 2.0});
  ForceModelOptions fo;
  fo.stylus_radius_mm = r;
  const LatticeForceModel lattice(fo);
  PlaybackOptions p;
  p.sim_rate_hz = 500;
  const interaction::Trajectory down = straight_pass({17, 6, 10 + r + 0.5}, {17, 6, 10 + r - depth},
                                                     20.0, interaction::ToolMode::kPress);
  const std::vector<HapticSample> samples = play_trajectory(down, source, lattice, p);

  // The lattice force is rough (a few nodes, each with inertia: thesis §8.6.3); its mean over
  // each millimetre of depth is what must grow.
  Vec3d sum[4] = {};
  int count[4] = {};
  for (const HapticSample& s : samples) {
    ASSERT_TRUE(all_finite(s.force_un)) << "t = " << s.time_s;
    const double d = 10 + r - s.position_mm.z;
    const int bin = static_cast<int>(std::floor(d));
    if (d < 0 || bin > 3) continue;
    sum[bin] += s.force_un;
    ++count[bin];
  }
  double previous = 0, first_angle = 0, last_angle = 0;
  for (int b = 0; b < 4; ++b) {
    ASSERT_GT(count[b], 0);
    const Vec3d mean = sum[b] / static_cast<double>(count[b]);
    EXPECT_GT(mean.z, 0.0) << "the beam pushes the stylus up, depth " << b << "–" << b + 1 << " mm";
    EXPECT_GT(length(mean), previous * 1.1)
        << "the force must grow with depth (" << b << "–" << b + 1 << " mm)";
    previous = length(mean);
    // Angle from +z in the x–z plane.
    const double angle = std::atan2(mean.x, mean.z) * 180.0 / 3.14159265358979;
    if (b == 0) first_angle = angle;
    last_angle = angle;
  }
  EXPECT_GT(std::fabs(last_angle - first_angle), 5.0)
      << "the reaction must turn as the beam bends: first " << first_angle << "°, last "
      << last_angle << "°";
}

}  // namespace
}  // namespace tsf::haptics
