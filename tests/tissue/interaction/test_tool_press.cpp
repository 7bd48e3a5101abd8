// Pressing a sphere into tissue: no node and no coupled vertex ends inside the tool, the tool
// feels a force that pushes it out and grows with depth, and lifting the tool lets go.
#include <gtest/gtest.h>

#include <cmath>

#include "interaction_test_helpers.h"

namespace tsf::interaction {
namespace {

using test::block_options;
using test::block_volume;
using test::deepest_inside;

TissueModelOptions press_options() {
  auto o = block_options(-1, 0.0);
  o.solver.materials[0].youngs_modulus_pa = 50e3;  // soft: a longer stable step, fewer steps
  o.solver.materials[0].viscosity_pa_s = 10.0;     // settles within a few ms of simulated time
  o.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, 3.0});
  };
  return o;
}

TEST(ToolPress, NothingEndsInsideTheToolAndTheForceGrowsWithDepth) {
  // 20 × 20 × 16 mm block on an anchored bottom; a 5 mm ball pressed into the top (z = 18),
  // on the lattice's symmetry axis, up to 1 mm deep. The top node layer sits at the centres of
  // the partly filled surface cells, half a spacing above the surface, so 1 mm compresses the
  // top cells by ¾ of the 2 mm spacing; deeper presses fold them (docs/deform-cut.md).
  TissueModel model(block_volume({24, 24, 20}, {2, 2, 2}, {22, 22, 18}), press_options());
  Tool ball;
  ball.shape = collision::ToolShape::kSphere;
  ball.radius_mm = 5.0;
  double previous = 0;
  for (double depth : {0.2, 0.4, 0.6, 0.8, 1.0}) {
    const ToolPose pose{{12.5, 12.5, 18.0 + 5.0 - depth}, {}};
    model.apply_tool(ball, pose, ToolMode::kPress);
    for (int frame = 0; frame < 10; ++frame) model.advance(1e-3);
    ASSERT_TRUE(test::all_finite(model));
    const collision::WorldTool placed = place_tool(ball, pose);
    double node_depth = 0;
    const double vertex_depth = deepest_inside(model, placed, &node_depth);
    EXPECT_LE(node_depth, 1e-3) << "a node ended inside the ball at depth " << depth;
    EXPECT_LE(vertex_depth, 2e-3) << "a coupled vertex ended inside the ball at depth " << depth;
    const collision::ContactForce& c = model.contact();
    EXPECT_GT(c.nodes_held, 0u);
    // The tissue pushes the ball up (+z), harder the deeper it goes.
    EXPECT_GT(c.force_un.z, 0.0) << "depth " << depth;
    EXPECT_LT(std::fabs(c.force_un.x), 0.2 * c.force_un.z) << "symmetric press, depth " << depth;
    EXPECT_GT(c.force_un.z, previous * 1.05) << "force must grow with depth (" << depth << " mm)";
    previous = c.force_un.z;
  }
  // Lift the ball: nothing is held, the tissue springs back.
  model.release_tool();
  EXPECT_EQ(model.contact().nodes_held, 0u);
  for (int frame = 0; frame < 20; ++frame) model.advance(1e-3);
  double max_u = 0;
  for (const Vec3f& u : model.solver().displacements()) max_u = std::max(max_u, double(length(u)));
  EXPECT_LT(max_u, 0.5) << "the tissue must recover once the tool is lifted";
}

TEST(ToolPress, TheLatestContactIsReadableFromAnotherThread) {
  TissueModel model(block_volume({24, 24, 14}, {2, 2, 2}, {22, 22, 12}), press_options());
  Tool ball;
  ball.radius_mm = 3.0;
  model.apply_tool(ball, {{12.5, 12.5, 14.5}, {}}, ToolMode::kPress);
  model.advance(1e-3);
  const collision::ContactForce copy = model.latest_contact();
  EXPECT_EQ(copy.nodes_held, model.contact().nodes_held);
  EXPECT_EQ(copy.force_un.z, model.contact().force_un.z);
}

}  // namespace
}  // namespace tsf::interaction
