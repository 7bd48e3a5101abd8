// One tissue instance pushing another, one way (interaction/body_field.h): a block falling onto
// a held body comes to rest on it instead of passing through, a body that moves pushes the block
// along, and tissues that overlap at rest keep their overlap instead of being kicked apart.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "tissue/interaction/interaction_test_helpers.h"
#include "tsf/interaction/body_field.h"
#include "tsf/interaction/tissue_model.h"

namespace tsf::interaction {
namespace {

/// A stiff slab [0, 40] × [0, 20] × [0, 6] mm held everywhere (the bone).
std::unique_ptr<TissueModel> bone(bool held_everywhere = true) {
  auto o = test::block_options(-1, 0.0);
  o.solver.materials[0].youngs_modulus_pa = 2e6;
  o.solver.materials[0].viscosity_pa_s = 20.0;
  if (held_everywhere)
    o.anchor = [](crms::Lattice& l) {
      crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, 1e9});
    };
  return std::make_unique<TissueModel>(test::block_volume({44, 24, 12}, {0, 0, 0}, {40, 20, 6}), o);
}

/// A free soft block [12, 28] × [4, 16] × [7, 15] mm under gravity (1 mm above the slab).
std::unique_ptr<TissueModel> block(double z0 = 7.0) {
  auto o = test::block_options(-1, -9810.0);
  o.solver.materials[0].youngs_modulus_pa = 20e3;
  o.solver.materials[0].viscosity_pa_s = 5.0;
  o.solver.stability.kinetic_damping = 0.02;
  return std::make_unique<TissueModel>(
      test::block_volume({44, 24, 30}, {12, 4, z0}, {28, 16, z0 + 8}), o);
}

double lowest_node_z(const TissueModel& m) {
  double z = 1e9;
  const auto p = m.solver().positions();
  for (std::size_t i = 0; i < p.size(); ++i)
    if (m.solver().lattice().alive(static_cast<std::int64_t>(i))) z = std::min(z, double(p[i].z));
  return z;
}

double lowest_vertex_z(const TissueModel& m) {
  double z = 1e9;
  const auto& p = m.coupler().positions();
  for (std::uint32_t s = 1; s < m.surface().vertex_slot_count(); ++s)
    if (m.surface().vertex_live(s)) z = std::min(z, double(p[s].z));
  return z;
}

TEST(BodyContact, ABlockFallingOntoABodyRestsOnItInsteadOfPassingThrough) {
  const auto slab = bone();
  const auto on = block(), off = block();
  auto field = std::make_shared<BodyField>(*slab, 0.5);
  field->set_rest_allowance(*on);
  on->set_pushers({field});
  for (int frame = 0; frame < 60; ++frame) {  // 0.3 s: the fall takes ~15 ms
    field->follow(*slab);
    on->advance(5e-3);
    off->advance(5e-3);
  }
  ASSERT_TRUE(test::all_finite(*on));
  // The slab's top is at z = 6: the block's surface rests on it (its nodes are where their own
  // surface touches the slab: the bottom node layer sits up to half a spacing off that surface).
  EXPECT_GT(lowest_vertex_z(*on), 6.0 - 0.3) << "the surface stays out of the slab";
  EXPECT_LT(lowest_vertex_z(*on), 6.0 + 0.3) << "the block fell onto the slab";
  EXPECT_GT(lowest_node_z(*on), 6.0 - 1.0 - 0.05);
  EXPECT_GT(on->pusher_contact().nodes_held, 0u);
  EXPECT_GT(on->pusher_contact().force_un.z, 0.0) << "the slab holds the block up";
  EXPECT_EQ(on->contact().nodes_held, 0u) << "the body's support is not a tool's force";
  // Without the contact the block falls through the slab's place.
  EXPECT_LT(lowest_node_z(*off), 0.0);
}

TEST(BodyContact, AMovingBodyPushesTheBlockAlong) {
  // The slab rises 3 mm over 0.15 s (its nodes moved by constraints, as a tool or the script
  // would move it): the block resting on it rises with it.
  const auto slab = bone(false);
  const auto b = block();
  auto field = std::make_shared<BodyField>(*slab, 0.5);
  field->set_rest_allowance(*b);
  b->set_pushers({field});
  for (int frame = 0; frame < 30; ++frame) {
    field->follow(*slab);
    b->advance(5e-3);
  }
  const double resting = lowest_vertex_z(*b);
  crms::Solver& s = slab->solver();
  std::vector<std::int64_t> nodes;
  for (std::int64_t n = 0; n < s.lattice().node_count(); ++n)
    if (s.lattice().alive(n)) nodes.push_back(n);
  for (int frame = 1; frame <= 40; ++frame) {
    std::vector<Vec3d> targets;
    const double lift = 3.0 * std::min(1.0, frame / 30.0);
    for (std::int64_t n : nodes)
      targets.push_back(s.lattice().geometry().rest_position(n) + Vec3d{0, 0, lift});
    s.constrain_nodes(nodes, targets);
    slab->advance(5e-3);
    field->follow(*slab);
    b->advance(5e-3);
  }
  ASSERT_TRUE(test::all_finite(*b));
  EXPECT_GT(lowest_vertex_z(*b), resting + 2.5) << "the block rose with the slab";
  EXPECT_GT(lowest_vertex_z(*b), 9.0 - 0.3) << "and stays on it";
}

TEST(BodyContact, TissuesOverlappingAtRestKeepTheirOverlap) {
  // The block's bottom 1.5 mm lies inside the slab at rest (as two instances segmented from one
  // CT share boundary voxels): the nodes there may stay as deep as they were, so without gravity
  // nothing moves.
  auto o = test::block_options(-1, 0.0);
  o.solver.materials[0].youngs_modulus_pa = 20e3;
  const auto slab = bone();
  TissueModel b(test::block_volume({44, 24, 30}, {12, 4, 4.5}, {28, 16, 12.5}), o);
  auto field = std::make_shared<BodyField>(*slab, 0.5);
  field->set_rest_allowance(b);
  EXPECT_GT(field->nodes_overlapping_at_rest(), 0u);
  b.set_pushers({field});
  for (int frame = 0; frame < 10; ++frame) b.advance(5e-3);
  double max_u = 0;
  for (const Vec3f& u : b.solver().displacements()) max_u = std::max(max_u, double(length(u)));
  EXPECT_LT(max_u, 1e-3) << "the rest overlap must not kick the block";
}

}  // namespace
}  // namespace tsf::interaction
