// Signed-distance grids of closed meshes (the shape of mesh tools and of pushing bodies): the
// distance and normal match the body the mesh approximates, the inside holds its volume, and an
// open mesh, a mesh with no inside at the spacing, or a grid too large is refused by name.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "collision_test_meshes.h"
#include "tsf/collision/distance_grid.h"
#include "tsf/collision/world_tool.h"
#include "tsf/common/error.h"

namespace tsf::collision {
namespace {

TEST(DistanceGrid, ASphereMeshGivesTheSphereDistanceAndOutwardNormals) {
  const double r = 5.0;
  const test::Mesh m = test::sphere_mesh(r, 4);  // 2048 triangles: facets within 0.02 mm
  const SignedDistanceGrid g =
      SignedDistanceGrid::from_closed_mesh(m.vertices, m.triangles, 0.25, 1.0);
  std::mt19937 rng(7);
  // Within the grid's 1 mm margin (beyond it the distance only grows with the distance to the box).
  std::uniform_real_distribution<double> u(-1.0, 1.0), depth(-2.0, 0.9);
  for (int i = 0; i < 500; ++i) {
    const Vec3d dir = normalized_or_zero(Vec3d{u(rng), u(rng), u(rng)});
    if (length(dir) < 0.5) continue;
    const double d_true = depth(rng);
    const Vec3d p = dir * (r + d_true);
    Vec3d n;
    const double d = g.distance(p, n);
    EXPECT_NEAR(d, d_true, 0.05) << "at " << p.x << ", " << p.y << ", " << p.z;
    EXPECT_GT(dot(n, dir), 0.97) << "the normal points out of the sphere";
  }
  const double volume = 4.0 / 3.0 * M_PI * r * r * r;
  EXPECT_NEAR(g.inside_volume_mm3(), volume, 0.05 * volume);
  // Far outside the grid the distance keeps growing away from the body.
  Vec3d n;
  EXPECT_NEAR(g.distance({50, 0, 0}, n), 45.0, 0.2);
  EXPECT_GT(n.x, 0.99);
}

TEST(DistanceGrid, APosedMeshToolIsTheGridTurnedAndMoved) {
  const test::Mesh m = test::box_mesh({-1, -2, -4}, {1, 2, 4});
  const SignedDistanceGrid g =
      SignedDistanceGrid::from_closed_mesh(m.vertices, m.triangles, 0.1, 0.5);
  WorldTool t;
  t.shape = ToolShape::kMesh;
  t.grid = &g;
  t.pose = {{10, 20, 30}, Rotation::about_axis({1, 0, 0}, M_PI / 2)};  // local z → world −y
  Vec3d n;
  // 3 mm below the box's local top (+z = 4 mm): world (10, 20 − 1, 30), 3 mm inside → −1 mm.
  EXPECT_NEAR(tool_distance(t, {10, 19, 30}, n), -1.0, 0.05);
  // 1 mm beyond the local +z face: world y = 20 − 5.
  EXPECT_NEAR(tool_distance(t, {10, 15, 30}, n), 1.0, 0.05);
  EXPECT_LT(n.y, -0.99) << "that face's normal is local +z, world −y";
  Vec3d lo, hi;
  tool_bounds(t, lo, hi);
  EXPECT_LT(lo.y, 16.0);
  EXPECT_GT(hi.y, 24.0);
  EXPECT_TRUE(host_only(t.shape));
}

TEST(DistanceGrid, AnOpenMeshIsRefusedNamingTheEdge) {
  test::Mesh m = test::sphere_mesh(3.0, 2);
  m.triangles.pop_back();
  try {
    SignedDistanceGrid::from_closed_mesh(m.vertices, m.triangles, 0.2, 0.5);
    FAIL() << "an open mesh has no inside";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not closed"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("is used by 1 triangle"), std::string::npos) << e.what();
  }
  EXPECT_NE(closed_mesh_problem(3, {{0, 1, 7}}).find("names vertex 7"), std::string::npos);
}

TEST(DistanceGrid, AGridTooLargeOrABodyThinnerThanTheSpacingIsRefused) {
  const test::Mesh big = test::box_mesh({0, 0, 0}, {1000, 1000, 1000});
  try {
    SignedDistanceGrid::from_closed_mesh(big.vertices, big.triangles, 0.1, 0.5);
    FAIL() << "a grid of 10¹² samples";
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("use a spacing of at least"), std::string::npos)
        << e.what();
  }
  // 10 µm thick, between the samples of a 1 mm grid (margin 2.45 mm: no sample on its faces).
  const test::Mesh sheet = test::box_mesh({0.3, 0.3, 0.3}, {10.3, 10.3, 0.31});
  EXPECT_THROW(SignedDistanceGrid::from_closed_mesh(sheet.vertices, sheet.triangles, 1.0, 2.45),
               Error);
}

}  // namespace
}  // namespace tsf::collision
