#include "tsf/imt/bcc_lattice.h"

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <utility>

namespace tsf::imt {
namespace {

double det(const double a[3], const double b[3], const double c[3]) {
  return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
         a[2] * (b[0] * c[1] - b[1] * c[0]);
}

TEST(BccLattice, TwelvePositiveTetrahedraFillACubesWorthOfSpace) {
  double total = 0;
  for (int t = 0; t < kTetsPerCube; ++t) {
    const auto& p = kCubeTets.tet[t].point;
    double u[3], v[3], w[3];
    for (int k = 0; k < 3; ++k) {
      u[k] = 0.5 * (p[1][k] - p[0][k]);  // doubled -> index units
      v[k] = 0.5 * (p[2][k] - p[0][k]);
      w[k] = 0.5 * (p[3][k] - p[0][k]);
    }
    const double vol = det(u, v, w) / 6.0;
    EXPECT_GT(vol, 0.0) << "tet " << t << " is not positively oriented";
    total += vol;
  }
  EXPECT_DOUBLE_EQ(total, 1.0);  // the BCC tetrahedra tile space: one cube's worth per cube
}

TEST(BccLattice, EveryTetEdgeIsALatticeEdgeOwnedNearby) {
  for (int t = 0; t < kTetsPerCube; ++t)
    for (int e = 0; e < 6; ++e) {
      const auto& r = kCubeTets.tet[t].edge_ref[e];
      ASSERT_LT(r.slot, kSlotCornerPoint);
      for (int k = 0; k < 3; ++k) ASSERT_TRUE(r.offset[k] >= -1 && r.offset[k] <= 1);
      // The slot's canonical end points are the tet edge's end points (either order).
      const auto& s = kSlotEndpoints.s[r.slot];
      const auto& a = kCubeTets.tet[t].point[kTetEdgeA[e]];
      const auto& b = kCubeTets.tet[t].point[kTetEdgeB[e]];
      auto at = [&](const std::int8_t* q, const std::int8_t* x) {
        for (int k = 0; k < 3; ++k)
          if (q[k] != x[k] + 2 * r.offset[k]) return false;
        return true;
      };
      EXPECT_TRUE((at(a, s.p0) && at(b, s.p1)) || (at(a, s.p1) && at(b, s.p0)))
          << "tet " << t << " edge " << e;
    }
}

TEST(BccLattice, CaseTableOrientsTrianglesFromInsideToOutside) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    // A random positively oriented tetrahedron and random crossing positions.
    double P[4][3];
    for (auto& p : P)
      for (double& x : p) x = u(rng);
    double a[3], b[3], c[3];
    for (int k = 0; k < 3; ++k) {
      a[k] = P[1][k] - P[0][k];
      b[k] = P[2][k] - P[0][k];
      c[k] = P[3][k] - P[0][k];
    }
    if (det(a, b, c) < 0)
      for (int k = 0; k < 3; ++k) std::swap(P[0][k], P[1][k]);
    for (int mask = 1; mask < 15; ++mask) {
      double in_c[3] = {}, out_c[3] = {};
      int ni = 0, no = 0;
      for (int v = 0; v < 4; ++v)
        for (int k = 0; k < 3; ++k) ((mask >> v) & 1 ? in_c : out_c)[k] += P[v][k];
      for (int v = 0; v < 4; ++v) ((mask >> v) & 1 ? ni : no)++;
      const TetCase& tc = kTetCases.c[mask];
      ASSERT_EQ(tc.triangle_count, (ni == 2) ? 2 : 1);
      for (int t = 0; t < tc.triangle_count; ++t) {
        double q[3][3];
        for (int k = 0; k < 3; ++k) {
          const int e = tc.triangle[t][k];
          const double f = 0.2 + 0.6 * (0.5 + 0.5 * u(rng));
          for (int i = 0; i < 3; ++i)
            q[k][i] = P[kTetEdgeA[e]][i] + f * (P[kTetEdgeB[e]][i] - P[kTetEdgeA[e]][i]);
        }
        const double e1[3] = {q[1][0] - q[0][0], q[1][1] - q[0][1], q[1][2] - q[0][2]};
        const double e2[3] = {q[2][0] - q[0][0], q[2][1] - q[0][1], q[2][2] - q[0][2]};
        const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                             e1[0] * e2[1] - e1[1] * e2[0]};
        double d = 0;
        for (int i = 0; i < 3; ++i) d += n[i] * (out_c[i] / no - in_c[i] / ni);
        EXPECT_GT(d, 0.0) << "mask " << mask << " triangle " << t;
      }
    }
  }
}

TEST(BccLattice, LinkOfAPointIsASphereOf14Neighbours) {
  int edges = 0;
  for (int i = 0; i < 14; ++i) edges += __builtin_popcount(kNeighbours.adjacent[i]);
  EXPECT_EQ(edges / 2, 36);  // V − E + F = 14 − 36 + 24 = 2
  EXPECT_TRUE(link_connected(0x3FFF));
  EXPECT_TRUE(link_connected(0));
  // The two axis neighbours ±x alone are not adjacent: a disconnected set.
  EXPECT_FALSE(link_connected(0b11));
}

TEST(BccLattice, BodyCentreStaysOnItsCornersSide) {
  const float corners[8] = {0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5000001f};
  EXPECT_GE(body_centre_value(corners), 0.5f);
  const float mixed[8] = {0, 1, 0, 1, 0, 1, 0, 1};
  EXPECT_FLOAT_EQ(body_centre_value(mixed), 0.5f);
}

}  // namespace
}  // namespace tsf::imt
