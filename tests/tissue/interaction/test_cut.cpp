// Cutting through every layer: a blade swept through a clamped block separates it into exactly two
// lattice pieces; the free one falls while the clamped one stays; the render surface stays a
// closed manifold whose two pieces follow their own lattice pieces.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "interaction_test_helpers.h"
#include "tsf/interaction/lattice_components.h"

namespace tsf::interaction {
namespace {

using test::block_options;
using test::block_volume;

/// A blade whose thickness axis (local z) points along world x, cutting the plane x = x0.
Tool cross_blade() {
  Tool blade;
  blade.shape = collision::ToolShape::kBlade;
  blade.half_extents_mm = {9.0, 9.0, 0.5};  // length (world z), depth (world y), thickness
  return blade;
}
const Rotation kBladeAcrossX = Rotation::about_axis({0, 1, 0}, M_PI / 2);

TEST(Cut, ABladeThroughABlockMakesTwoPiecesThatMoveIndependently) {
  TissueModel model(block_volume({44, 14, 14}, {2, 2, 2}, {42, 12, 12}), block_options(4.0));
  ASSERT_EQ(model.lattice_components(), 1u);
  EXPECT_TRUE(test::closed_manifold(model.deformed_mesh()));

  const Tool blade = cross_blade();
  // Sweep from above the block to below it through x = 23.
  model.apply_tool(blade, {{23.0, 7.0, 24.0}, kBladeAcrossX}, ToolMode::kCut);
  const EditReport r = model.apply_tool(blade, {{23.0, 7.0, -10.0}, kBladeAcrossX}, ToolMode::kCut);
  EXPECT_TRUE(r.edited);
  EXPECT_GT(r.springs_broken + r.nodes_deleted, 0u);
  const LatticeComponents pieces = find_lattice_components(model.solver().lattice());
  ASSERT_EQ(pieces.count(), 2u) << "the cut must separate the lattice into exactly two pieces";
  EXPECT_TRUE(pieces.anchored[0] != pieces.anchored[1]) << "one piece clamped, one free";

  // The render surface: closed, and in two pieces.
  {
    const imt::SurfaceMesh mesh = model.deformed_mesh();
    EXPECT_TRUE(test::closed_manifold(mesh));
    EXPECT_EQ(imt::analyse_topology(mesh).components, 2u);
  }

  // Let it fall for 30 ms.
  for (int frame = 0; frame < 15; ++frame) model.advance(2e-3);
  ASSERT_TRUE(test::all_finite(model));
  const auto u = model.solver().displacements();
  const crms::Lattice& l = model.solver().lattice();
  double free_min_drop = 1e9, clamped_max = 0;
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    if (!l.alive(n)) continue;
    const int piece = pieces.label[static_cast<std::size_t>(n)];
    if (pieces.anchored[static_cast<std::size_t>(piece)])
      clamped_max = std::max(clamped_max, double(length(u[static_cast<std::size_t>(n)])));
    else
      free_min_drop = std::min(free_min_drop, -double(u[static_cast<std::size_t>(n)].z));
  }
  // Free fall for 30 ms: ½·g·t² = 4.4 mm (minus the first frames' settling).
  EXPECT_GT(free_min_drop, 2.5) << "every node of the free piece falls";
  EXPECT_LT(clamped_max, 2.0) << "the clamped piece only sags";

  // Every surface vertex of the free piece (rest x > 23) fell with it; none stayed behind on
  // the clamped piece's cut face, and none of the clamped piece went down with the free one.
  const auto& rest = model.surface().positions();
  const auto& now = model.coupler().positions();
  double free_vertex_min_drop = 1e9, clamped_vertex_max_drop = 0;
  for (std::uint32_t s = 1; s < model.surface().vertex_slot_count(); ++s) {
    if (!model.surface().vertex_live(s)) continue;
    const double drop = rest[s].z - now[s].z;
    if (rest[s].x > 23.0f)
      free_vertex_min_drop = std::min(free_vertex_min_drop, drop);
    else
      clamped_vertex_max_drop = std::max(clamped_vertex_max_drop, drop);
  }
  EXPECT_GT(free_vertex_min_drop, 2.0);
  EXPECT_LT(clamped_vertex_max_drop, 2.0);
  EXPECT_TRUE(test::closed_manifold(model.deformed_mesh()));
}

TEST(Cut, AShallowCutBreaksSpringsButKeepsOnePiece) {
  TissueModel model(block_volume({44, 14, 14}, {2, 2, 2}, {42, 12, 12}), block_options(4.0, 0));
  const Tool blade = cross_blade();
  // Down to z = 6 only (the block spans 2..12): a notch, not a separation.
  model.apply_tool(blade, {{23.0, 7.0, 24.0}, kBladeAcrossX}, ToolMode::kCut);
  const EditReport r = model.apply_tool(blade, {{23.0, 7.0, 15.0}, kBladeAcrossX}, ToolMode::kCut);
  EXPECT_TRUE(r.edited);
  EXPECT_GT(r.springs_broken + r.nodes_deleted, 0u);
  EXPECT_EQ(model.lattice_components(), 1u);
  EXPECT_TRUE(test::closed_manifold(model.deformed_mesh()));
}

}  // namespace
}  // namespace tsf::interaction
