// Ablation removes what the tool sweeps: within 2 % of the analytic swept volume inside solid
// tissue, for a ball dragged along a line (a capsule) and for the wand (a capsule swept sideways).
#include <gtest/gtest.h>

#include <cmath>

#include "interaction_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/interaction/tool_stroke.h"

namespace tsf::interaction {
namespace {

using test::block_options;
using test::block_volume;

TissueModel solid_block() {
  auto o = block_options(-1, 0.0);
  o.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, 3.0});
  };
  return TissueModel(block_volume({40, 40, 40}, {1, 1, 1}, {39, 39, 39}), o);
}

// The stroke's memory of applied weights (open addressing): every voxel keeps its own weight
// through the table's growth, voxel indices that collide in the low bits included, a voxel not
// reached reads 0, and after clear() nothing is remembered.
TEST(AblationVolume, TheStrokesMemoryKeepsEachVoxelsWeightThroughGrowth) {
  AppliedWeights applied;
  auto voxel = [](std::size_t i) { return i * 65536 + (i % 7); };  // low bits repeat
  for (std::size_t i = 0; i < 50000; ++i) applied[voxel(i)] = static_cast<float>(i % 1000) + 0.5f;
  EXPECT_EQ(applied.size(), 50000u);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < 50000; ++i)
    wrong += applied[voxel(i)] != static_cast<float>(i % 1000) + 0.5f;
  EXPECT_EQ(wrong, 0u);
  EXPECT_EQ(applied.size(), 50000u) << "reading a remembered voxel adds nothing";
  EXPECT_EQ(applied[3], 0.0f);
  EXPECT_EQ(applied.size(), 50001u);
  applied.clear();
  EXPECT_EQ(applied.size(), 0u);
  EXPECT_EQ(applied[voxel(17)], 0.0f);
}

TEST(AblationVolume, ABallDraggedThroughSolidTissueRemovesItsCapsule) {
  TissueModel model = solid_block();
  Tool ball;
  ball.radius_mm = 6.0;  // the fall-off band biases small radii up by ~h²/r² (docs/deform-cut.md)
  const Vec3d a{13, 20, 20}, b{27, 20, 20};
  double removed = 0;
  removed += model.apply_tool(ball, {a, {}}, ToolMode::kAblate).removed_mm3;
  // Three moves along the line (the sweep continues from the previous pose).
  for (int s = 1; s <= 3; ++s)
    removed += model.apply_tool(ball, {a + (b - a) * (s / 3.0), {}}, ToolMode::kAblate).removed_mm3;
  const double r = 6.0, len = length(b - a);
  const double expected = M_PI * r * r * len + 4.0 / 3.0 * M_PI * r * r * r;
  EXPECT_NEAR(removed, expected, 0.02 * expected);
  EXPECT_NEAR(model.totals().removed_mm3, removed, 1e-6 * expected);
  ASSERT_TRUE(test::all_finite(model));
  EXPECT_TRUE(test::closed_manifold(model.deformed_mesh()));
}

TEST(AblationVolume, TheWandSweptSidewaysRemovesItsSweptVolume) {
  TissueModel model = solid_block();
  Tool wand;
  wand.shape = collision::ToolShape::kCapsule;
  wand.radius_mm = 3.0;
  wand.half_length_mm = 4.0;  // axis along the pose's z
  const double sweep = 10.0;
  double removed = model.apply_tool(wand, {{15, 20, 20}, {}}, ToolMode::kAblate).removed_mm3;
  removed += model.apply_tool(wand, {{15 + sweep, 20, 20}, {}}, ToolMode::kAblate).removed_mm3;
  const double r = 3.0, l = 8.0;
  // Capsule + the slab its silhouette (2r × l rectangle plus a disc) sweeps.
  const double expected =
      M_PI * r * r * l + 4.0 / 3.0 * M_PI * r * r * r + sweep * (2 * r * l + M_PI * r * r);
  EXPECT_NEAR(removed, expected, 0.02 * expected);
  EXPECT_TRUE(test::closed_manifold(model.deformed_mesh()));
}

TEST(AblationVolume, AToolInTheAirRemovesNothing) {
  TissueModel model = solid_block();
  Tool ball;
  ball.radius_mm = 2.0;
  const EditReport r = model.apply_tool(ball, {{100, 100, 100}, {}}, ToolMode::kAblate);
  EXPECT_FALSE(r.tissue_near);
  EXPECT_FALSE(r.edited);
  EXPECT_EQ(r.removed_mm3, 0.0);
}

TEST(AblationVolume, ModesTheToolCannotRunAreRejected) {
  TissueModel model = solid_block();
  Tool ball;
  EXPECT_THROW(model.apply_tool(ball, {{20, 20, 20}, {}}, ToolMode::kCut), tsf::Error);
  Tool blade;
  blade.shape = collision::ToolShape::kBlade;
  EXPECT_THROW(model.apply_tool(blade, {{20, 20, 20}, {}}, ToolMode::kAblate), tsf::Error);
  Tool bad;
  bad.radius_mm = -1;
  EXPECT_THROW(model.apply_tool(bad, {{20, 20, 20}, {}}, ToolMode::kPress), tsf::Error);
}

}  // namespace
}  // namespace tsf::interaction
