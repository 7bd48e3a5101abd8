// Decimation: the budget is met, tissue borders survive, every output vertex is an input vertex,
// the surface stays closed, an error bound stops earlier, slabs on two threads agree with one
// call, and the measured distance to the full surface is small.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "export_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/export/mesh_cleanup.h"
#include "tsf/export/mesh_decimation.h"
#include "tsf/export/surface_deviation.h"
#include "tsf/imt/mesh_topology.h"

namespace tsf::exporter {
namespace {
using namespace test;

/// A finer labelled sphere (about 30 k triangles).
imt::SurfaceMesh fine_sphere() {
  VolumeGeometry g = cube_geometry({48, 48, 48}, 0.5);
  return labelled_sphere(g, 10.0, {2.0, 2.0, 2.0});
}

/// The decimated mesh with its tissue-border copies welded back by origin (for topology).
imt::SurfaceMesh welded(const imt::SurfaceMesh& full, const DecimatedMesh& d) {
  imt::SurfaceMesh m;
  std::map<std::uint32_t, std::uint32_t> index_of;
  std::vector<std::uint32_t> vertex(d.origin.size());
  for (std::size_t v = 0; v < d.origin.size(); ++v) {
    const auto [it, fresh] =
        index_of.emplace(d.origin[v], static_cast<std::uint32_t>(m.positions.size()));
    if (fresh) {
      m.positions.push_back(full.positions[d.origin[v]]);
      m.labels.push_back(d.labels[v]);
    }
    vertex[v] = it->second;
  }
  for (const auto& t : d.triangles)
    m.triangles.push_back({vertex[t[0]], vertex[t[1]], vertex[t[2]]});
  return m;
}

TEST(MeshDecimation, MeetsTheBudgetKeepsTissuesAndStaysClosed) {
  const imt::SurfaceMesh full = fine_sphere();
  ASSERT_GT(full.triangle_count(), 20000u);
  DecimationOptions o;
  o.target_triangles = full.triangle_count() / 10;
  o.manifold_runs = 3;
  const DecimatedMesh d = decimate(full, o);
  EXPECT_EQ(d.nonmanifold_vertices, 0u);
  EXPECT_LE(d.triangles.size(), o.target_triangles);
  EXPECT_GE(d.triangles.size(), o.target_triangles * 8 / 10);
  // Every output vertex is an input vertex; every triangle lies in one tissue.
  std::set<std::uint8_t> labels_in, labels_out;
  for (std::size_t t = 0; t < full.triangle_count(); ++t)
    labels_in.insert(imt::triangle_label(full, t));
  for (const auto& t : d.triangles) {
    EXPECT_EQ(d.labels[t[0]], d.labels[t[1]]);
    EXPECT_EQ(d.labels[t[0]], d.labels[t[2]]);
    labels_out.insert(d.labels[t[0]]);
  }
  EXPECT_EQ(labels_in, labels_out);
  for (std::size_t v = 0; v < d.origin.size(); ++v) ASSERT_LT(d.origin[v], full.vertex_count());
  // A copy keeps the tissue of the triangles around its source vertex.
  const imt::MeshTopology topo = imt::analyse_topology(welded(full, d));
  EXPECT_TRUE(topo.closed_oriented_manifold()) << topology_text(topo);
  // Close to the full surface: within a voxel (0.5 mm) everywhere, far less on average.
  const imt::SurfaceMesh out = decimated_surface(full, d);
  const SurfaceDeviation dev =
      measure_deviation({&full.positions, &full.triangles}, {&out.positions, &out.triangles});
  EXPECT_LT(dev.max_mm(), 0.5);
  EXPECT_LT(dev.mean_mm(), 0.1);
  EXPECT_EQ(count_triangle_defects(out).zero_area, 0u);
}

TEST(MeshDecimation, ErrorBoundStopsEarlier) {
  const imt::SurfaceMesh full = fine_sphere();
  DecimationOptions tight, loose;
  tight.max_error_mm = 0.005;
  loose.max_error_mm = 0.2;
  const DecimatedMesh a = decimate(full, tight), b = decimate(full, loose);
  EXPECT_GT(a.triangles.size(), b.triangles.size());
  EXPECT_LE(a.meshopt_error_mm, 0.005 * 1.0001);
  EXPECT_LE(b.meshopt_error_mm, 0.2 * 1.0001);
  EXPECT_LT(b.triangles.size(), full.triangle_count() / 4);
}

TEST(MeshDecimation, SlabsOnTwoThreadsMatchOneCall) {
  const imt::SurfaceMesh full = fine_sphere();
  DecimationOptions one, two;
  one.target_triangles = two.target_triangles = full.triangle_count() / 8;
  one.threads = 1;
  two.threads = 2;
  one.manifold_runs = two.manifold_runs = 3;
  two.parallel_min_triangles = 1000;  // force the slab path on this small mesh
  const DecimatedMesh a = decimate(full, one), b = decimate(full, two);
  EXPECT_EQ(b.slabs, 2);
  EXPECT_EQ(a.slabs, 1);
  EXPECT_LE(b.triangles.size(), two.target_triangles);
  EXPECT_GE(b.triangles.size(), two.target_triangles * 8 / 10);
  const imt::MeshTopology topo = imt::analyse_topology(welded(full, b));
  EXPECT_TRUE(topo.closed_oriented_manifold()) << topology_text(topo);
  const imt::SurfaceMesh sa = decimated_surface(full, a), sb = decimated_surface(full, b);
  const SurfaceDeviation da =
      measure_deviation({&full.positions, &full.triangles}, {&sa.positions, &sa.triangles});
  const SurfaceDeviation db =
      measure_deviation({&full.positions, &full.triangles}, {&sb.positions, &sb.triangles});
  EXPECT_LT(db.mean_mm(), 2.0 * da.mean_mm() + 1e-3);
}

TEST(MeshDecimation, FurtherLevelsKeepShrinking) {
  const imt::SurfaceMesh full = fine_sphere();
  DecimationOptions o;
  o.target_triangles = 4000;
  o.manifold_runs = 3;
  const DecimatedMesh l1 = decimate(full, o);
  o.target_triangles = 1000;
  const DecimatedMesh l2 = decimate_further(full, l1, o);
  EXPECT_LE(l2.triangles.size(), 1000u);
  EXPECT_LT(l2.triangles.size(), l1.triangles.size());
  for (const auto& t : l2.triangles) EXPECT_EQ(l2.labels[t[0]], l2.labels[t[1]]);
  const imt::MeshTopology topo = imt::analyse_topology(welded(full, l2));
  EXPECT_TRUE(topo.closed_oriented_manifold()) << topology_text(topo);
}

TEST(MeshDecimation, OneRunCountsWhatItLeavesNonManifold) {
  const imt::SurfaceMesh full = fine_sphere();
  DecimationOptions o;
  o.target_triangles = 1000;
  const DecimatedMesh d = decimate(full, o);
  EXPECT_EQ(d.rounds, 1);
  // The count in the report is the count in the mesh (vertices on edges of > 2 triangles).
  const imt::SurfaceMesh w = welded(full, d);
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  for (const auto& t : w.triangles)
    for (int k = 0; k < 3; ++k) ++edges[std::minmax(t[k], t[(k + 1) % 3])];
  std::set<std::uint32_t> on_bad;
  for (const auto& [e, n] : edges)
    if (n > 2) on_bad.insert({e.first, e.second});
  EXPECT_EQ(d.nonmanifold_vertices, on_bad.size());
  EXPECT_EQ(imt::analyse_topology(w).boundary_edges, 0u) << "closed, whatever else";
}

TEST(MeshDecimation, NeedsATarget) {
  EXPECT_THROW(DecimationOptions{}.validate(), Error);
  DecimationOptions o;
  o.max_error_mm = -1.0;
  EXPECT_THROW(o.validate(), Error);
}

}  // namespace
}  // namespace tsf::exporter
