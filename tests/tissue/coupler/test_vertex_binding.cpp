// Binding vertices across cuts, and inferring the corners a vertex cannot use: a vertex follows
// its own side of a cut, and missing corners follow the known ones exactly under the motions the
// inference claims (cube_corners.h).
#include <gtest/gtest.h>

#include <cmath>

#include "tsf/coupler/cube_corners.h"
#include "tsf/coupler/vertex_binder.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::coupler {
namespace {

crms::Lattice box_lattice() {
  crms::BoxLatticeOptions o;
  o.size_mm = {8, 8, 8};
  o.spacing_mm = 2.0;
  return crms::build_box_lattice(o);  // 4×4×4 nodes at 1, 3, 5, 7 mm
}

TEST(VertexBinding, AVertexOnACutFaceFollowsItsOwnSide) {
  crms::Lattice l = box_lattice();
  const crms::LatticeGeometry& g = l.geometry();
  // Cut between node layers x = 1 and x = 2 (rest x = 3 and 5 mm).
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j) l.break_spring(g.index(1, j, k), crms::make_direction(0, +1));
  VertexBinder binder(l);
  // A vertex at x = 3.6 mm on the left piece's cut face: its normal points across the gap (+x).
  const BindingResult left = binder.bind({3.6f, 4.0f, 4.0f}, {1, 0, 0});
  const BindingResult right = binder.bind({4.4f, 4.0f, 4.0f}, {-1, 0, 0});
  EXPECT_EQ(left.binding.cell, right.binding.cell);
  for (int c = 0; c < 8; ++c) {
    EXPECT_EQ((left.sources >> c) & 1u, corner_bit(c, 0) == 0 ? 1u : 0u) << "corner " << c;
    EXPECT_EQ((right.sources >> c) & 1u, corner_bit(c, 0) == 1 ? 1u : 0u) << "corner " << c;
  }
  EXPECT_FALSE(left.orphan);
  EXPECT_FALSE(right.orphan);
  // Without the cut both see all 8 corners.
  crms::Lattice whole = box_lattice();
  VertexBinder b2(whole);
  EXPECT_EQ(b2.bind({3.6f, 4.0f, 4.0f}, {1, 0, 0}).sources & kCornerBits, 0xffu);
}

/// A reader over a function of node coordinates (the "true" deformation).
template <typename Motion>
struct MotionReader {
  Motion motion;
  float h[3];
  std::uint32_t alive_mask;  // corners alive (offsets within the cube at cell 0)
  Int3 cell;
  bool displacement(int i, int j, int k, Vec3f& u) const {
    const int ox = i - cell.x, oy = j - cell.y, oz = k - cell.z;
    if (ox >= 0 && ox <= 1 && oy >= 0 && oy <= 1 && oz >= 0 && oz <= 1 &&
        !((alive_mask >> (ox + 2 * oy + 4 * oz)) & 1u))
      return false;
    const Vec3f r{static_cast<float>(i) * h[0], static_cast<float>(j) * h[1],
                  static_cast<float>(k) * h[2]};
    u = motion(r) - r;
    return true;
  }
};

TEST(VertexBinding, InferredCornersAreExactForTheMotionsTheFitClaims) {
  const float h[3] = {2.0f, 2.0f, 3.0f};
  const Int3 cell{3, 3, 3};
  const Vec3f origin{6, 6, 9};
  const Rotation rot = Rotation::about_axis({1, 1, 0}, 0.6);
  auto rigid = [&](const Vec3f& r) {
    return to_float(rot.apply(to_double(r)) * 1.2) + Vec3f{1, -2, 0.5f};
  };
  auto affine = [&](const Vec3f& r) {
    return Vec3f{1.1f * r.x + 0.2f * r.y, 0.9f * r.y + 0.1f * r.z, 1.3f * r.z - 0.1f * r.x};
  };
  struct Case {
    std::uint32_t alive;
    bool with_outside;
    bool affine_exact;
  };
  // 5 corners (3-D): affine exact. A face (coplanar): similarity exact. A face plus its outside
  // neighbours: affine exact again. One edge: similarity exact (rotation + scale on the line),
  // checked with a rotation about that edge's axis only.
  for (const Case& c :
       {Case{0x1fu, false, true}, Case{0x0fu, false, false}, Case{0x0fu, true, true}}) {
    for (int m = 0; m < 2; ++m) {
      if (m == 1 && !c.affine_exact) continue;
      Vec3f q[8];
      const std::uint32_t sources = c.alive | (c.with_outside ? 0xffffff00u : 0u);
      bool ok;
      if (m == 0) {
        MotionReader<decltype(rigid)> r{rigid, {h[0], h[1], h[2]}, c.alive, cell};
        ok = resolve_cube_corners(r, cell, h, sources, q);
      } else {
        MotionReader<decltype(affine)> r{affine, {h[0], h[1], h[2]}, c.alive, cell};
        ok = resolve_cube_corners(r, cell, h, sources, q);
      }
      ASSERT_TRUE(ok);
      for (int k = 0; k < 8; ++k) {
        const Vec3f r{static_cast<float>(cell.x + corner_bit(k, 0)) * h[0],
                      static_cast<float>(cell.y + corner_bit(k, 1)) * h[1],
                      static_cast<float>(cell.z + corner_bit(k, 2)) * h[2]};
        const Vec3f expected = (m == 0 ? rigid(r) : affine(r)) - origin;
        EXPECT_LT(length(q[k] - expected), 2e-4f)
            << "alive " << c.alive << " outside " << c.with_outside << " motion " << m << " corner "
            << k;
      }
    }
  }
  // A single known corner: translation only.
  auto shift = [](const Vec3f& r) { return r + Vec3f{0.5f, 0.25f, -1.0f}; };
  MotionReader<decltype(shift)> r{shift, {h[0], h[1], h[2]}, 0x01u, cell};
  Vec3f q[8];
  ASSERT_TRUE(resolve_cube_corners(r, cell, h, 0x01u, q));
  for (int k = 0; k < 8; ++k)
    EXPECT_LT(length(q[k] - (rest_offset(corner_bit(k, 0), corner_bit(k, 1), corner_bit(k, 2), h) +
                             Vec3f{0.5f, 0.25f, -1.0f})),
              1e-5f);
  // Nothing known: not bound.
  EXPECT_FALSE(resolve_cube_corners(r, cell, h, 0u, q));
}

}  // namespace
}  // namespace tsf::coupler
