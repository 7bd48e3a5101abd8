#include <gtest/gtest.h>

#include "tsf/segment/connected_components.h"

namespace tsf::segment {
namespace {

TEST(ConnectedComponents, DiagonalNeighboursJoinOnlyWithFullConnectivity) {
  // 4×4×4: a 2×2×2 block at the origin and a voxel touching it only by a corner; a far voxel.
  const std::array<std::size_t, 3> dims{4, 4, 4};
  std::vector<unsigned char> mask(64, 0);
  auto at = [](std::size_t i, std::size_t j, std::size_t k) { return i + 4 * (j + 4 * k); };
  for (std::size_t k = 0; k < 2; ++k)
    for (std::size_t j = 0; j < 2; ++j)
      for (std::size_t i = 0; i < 2; ++i) mask[at(i, j, k)] = 1;
  mask[at(2, 2, 2)] = 1;  // corner contact with (1,1,1)
  mask[at(3, 0, 3)] = 1;  // alone

  const ComponentLabels faces = label_connected_components(mask.data(), dims, false);
  ASSERT_EQ(faces.count(), 3u);
  EXPECT_EQ(faces.sizes[faces.largest()], 8u);
  EXPECT_NE(faces.labels[at(2, 2, 2)], faces.labels[at(0, 0, 0)]);

  const ComponentLabels full = label_connected_components(mask.data(), dims, true);
  ASSERT_EQ(full.count(), 2u);
  EXPECT_EQ(full.sizes[full.largest()], 9u);
  EXPECT_EQ(full.labels[at(2, 2, 2)], full.labels[at(0, 0, 0)]);
  EXPECT_EQ(full.labels[at(1, 2, 3)], 0u);  // background
}

TEST(ConnectedComponents, EmptyMaskHasNoComponents) {
  std::vector<unsigned char> mask(27, 0);
  const ComponentLabels c = label_connected_components(mask.data(), {3, 3, 3}, true);
  EXPECT_EQ(c.count(), 0u);
  EXPECT_EQ(c.largest(), 0u);
}

}  // namespace
}  // namespace tsf::segment
