// Per-tissue parts partition the surface (label_partition.h).
#include <gtest/gtest.h>

#include <numeric>

#include "export_test_helpers.h"
#include "tsf/export/label_partition.h"

namespace tsf::exporter {
namespace {
using namespace test;

TEST(LabelPartition, PartsCoverEveryTriangleExactlyOnce) {
  const imt::SurfaceMesh mesh = labelled_sphere(oblique_geometry());
  const auto parts = partition_by_label(mesh);
  ASSERT_EQ(parts.size(), 3u);
  std::vector<int> seen(mesh.triangle_count(), 0);
  std::uint8_t previous = 0;
  for (const LabelPart& part : parts) {
    EXPECT_GT(part.label, previous) << "parts in ascending label order";
    previous = part.label;
    ASSERT_EQ(part.triangle_ids.size(), part.triangles.size());
    EXPECT_TRUE(std::is_sorted(part.triangle_ids.begin(), part.triangle_ids.end()));
    for (std::size_t i = 0; i < part.triangle_ids.size(); ++i) {
      const std::uint32_t t = part.triangle_ids[i];
      ++seen[t];
      EXPECT_EQ(imt::triangle_label(mesh, t), part.label);
      // Re-indexed corners are the mesh's corners.
      for (std::size_t k = 0; k < 3; ++k)
        EXPECT_EQ(part.vertices[part.triangles[i][k]], mesh.triangles[t][k]);
    }
  }
  for (std::size_t t = 0; t < seen.size(); ++t) ASSERT_EQ(seen[t], 1) << "triangle " << t;
}

TEST(LabelPartition, BorderVerticesAreSharedOnlyAtTissueBorders) {
  const imt::SurfaceMesh mesh = labelled_sphere(oblique_geometry());
  const auto parts = partition_by_label(mesh);
  std::vector<int> uses(mesh.vertex_count(), 0);
  std::size_t total = 0;
  for (const LabelPart& part : parts) {
    total += part.vertices.size();
    for (std::uint32_t v : part.vertices) ++uses[v];
  }
  std::size_t shared = 0;
  for (int u : uses) {
    EXPECT_GE(u, 1) << "every vertex of a closed surface is in a part";
    shared += u > 1;
  }
  EXPECT_GT(shared, 0u) << "three tissues meet along borders";
  EXPECT_LT(shared, mesh.vertex_count() / 5) << "only border vertices are duplicated";
  EXPECT_EQ(
      total, mesh.vertex_count() + [&] {
        std::size_t extra = 0;
        for (int u : uses) extra += static_cast<std::size_t>(u - 1);
        return extra;
      }());
}

TEST(LabelPartition, WholeMeshPartIsTheIdentity) {
  const imt::SurfaceMesh mesh = labelled_sphere(oblique_geometry());
  const LabelPart whole = whole_mesh_part(mesh, 0);
  EXPECT_EQ(whole.triangles, mesh.triangles);
  ASSERT_EQ(whole.vertices.size(), mesh.vertex_count());
  EXPECT_EQ(whole.vertices.back(), mesh.vertex_count() - 1);
}

TEST(LabelPartition, EmptyMeshHasNoParts) {
  EXPECT_TRUE(partition_by_label(imt::SurfaceMesh{}).empty());
}

}  // namespace
}  // namespace tsf::exporter
