// NodeNeighbourhood's lookup by lattice coordinates: the dense index over the gathered nodes' box
// and the binary search it falls back to for sparse boxes must agree with the search by node
// index for every coordinate in and around the box, including nodes that were not gathered.
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "tsf/collision/node_neighbourhood.h"

namespace tsf::collision {
namespace {

std::int64_t index_of(const Int3& dims, int i, int j, int k) {
  return i + static_cast<std::int64_t>(dims.x) * (j + static_cast<std::int64_t>(dims.y) * k);
}

/// Every coordinate of [lo − 1, hi + 1]; `in_window` of the gathered nodes lie in [lo, hi].
void expect_lookups_agree(const NodeNeighbourhood& nb, const Int3& dims, const Int3& lo,
                          const Int3& hi, std::size_t in_window) {
  std::size_t found = 0;
  for (int k = lo.z - 1; k <= hi.z + 1; ++k)
    for (int j = lo.y - 1; j <= hi.y + 1; ++j)
      for (int i = lo.x - 1; i <= hi.x + 1; ++i) {
        const bool in_lattice =
            i >= 0 && j >= 0 && k >= 0 && i < dims.x && j < dims.y && k < dims.z;
        const std::ptrdiff_t expected = in_lattice ? nb.find(index_of(dims, i, j, k)) : -1;
        const std::ptrdiff_t got = nb.find(i, j, k, dims);
        ASSERT_EQ(got, expected) << i << "," << j << "," << k;
        found += got >= 0;
      }
  EXPECT_EQ(found, in_window);
}

TEST(NodeNeighbourhood, DenseIndexAgreesWithTheSearchByNodeIndex) {
  const Int3 dims{20, 16, 12};
  NodeNeighbourhood nb;
  // A 5×4×3 block with holes (nodes not gathered read as absent).
  for (int k = 4; k < 7; ++k)
    for (int j = 3; j < 7; ++j)
      for (int i = 10; i < 15; ++i)
        if ((i + 2 * j + 3 * k) % 4 != 0) nb.nodes.push_back(index_of(dims, i, j, k));
  nb.build_index(dims);
  expect_lookups_agree(nb, dims, {10, 3, 4}, {14, 6, 6}, nb.size());
}

TEST(NodeNeighbourhood, SparseBoxesFallBackToTheSearch) {
  const Int3 dims{100, 100, 100};
  NodeNeighbourhood nb;
  nb.nodes = {index_of(dims, 1, 2, 3), index_of(dims, 2, 2, 3), index_of(dims, 90, 95, 99)};
  nb.build_index(dims);
  EXPECT_EQ(nb.find(1, 2, 3, dims), 0);
  EXPECT_EQ(nb.find(2, 2, 3, dims), 1);
  EXPECT_EQ(nb.find(90, 95, 99, dims), 2);
  EXPECT_EQ(nb.find(3, 2, 3, dims), -1);
  EXPECT_EQ(nb.find(50, 50, 50, dims), -1);
  expect_lookups_agree(nb, dims, {0, 1, 2}, {3, 3, 4}, 2);
}

TEST(NodeNeighbourhood, ClearForgetsTheIndex) {
  const Int3 dims{8, 8, 8};
  NodeNeighbourhood nb;
  nb.nodes = {index_of(dims, 1, 1, 1), index_of(dims, 2, 1, 1)};
  nb.build_index(dims);
  ASSERT_EQ(nb.find(2, 1, 1, dims), 1);
  nb.clear();
  EXPECT_EQ(nb.find(2, 1, 1, dims), -1);
  nb.nodes = {index_of(dims, 5, 5, 5)};  // refilled without an index: the search answers
  EXPECT_EQ(nb.find(5, 5, 5, dims), 0);
  EXPECT_EQ(nb.find(1, 1, 1, dims), -1);
}

}  // namespace
}  // namespace tsf::collision
