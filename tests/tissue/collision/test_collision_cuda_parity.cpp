// Collision queries on both backends: the CUDA gather kernel and the CPU broad phase must find
// the same nodes with the same exact tool tests, the force kernel must match the CPU spring
// forces, and a whole press must hold the same nodes with the same reaction.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "../interaction/interaction_test_helpers.h"
#include "collision_test_meshes.h"
#include "tsf/collision/node_gatherer.h"
#include "tsf/common/cuda_support.h"
#include "tsf/interaction/body_field.h"

namespace tsf::collision {
namespace {

using interaction::TissueModel;

std::unique_ptr<TissueModel> make_model(crms::Backend backend) {
  auto o = interaction::test::block_options(-1, 0.0);
  o.solver.backend = backend;
  o.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, 3.0});
  };
  return std::make_unique<TissueModel>(
      interaction::test::block_volume({24, 24, 16}, {2, 2, 2}, {22, 22, 14}), o);
}

void squash(TissueModel& model) {
  const crms::Lattice& l = model.solver().lattice();
  std::vector<Vec3f> du(static_cast<std::size_t>(l.node_count())), v(du.size());
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    const Vec3d p = l.geometry().rest_position(n);
    du[static_cast<std::size_t>(n)] = to_float(Vec3d{0.01 * p.y, 0.0, -0.03 * p.z});
  }
  model.solver().set_state(du, v);
}

TEST(CollisionCudaParity, GatherAndForcesAgreeWithTheCpu) {
  if (!cuda_status().available) GTEST_SKIP() << "CUDA parity not run: " << cuda_status().reason;
  auto cpu = make_model(crms::Backend::kCpu);
  auto gpu = make_model(crms::Backend::kCuda);
  ASSERT_TRUE(gpu->solver().on_cuda());
  squash(*cpu);
  squash(*gpu);
  WorldTool tool;
  tool.shape = ToolShape::kCapsule;
  tool.a = {8, 12, 15};
  tool.b = {16, 12, 13};
  tool.radius = 2.5;
  NodeGatherer g_cpu(cpu->solver().lattice().geometry()), g_gpu(gpu->solver().lattice().geometry());
  NodeNeighbourhood a, b;
  g_cpu.gather_around_tool(cpu->solver(), tool, 4.0, a);
  g_gpu.gather_around_tool(gpu->solver(), tool, 4.0, b);
  ASSERT_GT(a.size(), 10u);
  ASSERT_EQ(a.nodes, b.nodes);
  std::size_t inside = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_LT(length(a.displacement[i] - b.displacement[i]), 1e-6f);
    EXPECT_EQ(a.inside[i], b.inside[i]) << "node " << a.nodes[i];
    if (a.inside[i]) {
      ++inside;
      EXPECT_LT(length(a.target[i] - b.target[i]), 1e-5f);
      EXPECT_LT(length(a.normal[i] - b.normal[i]), 1e-5f);
    }
  }
  EXPECT_GT(inside, 0u);
  std::vector<Vec3f> fa, fb;
  g_cpu.spring_forces_at(cpu->solver(), a.nodes, fa);
  g_gpu.spring_forces_at(gpu->solver(), b.nodes, fb);
  // The net force at a node is a sum of spring forces that nearly cancel inside a uniformly
  // squashed block; float rounding (and FMA on the device) is relative to the spring forces, not
  // to their small sum, so the tolerance scales with the largest net force gathered (a surface
  // node's: about one spring's force). A missing or wrong spring would be off by ~that force.
  float scale = 0;
  for (const Vec3f& f : fa) scale = std::max(scale, length(f));
  ASSERT_GT(scale, 0.0f);
  for (std::size_t i = 0; i < fa.size(); ++i)
    EXPECT_LT(length(fa[i] - fb[i]), 1e-5f * scale + 1e-6f) << "node " << a.nodes[i];
}

TEST(CollisionCudaParity, APressHoldsTheSameNodesWithTheSameForce) {
  if (!cuda_status().available) GTEST_SKIP() << "CUDA parity not run: " << cuda_status().reason;
  auto cpu = make_model(crms::Backend::kCpu);
  auto gpu = make_model(crms::Backend::kCuda);
  interaction::Tool ball;
  ball.radius_mm = 4.0;
  const ToolPose pose{{12.5, 12.5, 17.2}, {}};
  const interaction::EditReport rc = cpu->apply_tool(ball, pose, interaction::ToolMode::kPress);
  const interaction::EditReport rg = gpu->apply_tool(ball, pose, interaction::ToolMode::kPress);
  EXPECT_EQ(rc.contact.nodes_held, rg.contact.nodes_held);
  EXPECT_GT(rc.contact.nodes_held, 0u);
  EXPECT_LT(length(rc.contact.force_un - rg.contact.force_un),
            1e-4 * (1.0 + length(rc.contact.force_un)));
  cpu->advance(5e-4);
  gpu->advance(5e-4);
  EXPECT_EQ(cpu->contact().nodes_held, gpu->contact().nodes_held);
  EXPECT_LT(length(cpu->contact().force_un - gpu->contact().force_un),
            1e-2 * (1.0 + length(cpu->contact().force_un)));
}

TEST(CollisionCudaParity, MeshToolsTwoHandsAndABodyHoldTheSameNodesOnBothBackends) {
  if (!cuda_status().available) GTEST_SKIP() << "CUDA parity not run: " << cuda_status().reason;
  // Host-tested tools on CUDA: the gather kernel takes a mesh tool's (and a body's) box, the host
  // tests the nodes; the result must be the CPU's. A mesh ball in hand 0, a capsule in hand 1,
  // and a slab under the block pushing it (the block's bottom overlaps it by 1 mm at rest).
  auto cpu = make_model(crms::Backend::kCpu);
  auto gpu = make_model(crms::Backend::kCuda);
  ASSERT_TRUE(gpu->solver().on_cuda());
  const test::Mesh m = test::sphere_mesh(4.0, 3);
  interaction::Tool mesh_ball;
  mesh_ball.shape = ToolShape::kMesh;
  mesh_ball.mesh = interaction::ToolMesh::from_closed_mesh("sphere", m.vertices, m.triangles, 0.25);
  interaction::Tool wand;
  wand.shape = ToolShape::kCapsule;
  wand.radius_mm = 2.0;
  wand.half_length_mm = 2.0;
  auto slab_options = interaction::test::block_options(-1, 0.0);
  slab_options.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, 1e9});
  };
  const TissueModel slab(interaction::test::block_volume({24, 24, 8}, {0, 0, 0}, {24, 24, 3}),
                         slab_options);
  for (TissueModel* model : {cpu.get(), gpu.get()}) {
    auto field = std::make_shared<interaction::BodyField>(slab, 0.5);
    field->set_rest_allowance(*model);
    model->set_pushers({field});
    model->apply_tool(0, mesh_ball, {{8.5, 12.5, 17.2}, {}}, interaction::ToolMode::kPress);
    model->apply_tool(1, wand, {{17.0, 12.5, 16.0}, Rotation::about_axis({1, 0, 0}, 1.0)},
                      interaction::ToolMode::kPress);
  }
  for (int h = 0; h < 2; ++h) {
    EXPECT_EQ(cpu->tool_contact(h).nodes_held, gpu->tool_contact(h).nodes_held) << "hand " << h;
    EXPECT_GT(cpu->tool_contact(h).nodes_held, 0u) << "hand " << h;
    EXPECT_LT(length(cpu->tool_contact(h).force_un - gpu->tool_contact(h).force_un),
              1e-4 * (1.0 + length(cpu->tool_contact(h).force_un)))
        << "hand " << h;
  }
  cpu->advance(5e-4);
  gpu->advance(5e-4);
  EXPECT_EQ(cpu->contact().nodes_held, gpu->contact().nodes_held);
  EXPECT_EQ(cpu->pusher_contact().nodes_held, gpu->pusher_contact().nodes_held);
  EXPECT_LT(length(cpu->contact().force_un - gpu->contact().force_un),
            1e-2 * (1.0 + length(cpu->contact().force_un)));
}

}  // namespace
}  // namespace tsf::collision
