// Closed per-tissue bodies: every body a closed, consistently oriented 2-manifold, neighbours
// sharing their interface exactly, volumes that match the voxels, also for random label soups
// and after decimation.
#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>

#include "export_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/export/mesh_decimation.h"
#include "tsf/export/tissue_bodies.h"
#include "tsf/imt/mesh_smoothing.h"
#include "tsf/imt/mesh_topology.h"

namespace tsf::exporter {
namespace {
using namespace test;

/// Triangles as sorted corner-position keys (orientation dropped).
std::multiset<std::array<float, 9>> unoriented(const imt::SurfaceMesh& m) {
  std::multiset<std::array<float, 9>> out;
  for (const auto& t : m.triangles) {
    std::array<Vec3f, 3> p{m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]};
    std::sort(p.begin(), p.end(), [](const Vec3f& a, const Vec3f& b) {
      return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z);
    });
    out.insert({p[0].x, p[0].y, p[0].z, p[1].x, p[1].y, p[1].z, p[2].x, p[2].y, p[2].z});
  }
  return out;
}

/// Three tissues side by side in a block touching the volume's border, a ball of a fourth
/// inside, and a smooth density ramp on the outside.
VoxelVolume layered_block() {
  VoxelVolume v(cube_geometry({24, 20, 18}, 0.8));
  for (int k = 0; k < 18; ++k)
    for (int j = 0; j < 20; ++j)
      for (int i = 0; i < 24; ++i) {
        const std::size_t n = v.index(i, j, k);
        const bool inside = i >= 2 && i < 24 && j >= 3 && j < 17 && k >= 2 && k < 15;
        v.density_data()[n] = inside ? 1.0f : 0.0f;
        if (!inside) continue;
        const double di = i - 12.0, dj = j - 10.0, dk = k - 8.0;
        v.label_data()[n] = di * di + dj * dj + dk * dk < 16.0 ? kLabelTumour
                            : i < 9                            ? kLabelCorticalBone
                            : i < 16                           ? kLabelSoftTissue
                                                               : kLabelMucosa;
      }
  v.mark_all_modified();
  return v;
}

void expect_bodies_closed_and_shared(const InterfaceComplex& c) {
  const std::vector<std::uint8_t> tissues = c.tissues();
  ASSERT_FALSE(tissues.empty());
  std::map<std::uint8_t, imt::SurfaceMesh> bodies;
  for (std::uint8_t l : tissues) {
    bodies[l] = body_mesh(c, l);
    const imt::MeshTopology topo = imt::analyse_topology(bodies[l]);
    EXPECT_TRUE(topo.closed_oriented_manifold())
        << tissue_label_name(l) << ": " << topology_text(topo);
    EXPECT_GT(imt::enclosed_volume(bodies[l]), 0.0) << tissue_label_name(l) << " faces inwards";
  }
  // Every interface triangle between two tissues is in both bodies.
  for (std::size_t t = 0; t < c.triangles.size(); ++t) {
    EXPECT_LT(c.behind[t], c.front[t]);
    EXPECT_NE(c.behind[t], kAirRegion);
  }
  for (std::size_t a = 0; a < tissues.size(); ++a)
    for (std::size_t b = a + 1; b < tissues.size(); ++b) {
      InterfaceComplex only;
      only.positions = c.positions;
      for (std::size_t t = 0; t < c.triangles.size(); ++t)
        if (c.behind[t] == tissues[a] && c.front[t] == tissues[b]) {
          only.triangles.push_back(c.triangles[t]);
          only.behind.push_back(c.behind[t]);
          only.front.push_back(c.front[t]);
        }
      if (only.triangles.empty()) continue;
      // The interface seen from either side is the same set of triangles.
      const auto from_a = unoriented(body_mesh(only, tissues[a]));
      const auto from_b = unoriented(body_mesh(only, tissues[b]));
      EXPECT_EQ(from_a, from_b);
      const auto whole_a = unoriented(bodies[tissues[a]]);
      for (const auto& k : from_a) EXPECT_EQ(whole_a.count(k), 1u);
    }
}

TEST(TissueBodies, EveryTissueIsAClosedManifoldAndNeighboursShareTheirInterface) {
  const VoxelVolume v = layered_block();
  const InterfaceComplex c = tissue_interfaces(v, 0.5f);
  EXPECT_EQ(c.tissues(), (std::vector<std::uint8_t>{kLabelSoftTissue, kLabelMucosa,
                                                    kLabelCorticalBone, kLabelTumour}));
  expect_bodies_closed_and_shared(c);
  // Volumes: about the voxel count of each tissue (the surface runs through voxel centres and
  // midpoints, so a body is about its voxels minus half a voxel on its outer faces).
  double total = 0;
  for (std::uint8_t l : c.tissues()) total += imt::enclosed_volume(body_mesh(c, l));
  const double voxel = 0.8 * 0.8 * 0.8;
  const double block = 22.0 * 14.0 * 13.0 * voxel;
  EXPECT_GT(total, 0.8 * block);
  EXPECT_LT(total, 1.0 * block);
}

TEST(TissueBodies, RandomLabelSoupsStillGiveClosedManifolds) {
  // Labels and air at random: every configuration of a tetrahedron occurs.
  std::mt19937 rng(11);
  for (int trial = 0; trial < 4; ++trial) {
    VoxelVolume v(cube_geometry({10, 9, 8}, 1.0));
    std::uniform_int_distribution<int> pick(0, 4);
    std::uniform_real_distribution<float> density(0.0f, 1.0f);
    for (std::size_t n = 0; n < v.voxel_count(); ++n) {
      const int r = pick(rng);
      v.density_data()[n] = r == 0 ? 0.2f * density(rng) : 0.5f + 0.5f * density(rng);
      v.label_data()[n] = static_cast<std::uint8_t>(r == 0 ? 0 : r);
    }
    v.mark_all_modified();
    SCOPED_TRACE("trial " + std::to_string(trial));
    expect_bodies_closed_and_shared(tissue_interfaces(v, 0.5f));
  }
}

TEST(TissueBodies, DecimatedBodiesStayClosedAndShared) {
  const VoxelVolume v = layered_block();
  const InterfaceComplex c = tissue_interfaces(v, 0.5f);
  DecimationOptions o;
  o.target_triangles = c.triangles.size() / 6;
  DecimatedMesh d;
  const InterfaceComplex dc = decimate_interfaces(c, o, &d);
  EXPECT_LE(dc.triangles.size(), o.target_triangles * 12 / 10);
  EXPECT_LT(dc.triangles.size(), c.triangles.size() / 3);
  EXPECT_EQ(d.nonmanifold_vertices, 0u);
  expect_bodies_closed_and_shared(dc);
}

TEST(TissueBodies, NothingAboveTheIsoLevelGivesNoBodies) {
  VoxelVolume v(cube_geometry({6, 6, 6}, 1.0));
  EXPECT_TRUE(tissue_interfaces(v, 0.5f).tissues().empty());
  EXPECT_THROW(tissue_interfaces(v, 0.0f), Error);
}

}  // namespace
}  // namespace tsf::exporter
