// From voxel edits to lattice topology: springs break exactly where the voxels between their nodes
// were cut through, nodes go when their cells empty, and nothing else changes.
#include <gtest/gtest.h>

#include <algorithm>

#include "interaction_test_helpers.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/interaction/lattice_components.h"
#include "tsf/interaction/lattice_topology_edit.h"
#include "tsf/volume/volume_edits.h"

namespace tsf::interaction {
namespace {

struct Scene {
  VoxelVolume volume;
  crms::Lattice lattice;
};

Scene block() {
  Scene s{test::block_volume({44, 14, 14}, {2, 2, 2}, {42, 12, 12}), {}};
  crms::VolumeLatticeOptions o;
  o.node_spacing_voxels = 2;
  s.lattice = crms::build_lattice_from_volume(s.volume, o);
  return s;
}

LatticeTopologyEdit edit_box(Scene& s, const Vec3d& lo, const Vec3d& hi) {
  DensitySnapshot before;
  before.capture(s.volume, voxels_near_box(s.volume.geometry(), lo, hi, 2.0));
  const VoxelBox changed = set_box(s.volume, lo, hi, 0.0f);
  return find_lattice_topology_edit(s.volume, before, changed, s.lattice, 2, 0.125f, 0.5f);
}

TEST(LatticeTopologyEdit, ASlabCutBreaksExactlyTheSpringsAcrossIt) {
  Scene s = block();
  // Clear voxel layer x = 23 (centres 22.5..23.5 mm): the bridge of nodes x-index 11 → 12.
  const LatticeTopologyEdit e = edit_box(s, {22.5, -1, -1}, {23.5, 99, 99});
  ASSERT_FALSE(e.broken_springs.empty());
  const crms::LatticeGeometry& g = s.lattice.geometry();
  // Only the partly filled cells along the block's edges in the slab's layers may empty.
  for (std::int64_t n : e.deleted_nodes) {
    const Int3 c = g.coordinates(n);
    EXPECT_TRUE(c.x == 11 || c.x == 12) << "node " << n;
    EXPECT_TRUE(c.y == 1 || c.y == 6 || c.z == 1 || c.z == 6) << "an interior node was deleted";
  }
  auto deleted = [&](std::int64_t n) {
    return std::find(e.deleted_nodes.begin(), e.deleted_nodes.end(), n) != e.deleted_nodes.end();
  };
  std::size_t across = 0;
  for (std::int64_t n = 0; n < g.node_count(); ++n) {
    const Int3 c = g.coordinates(n);
    const int d = crms::make_direction(0, +1);
    if (c.x == 11 && s.lattice.link(n, d) && !deleted(n) && !deleted(s.lattice.neighbour(n, d)))
      ++across;
  }
  EXPECT_EQ(e.broken_springs.size(), across) << "every +x spring from layer 11 crosses the slab";
  for (const crms::SpringRef& r : e.broken_springs) {
    EXPECT_EQ(g.coordinates(r.node).x, 11);
    EXPECT_EQ(r.direction, crms::make_direction(0, +1));
  }
  for (const crms::SpringRef& r : e.broken_springs) s.lattice.break_spring(r.node, r.direction);
  for (std::int64_t n : e.deleted_nodes) s.lattice.set_alive(n, false);
  EXPECT_EQ(find_lattice_components(s.lattice).count(), 2u);
}

TEST(LatticeTopologyEdit, AnEmptiedCellDeletesItsNode) {
  Scene s = block();
  const crms::LatticeGeometry& g = s.lattice.geometry();
  const std::int64_t n = g.index(5, 3, 3);  // voxels [10,12)×[6,8)×[6,8)
  ASSERT_TRUE(s.lattice.alive(n));
  const LatticeTopologyEdit e = edit_box(s, {9.5, 5.5, 5.5}, {11.5, 7.5, 7.5});
  ASSERT_EQ(e.deleted_nodes.size(), 1u);
  EXPECT_EQ(e.deleted_nodes[0], n);
  EXPECT_NEAR(cell_occupancy(s.volume, g, n, 2), 0.0f, 1e-6f);
}

TEST(LatticeTopologyEdit, AnEditThatCutsNothingThroughBreaksNothing) {
  Scene s = block();
  // A notch two voxels deep into the top face: columns below it still carry every spring.
  const LatticeTopologyEdit e = edit_box(s, {19.5, 3.5, 10.5}, {26.5, 10.5, 12.5});
  EXPECT_TRUE(e.broken_springs.empty() || e.broken_springs.size() < 10u);
  for (const crms::SpringRef& r : e.broken_springs)
    EXPECT_GE(s.lattice.geometry().coordinates(r.node).z, 5) << "only springs in the notch";
  // The block's outer face (partly filled cells) is left alone by an edit beside it.
  Scene t = block();
  const LatticeTopologyEdit side = edit_box(t, {2.5, 5.5, 5.5}, {3.5, 6.5, 6.5});
  EXPECT_TRUE(side.deleted_nodes.empty());
}

}  // namespace
}  // namespace tsf::interaction
