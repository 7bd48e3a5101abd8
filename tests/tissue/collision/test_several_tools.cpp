// Several tools on one tissue in the same frame (two hands): each pressing tool holds its own
// nodes and feels its own share, nothing ends inside any of them, lifting one hand leaves the
// other's contact, an ablating hand and a pressing hand act in one frame, and a tool made from a
// closed mesh presses like the shape it was made from.
#include <gtest/gtest.h>

#include <cmath>

#include "collision_test_meshes.h"
#include "tissue/interaction/interaction_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/interaction/tissue_model.h"

namespace tsf::interaction {
namespace {

TissueModelOptions held_bottom() {
  auto o = test::block_options(-1, 0.0);
  o.solver.materials[0].youngs_modulus_pa = 50e3;
  o.solver.materials[0].viscosity_pa_s = 10.0;
  o.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, 3.0});
  };
  return o;
}

Tool ball(double radius) {
  Tool t;
  t.shape = collision::ToolShape::kSphere;
  t.radius_mm = radius;
  return t;
}

/// The deepest any alive node lies inside `tool`, mm (0: none inside).
double node_depth(const TissueModel& model, const collision::WorldTool& tool) {
  double depth = 0;
  test::deepest_inside(model, tool, &depth);
  return depth;
}

TEST(SeveralTools, TwoPressingToolsEachHoldTheirNodesAndFeelTheirShare) {
  // A 40 × 20 × 16 mm block on an anchored bottom; two 4 mm balls 1 mm into its top, 20 mm
  // apart, in slots 0 and 1, in the same frames.
  TissueModel model(test::block_volume({44, 24, 20}, {2, 2, 2}, {42, 22, 18}), held_bottom());
  const Tool a = ball(4.0), b = ball(4.0);
  const ToolPose pa{{12.5, 12.5, 18.0 + 4.0 - 1.0}, {}}, pb{{32.5, 12.5, 18.0 + 4.0 - 1.0}, {}};
  for (int frame = 0; frame < 10; ++frame) {
    model.apply_tool(0, a, pa, ToolMode::kPress);
    model.apply_tool(1, b, pb, ToolMode::kPress);
    model.advance(1e-3);
  }
  ASSERT_TRUE(test::all_finite(model));
  EXPECT_LE(node_depth(model, place_tool(a, pa)), 1e-3);
  EXPECT_LE(node_depth(model, place_tool(b, pb)), 1e-3);
  const collision::ToolReaction ra = model.tool_contact(0), rb = model.tool_contact(1);
  EXPECT_GT(ra.nodes_held, 0u);
  EXPECT_GT(rb.nodes_held, 0u);
  EXPECT_GT(ra.force_un.z, 0.0);
  EXPECT_GT(rb.force_un.z, 0.0);
  // The same press at mirrored places: the same share, within 20 %.
  EXPECT_NEAR(ra.force_un.z, rb.force_un.z, 0.2 * ra.force_un.z);
  // The contact is the sum of the hands'.
  const collision::ContactForce& c = model.contact();
  EXPECT_EQ(c.nodes_held, ra.nodes_held + rb.nodes_held);
  EXPECT_NEAR(c.force_un.z, ra.force_un.z + rb.force_un.z, 1e-6 * c.force_un.z);

  // One hand lifts: the other keeps its contact; nothing stays held by the lifted one.
  model.release_tool(1);
  model.advance(1e-3);
  EXPECT_EQ(model.tool_contact(1).nodes_held, 0u);
  EXPECT_GT(model.tool_contact(0).nodes_held, 0u);
  EXPECT_EQ(model.contact().nodes_held, model.tool_contact(0).nodes_held);
  EXPECT_FALSE(model.slot_active(1));
  EXPECT_TRUE(model.slot_active(0));
}

TEST(SeveralTools, TwoToolsSqueezingTheSameTissueKeepItOutOfBoth) {
  // Two balls pressing down side by side, 5 mm apart with 3 mm radii: the tissue between them
  // is pushed out of one toward the other; none of it may end inside either.
  TissueModel model(test::block_volume({30, 24, 20}, {2, 2, 2}, {28, 22, 18}), held_bottom());
  const Tool a = ball(3.0), b = ball(3.0);
  for (double depth : {0.5, 1.0, 1.5}) {
    const ToolPose pa{{12.5, 12.5, 21.0 - depth}, {}}, pb{{17.5, 12.5, 21.0 - depth}, {}};
    model.apply_tool(0, a, pa, ToolMode::kPress);
    model.apply_tool(1, b, pb, ToolMode::kPress);
    for (int frame = 0; frame < 5; ++frame) model.advance(1e-3);
    EXPECT_LE(node_depth(model, place_tool(a, pa)), 1e-3) << depth;
    EXPECT_LE(node_depth(model, place_tool(b, pb)), 1e-3) << depth;
  }
  ASSERT_TRUE(test::all_finite(model));
}

TEST(SeveralTools, OneHandAblatesWhileTheOtherPressesInTheSameFrame) {
  TissueModel model(test::block_volume({44, 24, 20}, {2, 2, 2}, {42, 22, 18}), held_bottom());
  Tool wand;
  wand.shape = collision::ToolShape::kCapsule;
  wand.radius_mm = 1.5;
  wand.half_length_mm = 2.0;
  const Rotation along_y = Rotation::about_axis({1, 0, 0}, M_PI / 2);
  double removed = 0;
  for (int frame = 0; frame < 8; ++frame) {
    model.apply_tool(0, ball(4.0), {{32.5, 12.5, 21.0}, {}}, ToolMode::kPress);
    const EditReport e =
        model.apply_tool(1, wand, {{10.0, 6.0 + frame, 18.0}, along_y}, ToolMode::kAblate);
    removed += e.removed_mm3;
    model.advance(1e-3);
    if (frame > 0) {
      EXPECT_GT(e.removed_mm3, 0.0) << "frame " << frame << ": the wand ablates";
      EXPECT_GT(model.tool_contact(0).nodes_held, 0u) << "frame " << frame << ": the ball holds";
    }
  }
  EXPECT_GT(removed, 10.0);
  EXPECT_EQ(model.tool_contact(1).nodes_held, 0u) << "an ablating hand holds no nodes";
  ASSERT_TRUE(test::all_finite(model));
}

TEST(SeveralTools, AFeatherAblatingHandFollowsItsOwnForceNotTheOtherHands) {
  // Force-dependent ablation (feather force 20 mN) in hand 1 while hand 0 presses firmly 20 mm
  // away: the wand's first touch removes nothing (its own force is still zero, however hard the
  // other hand presses), then each move's rate is 1 − exp(−F/F0) of the wand's own force, and
  // the wand holds its own nodes: lifting the pressing hand leaves the wand's grip.
  auto o = held_bottom();
  o.feather_force_un = 20e3;
  TissueModel model(test::block_volume({44, 24, 20}, {2, 2, 2}, {42, 22, 18}), std::move(o));
  const Tool wand = ball(2.0);
  for (int frame = 0; frame < 4; ++frame) {
    model.apply_tool(0, ball(4.0), {{32.5, 12.5, 21.0}, {}}, ToolMode::kPress);
    model.advance(1e-3);
  }
  ASSERT_GT(length(model.tool_contact(0).force_un), 20e3) << "hand 0 presses firmly";
  double removed = 0;
  bool lifted = false;
  for (int frame = 0; frame < 8; ++frame) {
    const double own_force = length(model.tool_contact(1).force_un);
    const EditReport e =
        model.apply_tool(1, wand, {{10.5, 12.5, 20.5 - 0.5 * frame}, {}}, ToolMode::kAblate);
    EXPECT_NEAR(e.rate_scale, 1.0 - std::exp(-own_force / 20e3), 1e-9) << "frame " << frame;
    if (frame == 0) {
      EXPECT_EQ(e.rate_scale, 0.0) << "no force of its own yet";
      EXPECT_EQ(e.removed_mm3, 0.0);
    }
    removed += e.removed_mm3;
    model.advance(1e-3);
    const std::size_t wand_held = model.tool_contact(1).nodes_held;
    if (!lifted && wand_held > 0 && model.tool_contact(0).nodes_held > 0) {
      model.release_tool(0);
      lifted = true;
      EXPECT_EQ(model.tool_contact(0).nodes_held, 0u);
      EXPECT_EQ(model.tool_contact(1).nodes_held, wand_held) << "lifting hand 0 keeps the wand's";
    }
  }
  EXPECT_TRUE(lifted) << "the feather-ablating wand never held nodes beside the pressing hand";
  EXPECT_GT(removed, 1.0) << "pressing, the wand ablates";
  ASSERT_TRUE(test::all_finite(model));
}

TEST(SeveralTools, AMeshToolPressesLikeTheShapeItWasMadeFrom) {
  // A 4 mm sphere as a closed mesh (2048 triangles, 0.2 mm grid) against the analytic sphere,
  // pressed 1 mm into the same block: the same nodes held within 25 % and the same force within
  // 25 %, and no node inside the mesh tool.
  const collision::test::Mesh m = collision::test::sphere_mesh(4.0, 4);
  Tool mesh_ball;
  mesh_ball.shape = collision::ToolShape::kMesh;
  mesh_ball.mesh = ToolMesh::from_closed_mesh("sphere", m.vertices, m.triangles, 0.2);
  const ToolPose pose{{12.5, 12.5, 21.0}, Rotation::about_axis({0, 0, 1}, 0.3)};
  auto press = [&](const Tool& tool) {
    auto model = std::make_unique<TissueModel>(
        test::block_volume({24, 24, 20}, {2, 2, 2}, {22, 22, 18}), held_bottom());
    for (int frame = 0; frame < 10; ++frame) {
      model->apply_tool(tool, pose, ToolMode::kPress);
      model->advance(1e-3);
    }
    return model;
  };
  const auto analytic = press(ball(4.0));
  const auto meshed = press(mesh_ball);
  ASSERT_TRUE(test::all_finite(*meshed));
  const collision::ContactForce& ca = analytic->contact();
  const collision::ContactForce& cm = meshed->contact();
  ASSERT_GT(ca.nodes_held, 0u);
  EXPECT_NEAR(double(cm.nodes_held), double(ca.nodes_held), 0.25 * ca.nodes_held);
  EXPECT_GT(cm.force_un.z, 0.0);
  EXPECT_NEAR(cm.force_un.z, ca.force_un.z, 0.25 * ca.force_un.z);
  EXPECT_LE(node_depth(*meshed, place_tool(mesh_ball, pose)), 1e-3);
  // A mesh tool presses only: ablation and cuts need a sphere, capsule or blade.
  EXPECT_FALSE(mesh_ball.supports(ToolMode::kAblate));
  EXPECT_FALSE(mesh_ball.supports(ToolMode::kCut));
  EXPECT_THROW(meshed->apply_tool(mesh_ball, pose, ToolMode::kAblate), Error);
}

TEST(SeveralTools, ASlotOutOfRangeIsAnError) {
  TissueModel model(test::block_volume({12, 12, 12}, {2, 2, 2}, {10, 10, 10}), held_bottom());
  EXPECT_THROW(
      model.apply_tool(TissueModel::kMaxToolSlots, ball(1.0), {{5, 5, 15}, {}}, ToolMode::kPress),
      Error);
  EXPECT_THROW(model.apply_tool(-1, ball(1.0), {{5, 5, 15}, {}}, ToolMode::kPress), Error);
}

}  // namespace
}  // namespace tsf::interaction
