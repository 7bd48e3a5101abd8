// The voxel model against analytic cases (thesis §8.6.2): a sphere stylus through a larger
// sphere follows the intersection-volume law, and through a chamfered cube gives two smooth peaks
// with no force while fully immersed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "haptics_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/haptics/sphere_intersection.h"
#include "tsf/haptics/voxel_force.h"

namespace tsf::haptics {
namespace {

using test::forces_along;
using test::line_points;

constexpr double kTissueRadius = 8.0, kStylusRadius = 2.5;

ForceModelOptions stylus_options(int resolution, double taper) {
  ForceModelOptions o;
  o.stylus_radius_mm = kStylusRadius;
  o.voxel_resolution = resolution;
  o.law.c1 = 1e4;
  o.law.c2 = 1.0;
  o.law.taper_fraction = taper;
  return o;
}

TEST(VoxelForce, SphereThroughLargerSphereFollowsTheIntersectionVolumeLaw) {
  // Tolerance: 4% of the peak force, everywhere along the pass (the discrete stylus and the
  // trilinear density ramp of 0.5 mm voxels against the exact lens volume).
  const VoxelVolume tissue = test::sphere_volume_of(kTissueRadius, 24.0, 0.5, 0.25);
  const Vec3d c = test::volume_centre(tissue);
  const VoxelForceModel model(stylus_options(16, 0.5));
  const double v_stylus = sphere_volume(kStylusRadius);
  // From outside (d = R + r + 0.5) to the centre, along +x into the sphere.
  const auto points = line_points(c + Vec3d{kTissueRadius + kStylusRadius + 0.5, 0, 0}, c, 221);
  const auto forces = forces_along(model, tissue, nullptr, kStylusRadius, points);
  double peak = 0;
  for (std::size_t i = 0; i < points.size(); ++i)
    peak = std::max(
        peak, model.law().magnitude(
                  sphere_intersection_volume(kStylusRadius, kTissueRadius, length(points[i] - c)),
                  v_stylus));
  ASSERT_GT(peak, 0);
  int in_contact = 0, past_cutoff = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double d = length(points[i] - c);
    const double V = sphere_intersection_volume(kStylusRadius, kTissueRadius, d);
    const double expected = model.law().magnitude(V, v_stylus);
    const Vec3d F = forces[i].force_un;
    EXPECT_NEAR(length(F), expected, 0.04 * peak) << "d = " << d << " mm, V = " << V << " mm³";
    if (length(F) > 0.01 * peak) {
      ++in_contact;
      // Outward: it opposes the penetration (stylus centre away from the tissue centre).
      EXPECT_GT(dot(F, normalized_or_zero(points[i] - c)), 0.99 * length(F)) << "d = " << d;
    }
    if (V > 0.53 * v_stylus) {  // past the cut-off (with a margin for the discrete stylus)
      ++past_cutoff;
      EXPECT_EQ(length(F), 0.0) << "the force must vanish past the cut-off, d = " << d;
    }
  }
  EXPECT_GT(in_contact, 40);
  EXPECT_GT(past_cutoff, 40);
}

TEST(VoxelForce, HardCutOffMatchesTheLawAwayFromTheCutOff) {
  // The thesis's Eq. 12 without the taper: same law, the force drops to zero at V = ½·V_stylus.
  const VoxelVolume tissue = test::sphere_volume_of(kTissueRadius, 24.0, 0.5, 0.25);
  const Vec3d c = test::volume_centre(tissue);
  const VoxelForceModel model(stylus_options(16, 0.0));
  const double v_stylus = sphere_volume(kStylusRadius);
  const auto points = line_points(c + Vec3d{kTissueRadius + kStylusRadius, 0, 0}, c, 161);
  const auto forces = forces_along(model, tissue, nullptr, kStylusRadius, points);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double V =
        sphere_intersection_volume(kStylusRadius, kTissueRadius, length(points[i] - c));
    if (std::fabs(V / v_stylus - 0.5) < 0.04)
      continue;  // the cut-off itself: discretisation decides
    const double expected = model.law().magnitude(V, v_stylus);
    EXPECT_NEAR(length(forces[i].force_un), expected, 0.03 * 0.5 * v_stylus * 1e4 + 1e-9)
        << "V = " << V;
  }
}

/// A cube of half-size h with its 12 edges chamfered by c (mm), centred at `centre`.
double chamfered_cube(const Vec3d& p, const Vec3d& centre, double h, double c) {
  const Vec3d q = p - centre;
  double d = box_distance_local({h, h, h}, q);
  const double ax = std::fabs(q.x), ay = std::fabs(q.y), az = std::fabs(q.z);
  const double s = 1.0 / std::sqrt(2.0);
  d = std::max(d, (ax + ay - (2 * h - c)) * s);
  d = std::max(d, (ay + az - (2 * h - c)) * s);
  d = std::max(d, (ax + az - (2 * h - c)) * s);
  return d;
}

TEST(VoxelForce, SphereThroughChamferedCubeGivesTwoSmoothPeaksAndReverses) {
  // Thesis Fig. 67–69: a 2.5 mm stylus along a diagonal path through a chamfered 16 mm cube.
  const int n = 48;
  const double voxel = 0.5;
  const Vec3d centre{0.5 * (n - 1) * voxel, 0.5 * (n - 1) * voxel, 0.5 * (n - 1) * voxel};
  const VoxelVolume cube = make_sdf_volume(
      cube_geometry({n, n, n}, voxel),
      [&](const Vec3d& p) { return chamfered_cube(p, centre, 8.0, 3.0); }, 0.25);
  const VoxelForceModel model(stylus_options(16, 0.5));
  const Vec3d dir = normalized_or_zero(Vec3d{1, 0.5, 0});
  const auto points = line_points(centre - dir * 11.5, centre + dir * 11.5, 461);  // 0.05 mm steps
  const auto forces = forces_along(model, cube, nullptr, kStylusRadius, points);
  std::vector<double> mag;
  for (const HapticForce& f : forces) mag.push_back(length(f.force_un));
  const double peak = *std::max_element(mag.begin(), mag.end());
  ASSERT_GT(peak, 0);
  // Contact runs: maximal stretches of non-zero force.
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  for (std::size_t i = 0; i < mag.size(); ++i) {
    if (mag[i] <= 0) continue;
    if (runs.empty() || runs.back().second + 1 != i)
      runs.push_back({i, i});
    else
      runs.back().second = i;
  }
  ASSERT_EQ(runs.size(), 2u) << "expected an entry peak and an exit peak with zero between";
  const std::size_t gap = runs[1].first - runs[0].second;
  EXPECT_GT(gap, 40u) << "the fully immersed stretch (force masked) must be clearly zero";
  for (const auto& run : runs) {
    // Smooth: one peak per run (rises then falls), no step larger than 15% of the peak per 0.05 mm
    // (the law itself changes by up to ~10% per step at its steepest; a hard cut-off drops ~100%).
    std::size_t top = run.first;
    for (std::size_t i = run.first; i <= run.second; ++i)
      if (mag[i] > mag[top]) top = i;
    EXPECT_GT(mag[top], 0.5 * peak);
    for (std::size_t i = run.first; i <= run.second + 1 && i < mag.size(); ++i) {
      EXPECT_LT(std::fabs(mag[i] - mag[i - 1]), 0.15 * peak) << "a jump at sample " << i;
      if (i > run.first && i < top) {
        EXPECT_GE(mag[i], mag[i - 1] - 0.002 * peak) << "rising, sample " << i;
      }
      if (i > top && i <= run.second) {
        EXPECT_LE(mag[i], mag[i - 1] + 0.002 * peak) << "falling, sample " << i;
      }
    }
  }
  // Direction: against the motion on entry (≈180°), with it on exit (the tissue pushes the stylus
  // out of the far side).
  for (std::size_t i = runs[0].first; i <= runs[0].second; ++i)
    if (mag[i] > 0.05 * peak) {
      EXPECT_LT(dot(forces[i].force_un, dir), -0.7 * mag[i]) << "entry, sample " << i;
    }
  for (std::size_t i = runs[1].first; i <= runs[1].second; ++i)
    if (mag[i] > 0.05 * peak) {
      EXPECT_GT(dot(forces[i].force_un, dir), 0.7 * mag[i]) << "exit, sample " << i;
    }
}

TEST(VoxelForce, InverseWarpFollowsATranslatedLattice) {
  // A lattice window displaced by +2 mm in x: the tissue is felt 2 mm further along x.
  const VoxelVolume tissue = test::sphere_volume_of(kTissueRadius, 24.0, 0.5, 0.25);
  const Vec3d c = test::volume_centre(tissue);
  const VoxelForceModel model(stylus_options(12, 0.5));
  StaticFrameSource source(tissue, nullptr, {kStylusRadius, 3.0});
  HapticFrame frame;
  StylusPose pose, shifted;
  pose.position = c + Vec3d{kTissueRadius + 1.0, 0, 0};  // 1.5 mm deep without the warp
  shifted.position = pose.position - Vec3d{2, 0, 0};     // where the warp maps it: 3.5 mm deep
  source.step(0, shifted, false, frame);                 // the density window around the rest point
  const HapticForce reference = model.evaluate(frame.view(), shifted);
  const HapticForce unwarped = model.evaluate(frame.view(), pose);
  frame.lattice_dims = {6, 6, 6};
  frame.lattice_spacing = {2, 2, 2};
  frame.lattice_origin = pose.position - Vec3d{5, 5, 5};
  frame.displacement.assign(216, Vec3f{2, 0, 0});
  frame.alive.assign(216, 1);
  const HapticForce warped = model.evaluate(frame.view(), pose);
  EXPECT_TRUE(warped.warped);
  EXPECT_FALSE(reference.warped);
  EXPECT_NEAR(warped.intersection_mm3, reference.intersection_mm3,
              1e-6 * (1 + reference.intersection_mm3));
  EXPECT_GT(warped.intersection_mm3, unwarped.intersection_mm3 + 1.0);
}

TEST(VoxelForce, ForceLawValidationNamesTheField) {
  ForceModelOptions o;
  o.law.c2 = -1;
  try {
    VoxelForceModel m(o);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("c2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tsf::haptics
