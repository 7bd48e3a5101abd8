// Tool poses live in the deformed world; edits happen in rest space. The inverse map must undo the
// coupler's deformation: round trips rest → deformed → rest and deformed → rest → deformed agree
// to 0.01 voxel on a moderately bent and twisted block.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "interaction_test_helpers.h"
#include "tsf/coupler/vertex_binder.h"
#include "tsf/interaction/rest_space_map.h"

namespace tsf::interaction {
namespace {

using test::block_options;
using test::block_volume;

/// Bends (z += 0.01·x²), twists (about x, 0.02 rad/mm) and stretches (x · 1.05) the lattice.
void deform_moderately(TissueModel& model) {
  const crms::Lattice& l = model.solver().lattice();
  std::vector<Vec3f> du(static_cast<std::size_t>(l.node_count())), v(du.size());
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    const Vec3d p = l.geometry().rest_position(n);
    const double angle = 0.02 * p.x;
    const double y = p.y - 7, z = p.z - 7;
    const Vec3d q{1.05 * p.x, 7 + std::cos(angle) * y - std::sin(angle) * z,
                  7 + std::sin(angle) * y + std::cos(angle) * z + 0.01 * p.x * p.x};
    du[static_cast<std::size_t>(n)] = to_float(q - p);
  }
  model.solver().set_state(du, v);
  model.couple();
}

/// Forward map of a rest point through the coupler's trilinear deformation.
Vec3d forward(const TissueModel& model, const Vec3d& p) {
  coupler::VertexBinder binder(model.solver().lattice());
  const coupler::BindingResult b = binder.bind(to_float(p), {0, 0, 0});
  const coupler::DeformedLatticeView view = coupler::deformed_lattice_view(model.solver());
  return to_double(coupler::couple_vertex(coupler::LatticeReader{view}, view, b.binding, b.sources,
                                          {0, 0, 1}, coupler::CouplerMode::kTrilinear)
                       .position);
}

TEST(RestSpaceMap, RoundTripsToAHundredthOfAVoxelOnABentTwistedBlock) {
  TissueModel model(block_volume({44, 14, 14}, {2, 2, 2}, {42, 12, 12}), block_options(-1, 0));
  deform_moderately(model);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(3, 41), uy(3, 11);
  const double voxel = 1.0;
  double worst_rest = 0, worst_world = 0;
  int inside = 0;
  for (int t = 0; t < 300; ++t) {
    const Vec3d p{ux(rng), uy(rng), uy(rng)};
    const Vec3d x = forward(model, p);
    ASSERT_GT(length(x - p), 0.0);
    const RestPoint back = model.map_to_rest(x, 4.0);
    ASSERT_TRUE(back.found);
    inside += back.inside_cube;
    worst_rest = std::max(worst_rest, length(back.rest - p));
    // And the other way: a world point near the tissue, to rest and forward again.
    const Vec3d y = x + Vec3d{0.3, -0.2, 0.25};
    const RestPoint r2 = model.map_to_rest(y, 4.0);
    worst_world = std::max(worst_world, length(forward(model, r2.rest) - y));
  }
  EXPECT_LT(worst_rest, 0.01 * voxel);
  EXPECT_LT(worst_world, 0.01 * voxel);
  EXPECT_EQ(inside, 300) << "interior points must map inside a cube";
}

TEST(RestSpaceMap, ARigidlyRotatedBladeMapsBackToItsRestOrientation) {
  TissueModel model(block_volume({24, 24, 24}, {2, 2, 2}, {22, 22, 22}), block_options(-1, 0));
  const Rotation r = Rotation::about_axis({0, 0, 1}, 0.4);
  const crms::Lattice& l = model.solver().lattice();
  std::vector<Vec3f> du(static_cast<std::size_t>(l.node_count())), v(du.size());
  const Vec3d about{12, 12, 12};
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    const Vec3d p = l.geometry().rest_position(n);
    du[static_cast<std::size_t>(n)] = to_float(about + r.apply(p - about) - p);
  }
  model.solver().set_state(du, v);
  const Rotation world = Rotation::about_axis({1, 0, 0}, 0.3);
  const RestPoint rp = model.map_to_rest(about + r.apply(Vec3d{1, 2, -1}), 4.0);
  EXPECT_LT(length(rp.rest - (about + Vec3d{1, 2, -1})), 1e-3);
  const Rotation rest = rest_orientation(world, rp.gradient);
  // rest should be Rᵀ·world: compare by the angle between them.
  const Rotation expected = Rotation{r.w, -r.x, -r.y, -r.z};
  const Vec3d ex = expected.apply(world.apply({1, 0, 0})),
              ey = expected.apply(world.apply({0, 1, 0}));
  EXPECT_LT(length(rest.apply({1, 0, 0}) - ex), 1e-4);
  EXPECT_LT(length(rest.apply({0, 1, 0}) - ey), 1e-4);
}

TEST(RestSpaceMap, NoTissueNearMeansNotFound) {
  TissueModel model(block_volume({24, 14, 14}, {2, 2, 2}, {22, 12, 12}), block_options(-1, 0));
  const RestPoint far = model.map_to_rest({200, 200, 200}, 4.0);
  EXPECT_FALSE(far.found);
}

}  // namespace
}  // namespace tsf::interaction
