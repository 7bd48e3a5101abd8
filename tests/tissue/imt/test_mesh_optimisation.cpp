#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "imt_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/imt/mesh_quality.h"
#include "tsf/imt/mesh_smoothing.h"
#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/volume_edits.h"

namespace tsf::imt {
namespace {

const SphereField kBall{{15.5, 15.5, 15.5}, 12.0};

VoxelVolume ball32(double ramp) {
  return make_sdf_volume(
      cube_geometry({32, 32, 32}), [](const Vec3d& p) { return kBall.signed_distance(p); }, ramp);
}

SurfaceMesh surface(const VoxelVolume& v, float eps) {
  SurfaceOptions o;
  o.snap_epsilon = eps;
  return extract_surface(v, o);
}

TEST(MeshOptimisation, CountsBeforeAndAfterOn32CubedBall) {
  const VoxelVolume v = ball32(1.0);
  const SurfaceMesh raw = surface(v, 0.0f);
  const SurfaceMesh soup = unweld(raw);
  const SurfaceMesh merged = surface(v, 0.1f);
  std::printf(
      "32³ ball: unwelded %zu tri / %zu vert; welded %zu vert; merged %zu tri / %zu vert "
      "(%.1f%% triangles)\n",
      soup.triangle_count(), soup.vertex_count(), raw.vertex_count(), merged.triangle_count(),
      merged.vertex_count(),
      100.0 * (double(merged.triangle_count()) / double(raw.triangle_count()) - 1.0));
  EXPECT_EQ(soup.vertex_count(), 3 * raw.triangle_count());
  // Welding by edge key: a closed genus-0 mesh has V = T/2 + 2 exactly.
  EXPECT_EQ(raw.vertex_count(), raw.triangle_count() / 2 + 2);
  EXPECT_EQ(merged.vertex_count(), merged.triangle_count() / 2 + 2);
  EXPECT_LT(double(merged.triangle_count()), 0.9 * double(raw.triangle_count()));
  const MeshQuality q0 = measure_quality(raw), q1 = measure_quality(merged);
  EXPECT_LT(double(q1.slivers), 0.6 * double(q0.slivers)) << "merging removes slivers";
  EXPECT_GT(q1.mean_min_angle_deg, q0.mean_min_angle_deg);
  test::expect_closed_manifold(merged, "merged ball");
}

TEST(MeshOptimisation, AreaWeightedNormalsFollowTheSphere) {
  const SurfaceMesh m = surface(ball32(1.0), 0.1f);
  double worst = 0, sum = 0;
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    const Vec3d radial = normalized_or_zero(to_double(m.positions[v]) - kBall.centre);
    const double angle = std::acos(std::clamp(dot(radial, to_double(m.normals[v])), -1.0, 1.0));
    worst = std::max(worst, angle);
    sum += angle;
  }
  EXPECT_LT(sum / double(m.vertex_count()) * 180 / M_PI, 3.0);
  EXPECT_LT(worst * 180 / M_PI, 25.0);
}

TEST(MeshOptimisation, TaubinSmoothingRemovesStaircasesAndKeepsVolume) {
  // A binary (hard-step) ball: the marching surface is a staircase with errors up to half a voxel.
  const SurfaceMesh before = surface(ball32(0.0), 0.1f);
  SurfaceMesh after = before;
  smooth_taubin(after, {20, 0.5f, -0.53f});
  auto sdf = [](const Vec3d& p) { return kBall.signed_distance(p); };
  const auto e0 = test::surface_error(before, sdf), e1 = test::surface_error(after, sdf);
  EXPECT_LT(e1.mean, 0.9 * e0.mean) << "before " << e0.mean << " after " << e1.mean;
  EXPECT_LT(e1.max, e0.max);
  // The staircase shows in the normals: smoothing must bring them much closer to the sphere's.
  auto normal_error = [](const SurfaceMesh& m) {
    double sum = 0;
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
      const Vec3d radial = normalized_or_zero(to_double(m.positions[v]) - kBall.centre);
      sum += std::acos(std::clamp(dot(radial, to_double(m.normals[v])), -1.0, 1.0));
    }
    return sum / double(m.vertex_count()) * 180 / M_PI;
  };
  EXPECT_LT(normal_error(after), 0.6 * normal_error(before))
      << normal_error(before) << "° -> " << normal_error(after) << "°";
  const double v0 = enclosed_volume(before), v1 = enclosed_volume(after);
  EXPECT_NEAR(v1, v0, 0.01 * v0);
  test::expect_closed_manifold(after, "smoothed");
  // Normals were recomputed.
  for (const Vec3f& n : after.normals) ASSERT_NEAR(length(n), 1.0f, 1e-4f);
}

TEST(MeshOptimisation, BadSmoothingOptionsAreRejected) {
  SurfaceMesh m = surface(ball32(1.0), 0.0f);
  EXPECT_THROW(smooth_taubin(m, {5, 0.5f, -0.4f}), Error);
  EXPECT_THROW(smooth_taubin(m, {-1, 0.5f, -0.53f}), Error);
}

TEST(SurfaceLabels, PerLabelMeshesPartitionTheSurface) {
  const VoxelVolume v = make_blob_volume(cube_geometry({48, 48, 48}), 11);
  const SurfaceMesh m = extract_surface(v);
  const auto labels = triangle_labels_present(m);
  ASSERT_GE(labels.size(), 2u);
  std::size_t total = 0;
  for (std::uint8_t l : labels) {
    const SurfaceMesh part = extract_label(m, l);
    EXPECT_GT(part.triangle_count(), 0u);
    total += part.triangle_count();
    EXPECT_EQ(analyse_topology(part).unreferenced_vertices, 0u);
    for (std::size_t t = 0; t < part.triangle_count(); ++t) EXPECT_EQ(triangle_label(part, t), l);
  }
  EXPECT_EQ(total, m.triangle_count());
  EXPECT_TRUE(extract_label(m, kLabelVessel).triangles.empty());
}

TEST(SurfaceLabels, VerticesCarryTheLabelOfTheTissueTheyBound) {
  // Two touching boxes of different labels in air: every vertex label is one of the two.
  VoxelVolume v(cube_geometry({24, 24, 24}));
  set_box(v, {4, 4, 4}, {11, 19, 19}, 1.0f, kLabelMucosa);
  set_box(v, {12, 4, 4}, {19, 19, 19}, 1.0f, kLabelCartilage);
  const SurfaceMesh m = extract_surface(v);
  std::size_t mucosa = 0, cartilage = 0;
  for (std::size_t i = 0; i < m.vertex_count(); ++i) {
    ASSERT_TRUE(m.labels[i] == kLabelMucosa || m.labels[i] == kLabelCartilage) << int(m.labels[i]);
    (m.positions[i].x < 11.5f ? mucosa : cartilage) +=
        m.labels[i] == (m.positions[i].x < 11.5f ? kLabelMucosa : kLabelCartilage);
  }
  EXPECT_GT(mucosa, 100u);
  EXPECT_GT(cartilage, 100u);
}

}  // namespace
}  // namespace tsf::imt
