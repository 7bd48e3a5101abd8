// The narrow phase's incremental iterations: after the first, only the cubes that read a node
// the last iteration moved are tested again. The outcome must be the one of testing every cube
// in every iteration (ContactOptions::retest_every_cube), bit for bit, also by a slit and on a
// thin plate, where cubes infer missing corners from their corners' outside neighbours.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>

#include "../interaction/interaction_test_helpers.h"

namespace tsf::interaction {
namespace {

TissueModelOptions narrow_options(bool retest_every_cube) {
  auto o = test::block_options(-1, 0.0);
  o.solver.materials[0].youngs_modulus_pa = 50e3;
  o.solver.materials[0].viscosity_pa_s = 10.0;
  o.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, 3.0});
  };
  o.contact.retest_every_cube = retest_every_cube;
  return o;
}

bool same_floats(const std::vector<Vec3f>& a, const std::vector<Vec3f>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3f)) == 0;
}

/// Presses `ball` at pose(k), k = 0..7, into both models, two frames after each, and expects the
/// same contact, lattice and coupled vertices from both, and fewer cube tests from the
/// incremental one once some pass iterated (else the comparison would prove nothing).
void expect_same_presses(TissueModel& incremental, TissueModel& reference, const Tool& ball,
                         const std::function<ToolPose(int)>& pose) {
  std::size_t tests_incremental = 0, tests_reference = 0;
  int most_iterations = 0;
  for (int k = 0; k < 8; ++k) {
    const EditReport a = incremental.apply_tool(ball, pose(k), ToolMode::kPress);
    const EditReport b = reference.apply_tool(ball, pose(k), ToolMode::kPress);
    ASSERT_GT(a.contact.vertices_tested, 0u) << "press " << k;
    EXPECT_EQ(a.contact.narrow_iterations, b.contact.narrow_iterations) << "press " << k;
    EXPECT_EQ(a.contact.vertices_pushed, b.contact.vertices_pushed) << "press " << k;
    EXPECT_EQ(a.contact.nodes_held, b.contact.nodes_held) << "press " << k;
    EXPECT_EQ(a.contact.max_vertex_depth_mm, b.contact.max_vertex_depth_mm) << "press " << k;
    EXPECT_EQ(a.contact.force_un.x, b.contact.force_un.x) << "press " << k;
    EXPECT_EQ(a.contact.force_un.z, b.contact.force_un.z) << "press " << k;
    tests_incremental += a.contact.narrow_cube_tests;
    tests_reference += b.contact.narrow_cube_tests;
    most_iterations = std::max(most_iterations, a.contact.narrow_iterations);
    for (int frame = 0; frame < 2; ++frame) {
      incremental.advance(1e-3);
      reference.advance(1e-3);
    }
    ASSERT_TRUE(
        same_floats(incremental.solver().displacements(), reference.solver().displacements()))
        << "the lattices differ after press " << k;
    ASSERT_TRUE(same_floats(incremental.coupler().positions(), reference.coupler().positions()))
        << "the coupled vertices differ after press " << k;
  }
  EXPECT_GE(most_iterations, 2);
  EXPECT_LT(tests_incremental, tests_reference);
}

TEST(ToolContactNarrow, IncrementalIterationsBySlitGiveWhatRetestingEveryCubeGives) {
  const VoxelVolume volume = test::block_volume({28, 28, 20}, {2, 2, 2}, {26, 26, 18});
  TissueModel incremental(VoxelVolume(volume), narrow_options(false));
  TissueModel reference(VoxelVolume(volume), narrow_options(true));
  Tool blade;
  blade.shape = collision::ToolShape::kBlade;
  blade.half_extents_mm = {6.0, 16.0, 0.5};  // length (world z), depth (world y), thickness (x)
  const Rotation across_x = Rotation::about_axis({0, 1, 0}, M_PI / 2);
  // A slit cut down into the top: the cubes across it keep the corners of one side and infer
  // the others from their corners' outside neighbours.
  for (TissueModel* m : {&incremental, &reference}) {
    m->apply_tool(blade, {{14.3, 14.0, 26.0}, across_x}, ToolMode::kCut);
    m->apply_tool(blade, {{14.3, 14.0, 16.0}, across_x}, ToolMode::kCut);
    m->release_tool();
  }
  Tool ball;
  ball.radius_mm = 4.0;
  // The ball pressed over the slit, deeper and along it.
  expect_same_presses(incremental, reference, ball, [](int k) {
    return ToolPose{{13.0 + 0.4 * k, 8.0 + 1.5 * k, 18.0 + 4.0 - 0.3 * k}, {}};
  });
}

TEST(ToolContactNarrow, IncrementalIterationsOnAThinPlateGiveWhatRetestingEveryCubeGives) {
  // A plate one lattice cell thick: its cubes have the corners of one face only and infer the
  // others from the outside neighbours in the plate, which the corrections move.
  const VoxelVolume volume = test::block_volume({30, 30, 12}, {2, 2, 4}, {28, 28, 6.5});
  auto options = [](bool every) {
    TissueModelOptions o = narrow_options(every);
    o.anchor = [](crms::Lattice& l) {
      crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {4.0, 1e9, 1e9});
      crms::fix_nodes_in_box(l, {26.0, -1e9, -1e9}, {1e9, 1e9, 1e9});
    };
    return o;
  };
  TissueModel incremental(VoxelVolume(volume), options(false));
  TissueModel reference(VoxelVolume(volume), options(true));
  Tool ball;
  ball.radius_mm = 3.0;
  expect_same_presses(incremental, reference, ball, [](int k) {
    return ToolPose{{11.0 + 1.1 * k, 12.0 + 0.7 * k, 6.5 + 3.0 - 0.3 * k}, {}};
  });
}

}  // namespace
}  // namespace tsf::interaction
