// Clean triangles: no zero-area or duplicate triangles after clean_topology, the surface still
// closed and unchanged in shape (every vertex an input vertex, the same enclosed volume).
#include <gtest/gtest.h>

#include <cmath>

#include "export_test_helpers.h"
#include "tsf/export/mesh_cleanup.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/imt/mesh_quality.h"
#include "tsf/imt/mesh_smoothing.h"
#include "tsf/imt/mesh_topology.h"

namespace tsf::exporter {
namespace {
using namespace test;

imt::SurfaceMesh cleaned_mesh(const imt::SurfaceMesh& in, const CleanTopology& c) {
  imt::SurfaceMesh m;
  m.positions = gather(in.positions, c.origin);
  m.labels = c.labels;
  m.triangles = c.triangles;
  return m;
}

/// A box of density exactly 1 in a volume of 0 surfaced without vertex merging: body centres of
/// the cubes across each face sit exactly on the iso-level and every edge ending there emits a
/// vertex at the same point (docs/imt.md): many zero-area triangles.
imt::SurfaceMesh binary_box_surface() {
  VoxelVolume v(cube_geometry({14, 12, 10}, 1.0));
  for (int k = 3; k < 7; ++k)
    for (int j = 2; j < 9; ++j)
      for (int i = 2; i < 11; ++i) {
        v.density_data()[v.index(i, j, k)] = 1.0f;
        v.label_data()[v.index(i, j, k)] = i < 6 ? kLabelMucosa : kLabelSoftTissue;
      }
  v.mark_all_modified();
  imt::SurfaceOptions o;
  o.snap_epsilon = 0.0f;
  return imt::extract_surface(v, o);
}

TEST(MeshCleanup, BinaryBoxLosesEveryZeroAreaTriangleAndStaysClosed) {
  const imt::SurfaceMesh in = binary_box_surface();
  const TriangleDefects before = count_triangle_defects(in);
  ASSERT_GT(before.zero_area, 0u) << "the test surface must have defects to remove";
  EXPECT_EQ(before.zero_area, imt::measure_quality(in).zero_area);

  const CleanTopology c = clean_topology(in);
  EXPECT_EQ(c.report.before.zero_area, before.zero_area);
  EXPECT_EQ(c.report.after.zero_area, 0u);
  EXPECT_EQ(c.report.after.duplicates, 0u);
  EXPECT_GT(c.report.welded_vertices, 0u);
  const imt::SurfaceMesh out = cleaned_mesh(in, c);
  const TriangleDefects after = count_triangle_defects(out);
  EXPECT_EQ(after.zero_area, 0u);
  EXPECT_EQ(after.duplicates, 0u);
  EXPECT_EQ(after.triangles, c.report.after.triangles);
  const imt::MeshTopology topo = imt::analyse_topology(out);
  EXPECT_EQ(topo.boundary_edges, 0u);
  EXPECT_EQ(topo.misoriented_edges, 0u);
  EXPECT_EQ(topo.degenerate_triangles, 0u);
  EXPECT_EQ(topo.unreferenced_vertices, 0u);
  // Same shape: the same enclosed volume (positive: still facing out).
  EXPECT_GT(imt::enclosed_volume(out), 100.0);
  EXPECT_NEAR(imt::enclosed_volume(out), imt::enclosed_volume(in),
              1e-6 * std::fabs(imt::enclosed_volume(in)));
  // Labels come from the vertices kept.
  for (std::size_t v = 0; v < c.origin.size(); ++v) EXPECT_EQ(c.labels[v], in.labels[c.origin[v]]);
}

TEST(MeshCleanup, DuplicatesAndFinsAreDropped) {
  imt::SurfaceMesh m = labelled_sphere(oblique_geometry());
  const std::size_t n = m.triangles.size();
  const auto t0 = m.triangles[0], t1 = m.triangles[1];
  m.triangles.push_back(t0);                     // same orientation: one copy goes
  m.triangles.push_back({t1[0], t1[2], t1[1]});  // opposite: t1 and its reverse form a fin
  const TriangleDefects before = count_triangle_defects(m);
  EXPECT_EQ(before.duplicates, 2u);
  const CleanTopology c = clean_topology(m);
  EXPECT_EQ(c.report.duplicates_removed, 1u);
  EXPECT_EQ(c.report.fins_removed, 2u);
  EXPECT_EQ(c.triangles.size(), n - 1);  // t1 and its reverse both gone
  EXPECT_EQ(c.report.after.duplicates, 0u);
}

TEST(MeshCleanup, CollinearCapIsFlippedIntoItsNeighbour) {
  // A tetrahedron a b c d whose face abc is split at m, the midpoint of ab, with the zero-area
  // cap (a, b, m) closing the surface: a closed manifold with one cap.
  imt::SurfaceMesh m;
  m.positions = {{0, 0, 0}, {2, 0, 0}, {1, 2, 0}, {1, 1, 2}, {1, 0, 0}};
  const std::uint32_t a = 0, b = 1, c = 2, d = 3, mid = 4;
  m.triangles = {{a, mid, c}, {mid, b, c}, {a, b, mid}, {b, a, d}, {a, c, d}, {b, d, c}};
  m.labels.assign(5, kLabelSoftTissue);
  ASSERT_EQ(imt::analyse_topology(m).boundary_edges, 0u);
  ASSERT_EQ(count_triangle_defects(m).zero_area, 1u);
  const CleanTopology clean = clean_topology(m);
  EXPECT_EQ(clean.report.caps_flipped, 1u);
  EXPECT_EQ(clean.report.caps_removed, 0u);
  const imt::SurfaceMesh out = cleaned_mesh(m, clean);
  EXPECT_EQ(count_triangle_defects(out).zero_area, 0u);
  EXPECT_TRUE(imt::analyse_topology(out).closed_oriented_manifold());
  EXPECT_NEAR(imt::enclosed_volume(out), imt::enclosed_volume(m), 1e-9);
}

TEST(MeshCleanup, SequencesWeldOnlyWhatStaysTogether) {
  // Two vertices at one point at rest that move apart in a later state keep their own vertices.
  imt::SurfaceMesh m = binary_box_surface();
  std::vector<Vec3f> later = m.positions;
  // The first coincident pair: move its higher index away.
  std::uint32_t moved = UINT32_MAX;
  for (std::uint32_t v = 1; v < m.positions.size() && moved == UINT32_MAX; ++v)
    for (std::uint32_t u = 0; u < v; ++u)
      if (m.positions[u] == m.positions[v]) {
        moved = v;
        break;
      }
  ASSERT_NE(moved, UINT32_MAX);
  later[moved] += Vec3f{0.0f, 0.0f, 0.5f};
  const CleanTopology alone = clean_topology(m);
  const CleanTopology with_state = clean_topology(m, {&later});
  EXPECT_EQ(with_state.report.welded_vertices + 1, alone.report.welded_vertices);
  bool kept = false;
  for (std::uint32_t o : with_state.origin) kept |= o == moved;
  EXPECT_TRUE(kept) << "the vertex that moves apart keeps its own vertex";
}

}  // namespace
}  // namespace tsf::exporter
