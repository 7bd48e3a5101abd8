// The mesh model against a sphere's IMT surface: the force points out along the surface normal
// and follows the intersection-volume law near the surface (one stylus sphere); a set of smaller
// spheres (for tool shapes that are not spheres) still pushes out, a little later and softer.
#include <gtest/gtest.h>

#include <cmath>

#include "haptics_test_helpers.h"
#include "tsf/haptics/mesh_force.h"
#include "tsf/haptics/sphere_intersection.h"
#include "tsf/imt/extract_surface.h"

namespace tsf::haptics {
namespace {

TEST(MeshForce, ClosestPointOnTriangleMatchesTheRegions) {
  const Vec3d a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  double wa, wb, wc;
  const Vec3d inside = closest_point_on_triangle({0.2, 0.2, 3}, a, b, c, wa, wb, wc);
  EXPECT_NEAR(length(inside - Vec3d{0.2, 0.2, 0}), 0.0, 1e-12);
  EXPECT_NEAR(wa + wb + wc, 1.0, 1e-12);
  EXPECT_EQ(closest_point_on_triangle({-1, -1, 0}, a, b, c, wa, wb, wc), a);
  const Vec3d e = closest_point_on_triangle({1, 1, 0}, a, b, c, wa, wb, wc);
  EXPECT_NEAR(e.x, 0.5, 1e-12);
  EXPECT_NEAR(e.y, 0.5, 1e-12);
  // A zero-area triangle (two corners coincide, as IMT keeps where snapped vertices merge): the
  // nearest point of its edge, finite.
  const Vec3d seg = closest_point_on_triangle({0.5, 1, 0}, a, b, b, wa, wb, wc);
  EXPECT_NEAR(length(seg - Vec3d{0.5, 0, 0}), 0.0, 1e-12);
  EXPECT_TRUE(std::isfinite(wa + wb + wc));
}

TEST(MeshForce, PushesOutAlongTheNormalAndFollowsTheLawNearTheSurface) {
  const double R = 8.0, r = 2.5;
  const VoxelVolume tissue = test::sphere_volume_of(R, 24.0, 0.5, 0.25);
  const Vec3d c = test::volume_centre(tissue);
  const imt::SurfaceMesh mesh = imt::extract_surface(tissue);
  ASSERT_GT(mesh.triangle_count(), 1000u);
  ForceModelOptions o;
  o.stylus_radius_mm = r;
  o.sphere_resolution = 1;
  const MeshForceModel model(o);
  const Vec3d dir = normalized_or_zero(Vec3d{1, 1, 1});
  const auto points = test::line_points(c + dir * (R + r + 0.5), c + dir * (R - r - 0.5), 81);
  const auto forces = test::forces_along(model, tissue, &mesh, r, points);
  int touching = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double d = length(points[i] - c);
    const Vec3d F = forces[i].force_un;
    ASSERT_TRUE(all_finite(F));
    if (d >= R + r + 0.1) {
      EXPECT_EQ(length(F), 0.0) << "no contact yet, d = " << d;
    }
    if (length(F) > 0) {
      ++touching;
      EXPECT_GT(dot(F, dir), 0.98 * length(F)) << "along the outward normal, d = " << d;
    }
    // Shallow contact (less than a third of the stylus in): the caps approximate the lens.
    const double V = sphere_intersection_volume(r, R, d);
    // One stylus sphere: the cap under the deepest point is the lens of a flat surface, ~15%
    // above the lens against this curved one.
    if (d > R + r / 3.0) {
      EXPECT_NEAR(forces[i].intersection_mm3, V, 0.25 * V + 0.1) << "d = " << d;
    }
  }
  EXPECT_GT(touching, 20);
}

TEST(MeshForce, ASphereSetStylusPushesOutWithALateSofterOnset) {
  const double R = 8.0, r = 2.5;
  const VoxelVolume tissue = test::sphere_volume_of(R, 24.0, 0.5, 0.25);
  const Vec3d c = test::volume_centre(tissue);
  const imt::SurfaceMesh mesh = imt::extract_surface(tissue);
  ForceModelOptions o;
  o.stylus_radius_mm = r;
  o.sphere_resolution = 8;
  const MeshForceModel model(o);
  EXPECT_GT(model.stylus().offsets.size(), 100u);
  const Vec3d dir = normalized_or_zero(Vec3d{1, 0.3, -0.2});
  const auto points = test::line_points(c + dir * (R + r + 0.5), c + dir * (R - r - 0.5), 81);
  const auto forces = test::forces_along(model, tissue, &mesh, r, points);
  double first_contact = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double d = length(points[i] - c);
    const Vec3d F = forces[i].force_un;
    ASSERT_TRUE(all_finite(F));
    if (d >= R + r) {
      EXPECT_EQ(length(F), 0.0) << "every sphere lies inside the stylus, d = " << d;
    }
    if (length(F) > 0) {
      if (first_contact == 0) first_contact = d;
      EXPECT_GT(dot(F, dir), 0.98 * length(F)) << "d = " << d;
      const double V = sphere_intersection_volume(r, R, d);
      EXPECT_LE(forces[i].intersection_mm3, 1.3 * V + 0.1) << "d = " << d;
    }
  }
  EXPECT_GT(first_contact, R + r - 0.5) << "contact must start within 0.5 mm of touching";
}

}  // namespace
}  // namespace tsf::haptics
