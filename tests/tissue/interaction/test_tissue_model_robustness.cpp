// Random strokes of every tool on a small block, with presses and simulation between them: every
// layer stays consistent with the others (also run under ASan + UBSan in CI: keep it small).
//   * no NaN in nodes or coupled vertices;
//   * the render surface is a closed, consistently oriented manifold: no dangling vertex, no
//     non-manifold edge; the IMT buffers pass their own invariant check;
//   * every live vertex is bound; none is bound to a cube whose sources are all gone (an
//     orphan), so every vertex has a frame to follow;
//   * the incremental bindings equal binding every vertex afresh;
//   * the coupled positions equal coupling afresh.
#include <gtest/gtest.h>

#include <random>

#include "interaction_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/coupler/coupler.h"

namespace tsf::interaction {
namespace {

::testing::AssertionResult layers_consistent(const TissueModel& model, const std::string& when) {
  if (auto f = test::all_finite(model); !f) return f << " (" << when << ")";
  try {
    model.surface().check_invariants();
  } catch (const Error& e) {
    return ::testing::AssertionFailure() << when << ": IMT invariant: " << e.what();
  }
  const imt::SurfaceMesh mesh = model.deformed_mesh();
  if (auto m = test::closed_manifold(mesh); !m) return m << " (" << when << ")";

  const coupler::Coupler& c = model.coupler();
  const imt::ImtSurface& s = model.surface();
  coupler::Coupler fresh(model.solver().lattice().geometry(), c.options());
  fresh.bind_all(s, model.solver().lattice());
  fresh.couple(model.solver());
  for (std::uint32_t slot = 1; slot < s.vertex_slot_count(); ++slot) {
    if (!s.vertex_live(slot)) continue;
    const coupler::VertexBinding& b = c.bindings()[slot];
    const coupler::VertexBinding& f = fresh.bindings()[slot];
    if (b.cell < 0)
      return ::testing::AssertionFailure() << when << ": live vertex " << slot << " unbound";
    if (c.sources()[slot] == 0)
      return ::testing::AssertionFailure()
             << when << ": vertex " << slot << " has no source node (orphan)";
    if (b.cell != f.cell || b.w[0] != f.w[0] || b.w[1] != f.w[1] || b.w[2] != f.w[2] ||
        c.sources()[slot] != fresh.sources()[slot])
      return ::testing::AssertionFailure()
             << when << ": vertex " << slot << " bound to cell " << b.cell << " sources "
             << c.sources()[slot] << ", a fresh binding says cell " << f.cell << " sources "
             << fresh.sources()[slot];
    if (length(c.positions()[slot] - fresh.positions()[slot]) > 1e-5f)
      return ::testing::AssertionFailure()
             << when << ": vertex " << slot << " coupled position differs from a fresh coupling";
  }
  if (c.orphan_count() != 0)
    return ::testing::AssertionFailure() << when << ": " << c.orphan_count() << " orphans";
  return ::testing::AssertionSuccess();
}

TEST(TissueModelRobustness, RandomStrokesAndPressesKeepEveryLayerConsistent) {
  auto o = test::block_options(4.0);
  o.solver.materials[0].youngs_modulus_pa = 50e3;
  TissueModel model(test::block_volume({34, 22, 18}, {2, 2, 2}, {32, 20, 16}), o);
  ASSERT_TRUE(layers_consistent(model, "at start"));
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> ux(0, 34), uy(0, 22), uz(0, 18), unit(-1, 1);
  std::uniform_int_distribution<int> kind(0, 3);
  Tool ball, wand, blade;
  ball.radius_mm = 2.0;
  wand.shape = collision::ToolShape::kCapsule;
  wand.radius_mm = 1.5;
  wand.half_length_mm = 3.0;
  blade.shape = collision::ToolShape::kBlade;
  blade.half_extents_mm = {6.0, 4.0, 0.3};
  for (int op = 0; op < 120; ++op) {
    const Vec3d p{ux(rng), uy(rng), uz(rng)};
    const Rotation r =
        Rotation::about_axis({unit(rng), unit(rng), unit(rng) + 1e-3}, 3.0 * unit(rng));
    const Vec3d step{3 * unit(rng), 3 * unit(rng), 3 * unit(rng)};
    const int k = kind(rng);
    if (k == 0) {
      model.apply_tool(ball, {p, r}, ToolMode::kAblate);
      model.apply_tool(ball, {p + step, r}, ToolMode::kAblate);
    } else if (k == 1) {
      model.apply_tool(wand, {p, r}, ToolMode::kAblate);
      model.apply_tool(wand, {p + step, r}, ToolMode::kAblate);
    } else if (k == 2) {
      model.apply_tool(blade, {p, r}, ToolMode::kCut);
      model.apply_tool(blade, {p + step * 2.0, r}, ToolMode::kCut);
    } else {
      model.apply_tool(ball, {p, r}, ToolMode::kPress);
    }
    model.advance(2e-4);
    model.release_tool();
    if (op % 20 == 19) {
      ASSERT_TRUE(layers_consistent(model, "after op " + std::to_string(op)));
    }
  }
  EXPECT_GT(model.totals().edits, 50u);
  EXPECT_GT(model.totals().nodes_deleted + model.totals().springs_broken, 0u);
}

}  // namespace
}  // namespace tsf::interaction
