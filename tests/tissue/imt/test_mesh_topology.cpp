#include "tsf/imt/mesh_topology.h"

#include <gtest/gtest.h>

namespace tsf::imt {
namespace {

SurfaceMesh tetrahedron() {
  SurfaceMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.labels.assign(4, 1);
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

TEST(MeshTopology, TetrahedronIsAClosedSphere) {
  const MeshTopology t = analyse_topology(tetrahedron());
  EXPECT_TRUE(t.closed_oriented_manifold());
  EXPECT_EQ(t.edges, 6u);
  ASSERT_EQ(t.components, 1u);
  EXPECT_EQ(t.component_euler[0], 2);
}

TEST(MeshTopology, FindsHolesFlipsAndPinches) {
  SurfaceMesh open = tetrahedron();
  open.triangles.pop_back();
  EXPECT_EQ(analyse_topology(open).boundary_edges, 3u);

  SurfaceMesh flipped = tetrahedron();
  std::swap(flipped.triangles[3][1], flipped.triangles[3][2]);
  EXPECT_EQ(analyse_topology(flipped).misoriented_edges, 3u);

  // Two tetrahedra sharing one vertex: every edge fine, the shared vertex is a pinch.
  SurfaceMesh pinch = tetrahedron();
  const SurfaceMesh b = tetrahedron();
  for (const auto& p : b.positions) pinch.positions.push_back({-p.x, -p.y, -p.z});
  pinch.labels.assign(8, 1);
  for (auto t : b.triangles) {
    for (auto& v : t) v = v == 0 ? 0 : v + 4;
    std::swap(t[1], t[2]);  // mirrored: keep it outward
    pinch.triangles.push_back(t);
  }
  const MeshTopology t = analyse_topology(pinch);
  EXPECT_EQ(t.boundary_edges + t.nonmanifold_edges + t.misoriented_edges, 0u);
  EXPECT_EQ(t.nonmanifold_vertices, 1u);
  EXPECT_EQ(t.unreferenced_vertices, 1u);  // the unused copy of vertex 0
  EXPECT_FALSE(t.closed_oriented_manifold());

  SurfaceMesh degenerate = tetrahedron();
  degenerate.triangles.push_back({1, 1, 2});
  EXPECT_EQ(analyse_topology(degenerate).degenerate_triangles, 1u);
}

}  // namespace
}  // namespace tsf::imt
