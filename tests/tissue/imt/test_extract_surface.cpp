#include <gtest/gtest.h>

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "imt_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/imt/mesh_quality.h"
#include "tsf/imt/mesh_smoothing.h"
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

namespace tsf::imt {
namespace {

TEST(ExtractSurface, SameOutputForAnyThreadCount) {
  const VoxelVolume v = make_blob_volume(cube_geometry({96, 96, 96}, 0.8), 21);
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  SurfaceBuildStats one_stats;
  const SurfaceMesh one = extract_surface(v, {}, &one_stats);
  omp_set_num_threads(std::max(2, threads));
  SurfaceBuildStats many_stats;
  const SurfaceMesh many = extract_surface(v, {}, &many_stats);
  omp_set_num_threads(threads);
  ASSERT_GE(many_stats.active_blocks, 16u) << "the volume must be large enough to go parallel";
  EXPECT_EQ(one_stats.threads, 1);
  EXPECT_GE(many_stats.threads, 2);
  EXPECT_EQ(one.positions, many.positions);
  EXPECT_EQ(one.normals, many.normals);
  EXPECT_EQ(one.labels, many.labels);
  EXPECT_EQ(one.triangles, many.triangles);
}

TEST(ExtractSurface, EmptyAndFullVolumes) {
  VoxelVolume empty(cube_geometry({20, 20, 20}));
  EXPECT_EQ(extract_surface(empty).triangle_count(), 0u);
  // A volume full of tissue is closed by the zero padding outside it: one box-shaped component.
  VoxelVolume full(cube_geometry({12, 10, 8}));
  std::fill(full.density_data().begin(), full.density_data().end(), 1.0f);
  const SurfaceMesh m = extract_surface(full);
  const MeshTopology t = test::expect_closed_manifold(m, "full volume");
  ASSERT_EQ(t.components, 1u);
  EXPECT_EQ(t.component_euler[0], 2);
}

// Tissue cut by the volume's border (a CT cropped at the neck): the surface closes outside the
// border without degenerate triangles. Centres of cubes reaching outside the volume read 0; as
// the mean of their corners they would sit exactly on the iso-level (4 corners at 1, 4 at 0) and
// every edge ending there would emit the same vertex.
TEST(ExtractSurface, TissueCutByTheBorderHasNoZeroAreaTriangles) {
  VoxelVolume full(cube_geometry({12, 10, 8}));
  std::fill(full.density_data().begin(), full.density_data().end(), 1.0f);
  const SphereField ball{{10.3, 8.2, 4.1}, 9.37};  // no lattice point exactly on the sphere
  const VoxelVolume cut = make_sdf_volume(
      cube_geometry({24, 20, 16}), [&](const Vec3d& p) { return ball.signed_distance(p); }, 1.0);
  for (float eps : {0.0f, 0.1f}) {
    SurfaceOptions o;
    o.snap_epsilon = eps;
    for (const VoxelVolume* v : std::initializer_list<const VoxelVolume*>{&full, &cut}) {
      const SurfaceMesh m = extract_surface(*v, o);
      const std::string what = std::string(v == &full ? "full volume" : "ball cut by the border") +
                               ", merge eps " + std::to_string(eps);
      expect_closed_manifold(m, what);
      const MeshQuality q = measure_quality(m);
      EXPECT_GT(q.triangles, 0u) << what;
      EXPECT_EQ(q.zero_area, 0u) << what;
    }
  }
}

TEST(ExtractSurface, BinaryVolumeWithMergingHasNoZeroAreaTriangles) {
  // Density exactly 1 inside a box and 0 outside: the body centres of the cubes across each face
  // average to exactly the iso-level, and every edge ending at one emits its vertex there. With
  // merging, all of them merge (neighbours included), so no two vertices coincide; without, the
  // surface keeps the zero-area triangles (the cut-block scene's box was 64 % of them).
  VoxelVolume v(cube_geometry({20, 14, 14}));
  for (int k = 2; k < 12; ++k)
    for (int j = 2; j < 12; ++j)
      for (int i = 2; i < 18; ++i) v.density_data()[v.index(i, j, k)] = 1.0f;
  v.mark_all_modified();
  SurfaceOptions merged, plain;
  plain.snap_epsilon = 0.0f;
  const SurfaceMesh with = extract_surface(v, merged), without = extract_surface(v, plain);
  expect_closed_manifold(with, "binary box, merging");
  EXPECT_EQ(measure_quality(with).zero_area, 0u);
  EXPECT_GT(measure_quality(without).zero_area, without.triangle_count() / 4)
      << "the case must be hard without merging for the test to mean anything";
  // Same enclosed volume: merging exact points moves nothing.
  EXPECT_NEAR(enclosed_volume(with), enclosed_volume(without), 1e-6 * enclosed_volume(without));
}

TEST(ExtractSurface, RejectsBadOptions) {
  VoxelVolume v(cube_geometry({4, 4, 4}));
  SurfaceOptions o;
  o.iso = 0.0f;
  EXPECT_THROW(extract_surface(v, o), Error);
  o.iso = 0.5f;
  o.snap_epsilon = 0.5f;
  EXPECT_THROW(extract_surface(v, o), Error);
}

}  // namespace
}  // namespace tsf::imt
