#include <gtest/gtest.h>

#include <cmath>

#include "imt_test_helpers.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/volume/analytic_volumes.h"

namespace tsf::imt {
namespace {

using test::expect_closed_manifold;
using test::surface_error;

TEST(ExtractSurface, SphereIsClosedManifoldOfGenusZero) {
  for (float eps : {0.0f, 0.1f, 0.2f}) {
    const SphereField s{{15.3, 16.1, 15.7}, 9.4};
    const VoxelVolume v = make_sdf_volume(
        cube_geometry({32, 32, 32}), [&](const Vec3d& p) { return s.signed_distance(p); }, 2.0);
    SurfaceOptions o;
    o.snap_epsilon = eps;
    const SurfaceMesh m = extract_surface(v, o);
    ASSERT_GT(m.triangle_count(), 100u);
    const MeshTopology t = expect_closed_manifold(m, "sphere eps " + std::to_string(eps));
    ASSERT_EQ(t.components, 1u);
    EXPECT_EQ(t.component_euler[0], 2);
    EXPECT_GT(test::signed_volume(m), 0.0) << "normals point inward";
    const double expected = 4.0 / 3.0 * M_PI * s.radius * s.radius * s.radius;
    EXPECT_NEAR(test::signed_volume(m), expected, 0.02 * expected);
  }
}

TEST(ExtractSurface, TorusHasEulerCharacteristicZero) {
  const TorusField tor{{24.2, 23.7, 12.4}, 12.0, 4.5};
  const VoxelVolume v = make_sdf_volume(
      cube_geometry({48, 48, 25}), [&](const Vec3d& p) { return tor.signed_distance(p); }, 2.0);
  for (float eps : {0.0f, 0.1f}) {
    SurfaceOptions o;
    o.snap_epsilon = eps;
    const SurfaceMesh m = extract_surface(v, o);
    const MeshTopology t = expect_closed_manifold(m, "torus");
    ASSERT_EQ(t.components, 1u);
    EXPECT_EQ(t.component_euler[0], 0);
  }
}

TEST(ExtractSurface, SphereAccuracyAtSeveralResolutions) {
  // Clamped signed-distance ramp of ±2 voxels; radius in voxels grows with resolution.
  for (int n : {16, 32, 64, 128}) {
    const double r = 0.37 * n;
    const SphereField s{{0.5 * n + 0.31, 0.5 * n - 0.17, 0.5 * n + 0.07}, r};
    const VoxelVolume v = make_sdf_volume(
        cube_geometry({n, n, n}), [&](const Vec3d& p) { return s.signed_distance(p); }, 2.0);
    for (float eps : {0.0f, 0.1f}) {
      SurfaceOptions o;
      o.snap_epsilon = eps;
      const SurfaceMesh m = extract_surface(v, o);
      const auto e = surface_error(m, [&](const Vec3d& p) { return s.signed_distance(p); });
      EXPECT_LE(e.mean, 0.05) << n << "³ eps " << eps;
      EXPECT_LE(e.max, 0.2) << n << "³ eps " << eps;
    }
  }
}

}  // namespace
}  // namespace tsf::imt
