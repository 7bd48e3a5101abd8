// The coupler on whole scenes: a sagging block's surface follows the lattice exactly, rigid
// motions carry vertices and normals rigidly, the thesis's local frame agrees with trilinear
// where the deformation is affine, and dirty tracking names exactly what moved.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "../interaction/interaction_test_helpers.h"
#include "tsf/coupler/coupler.h"
#include "tsf/crms/lattice_geometry.h"

namespace tsf::coupler {
namespace {

using interaction::TissueModel;
using interaction::test::block_options;
using interaction::test::block_volume;

/// Trilinear interpolation of the 8 nodes of the cube holding rest point p, from the solver's
/// positions (all corners alive).
Vec3d interpolate_nodes(const crms::Solver& solver, const std::vector<Vec3f>& nodes,
                        const Vec3d& p) {
  const crms::LatticeGeometry& g = solver.lattice().geometry();
  const crms::LatticeCellLocation loc = crms::locate_rest_point(g, p);
  const Vec3d w{(p.x - g.rest_position(loc.cell.x, loc.cell.y, loc.cell.z).x) / g.spacing.x,
                (p.y - g.rest_position(loc.cell.x, loc.cell.y, loc.cell.z).y) / g.spacing.y,
                (p.z - g.rest_position(loc.cell.x, loc.cell.y, loc.cell.z).z) / g.spacing.z};
  Vec3d out{0, 0, 0};
  for (int c = 0; c < 8; ++c) {
    const int i = loc.cell.x + (c & 1), j = loc.cell.y + ((c >> 1) & 1),
              k = loc.cell.z + ((c >> 2) & 1);
    const double wx = (c & 1) ? w.x : 1 - w.x, wy = (c & 2) ? w.y : 1 - w.y,
                 wz = (c & 4) ? w.z : 1 - w.z;
    out += to_double(nodes[static_cast<std::size_t>(g.index(i, j, k))]) * (wx * wy * wz);
  }
  return out;
}

TEST(Coupler, AtRestEveryVertexSitsOnItsRestPosition) {
  for (CouplerMode mode : {CouplerMode::kTrilinear, CouplerMode::kLocalFrame}) {
    auto o = block_options(-1.0, 0.0);
    o.coupler_mode = mode;
    const TissueModel model(block_volume({24, 14, 14}, {2, 2, 2}, {22, 12, 12}), o);
    const auto& rest = model.surface().positions();
    const auto& rest_n = model.surface().normals();
    std::size_t checked = 0;
    for (std::uint32_t s = 1; s < model.surface().vertex_slot_count(); ++s) {
      if (!model.surface().vertex_live(s)) continue;
      ++checked;
      EXPECT_LT(length(model.coupler().positions()[s] - rest[s]), 1e-4f) << "slot " << s;
      EXPECT_LT(length(model.coupler().normals()[s] - rest_n[s]), 1e-4f) << "slot " << s;
    }
    EXPECT_GT(checked, 1000u);
  }
}

TEST(Coupler, SaggingBlockSurfaceEqualsTrilinearInterpolationOfItsCube) {
  // 40 × 10 × 10 mm block clamped at x < 4 mm, sagging under gravity. Its faces lie half a voxel
  // off the voxel centres with a 1 mm density ramp and the node threshold is low, so every
  // surface cell keeps its node: each vertex's cube has all 8 corners and its coupled position
  // must be exactly their trilinear interpolation (inferred corners are tested elsewhere).
  auto options = block_options(4.0);
  options.lattice.occupancy_threshold = 0.004f;
  options.deletion_threshold = 0.004f;
  const Vec3d lo{1.5, 1.5, 1.5}, hi{41.5, 11.5, 11.5};
  VoxelVolume volume = make_sdf_volume(
      cube_geometry({44, 14, 14}, 1.0),
      [&](const Vec3d& p) { return box_distance_local((hi - lo) * 0.5, p - (lo + hi) * 0.5); },
      1.0);
  TissueModel model(std::move(volume), options);
  for (int frame = 0; frame < 10; ++frame) model.advance(2e-3);
  const std::vector<Vec3f> nodes = model.solver().positions();
  // The free end must have moved down noticeably, or the test proves nothing.
  double tip = 0;
  for (const Vec3f& d : model.solver().displacements())
    tip = std::min(tip, static_cast<double>(d.z));
  EXPECT_LT(tip, -0.05) << "the block did not sag";

  const crms::Lattice& l = model.solver().lattice();
  const auto& rest = model.surface().positions();
  double worst = 0;
  std::size_t checked = 0;
  for (std::uint32_t s = 1; s < model.surface().vertex_slot_count(); ++s) {
    if (!model.surface().vertex_live(s)) continue;
    const crms::LatticeCellLocation loc = crms::locate_rest_point(l.geometry(), to_double(rest[s]));
    for (int c = 0; c < 8; ++c)
      ASSERT_TRUE(l.alive(l.geometry().index(loc.cell.x + (c & 1), loc.cell.y + ((c >> 1) & 1),
                                             loc.cell.z + ((c >> 2) & 1))))
          << "slot " << s << ": a corner of its cube is missing (scene set-up)";
    const Vec3d expected = interpolate_nodes(model.solver(), nodes, to_double(rest[s]));
    worst = std::max(worst, length(to_double(model.coupler().positions()[s]) - expected));
    ++checked;
  }
  EXPECT_GT(checked, 2000u);
  EXPECT_LT(worst, 2e-5) << "coupled vertex differs from the interpolation of its cube";
}

TEST(Coupler, RigidMotionMovesVerticesAndNormalsRigidlyInBothModes) {
  for (CouplerMode mode : {CouplerMode::kTrilinear, CouplerMode::kLocalFrame}) {
    auto o = block_options(-1.0, 0.0);
    o.coupler_mode = mode;
    TissueModel model(block_volume({20, 16, 14}, {2, 2, 2}, {18, 14, 12}), o);
    const Rotation r = Rotation::about_axis({1, 2, 3}, 0.7);
    const Vec3d shift{3, -2, 5}, about{10, 8, 7};
    const crms::Lattice& l = model.solver().lattice();
    std::vector<Vec3f> du(static_cast<std::size_t>(l.node_count())), v(du.size());
    for (std::int64_t n = 0; n < l.node_count(); ++n) {
      const Vec3d p = l.geometry().rest_position(n);
      du[static_cast<std::size_t>(n)] = to_float(about + r.apply(p - about) + shift - p);
    }
    model.solver().set_state(du, v);
    model.couple();
    const auto& rest = model.surface().positions();
    const auto& rest_n = model.surface().normals();
    double worst_p = 0, worst_n = 0;
    for (std::uint32_t s = 1; s < model.surface().vertex_slot_count(); ++s) {
      if (!model.surface().vertex_live(s)) continue;
      const Vec3d expect = about + r.apply(to_double(rest[s]) - about) + shift;
      worst_p = std::max(worst_p, length(to_double(model.coupler().positions()[s]) - expect));
      if (length(rest_n[s]) > 0.5f)
        worst_n = std::max(worst_n, length(to_double(model.coupler().normals()[s]) -
                                           r.apply(to_double(rest_n[s]))));
    }
    EXPECT_LT(worst_p, 1e-4) << "mode " << static_cast<int>(mode);
    EXPECT_LT(worst_n, 1e-4) << "mode " << static_cast<int>(mode);
  }
}

TEST(Coupler, NormalsStayPerpendicularUnderShear) {
  // A shear x += 0.5·z maps the face x = x0 onto the plane x − 0.5·z = x0: rest normal +x
  // becomes ∝ (1, 0, −0.5). (Multiplying the normal by F, as the thesis did, would give (1,0,0).)
  auto o = block_options(-1.0, 0.0);
  TissueModel model(block_volume({20, 16, 14}, {2, 2, 2}, {18, 14, 12}), o);
  const crms::Lattice& l = model.solver().lattice();
  std::vector<Vec3f> du(static_cast<std::size_t>(l.node_count())), v(du.size());
  for (std::int64_t n = 0; n < l.node_count(); ++n)
    du[static_cast<std::size_t>(n)] = {0.5f * static_cast<float>(l.geometry().rest_position(n).z),
                                       0, 0};
  model.solver().set_state(du, v);
  model.couple();
  const Vec3d expect = normalized_or_zero(Vec3d{1, 0, -0.5});
  std::size_t top = 0;
  for (std::uint32_t s = 1; s < model.surface().vertex_slot_count(); ++s) {
    if (!model.surface().vertex_live(s)) continue;
    const Vec3f r = model.surface().normals()[s];
    const Vec3f p = model.surface().positions()[s];
    // Flat part of the +x face (away from edges, where IMT normals are exactly +x).
    if (r.x < 0.999f || p.z < 5 || p.z > 9 || p.y < 5 || p.y > 11) continue;
    ++top;
    EXPECT_LT(length(to_double(model.coupler().normals()[s]) - expect), 1e-4) << "slot " << s;
  }
  EXPECT_GT(top, 20u);
}

TEST(Coupler, LocalFrameEqualsTrilinearUnderAffineMotionAndDiffersUnderBending) {
  auto make = [](CouplerMode mode) {
    auto o = block_options(-1.0, 0.0);
    o.coupler_mode = mode;
    return std::make_unique<TissueModel>(block_volume({20, 16, 14}, {2, 2, 2}, {18, 14, 12}), o);
  };
  auto tri = make(CouplerMode::kTrilinear), frame = make(CouplerMode::kLocalFrame);
  const crms::Lattice& l = tri->solver().lattice();
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<Vec3f> du(static_cast<std::size_t>(l.node_count())), v(du.size());
    for (std::int64_t n = 0; n < l.node_count(); ++n) {
      const Vec3d p = l.geometry().rest_position(n);
      // pass 0: affine (stretch + shear); pass 1: bending z += 0.02·x².
      du[static_cast<std::size_t>(n)] =
          pass == 0 ? to_float(Vec3d{0.1 * p.x + 0.2 * p.y, -0.05 * p.y, 0.1 * p.x})
                    : to_float(Vec3d{0, 0, 0.02 * p.x * p.x});
    }
    tri->solver().set_state(du, v);
    frame->solver().set_state(du, v);
    tri->couple();
    frame->couple();
    double worst = 0;
    for (std::uint32_t s = 1; s < tri->surface().vertex_slot_count(); ++s)
      if (tri->surface().vertex_live(s))
        worst = std::max(worst, length(to_double(tri->coupler().positions()[s] -
                                                 frame->coupler().positions()[s])));
    if (pass == 0)
      EXPECT_LT(worst, 1e-4) << "affine motion: the two modes must agree";
    else
      EXPECT_GT(worst, 1e-3) << "bending: the local frame cannot follow the curvature";
  }
}

TEST(Coupler, RecouplingAnUnchangedStateStampsNoBlock) {
  TissueModel model(block_volume({24, 14, 14}, {2, 2, 2}, {22, 12, 12}), block_options(4.0));
  model.advance(1e-3);
  const std::uint64_t v = model.coupler().version();
  model.couple();
  EXPECT_TRUE(model.coupler().changed_ranges(v).empty());
  model.advance(1e-3);
  const auto ranges = model.coupler().changed_ranges(v);
  ASSERT_FALSE(ranges.empty());
  std::uint32_t covered = 0;
  for (const auto& r : ranges) {
    EXPECT_LT(r.first, r.second);
    covered += r.second - r.first;
  }
  EXPECT_LE(covered, model.surface().vertex_slot_count());
}

}  // namespace
}  // namespace tsf::coupler
