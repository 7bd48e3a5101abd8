// The per-node force (node_force.h): zero at rest, Hooke's law per spring, angular restoring
// direction, momentum conservation of the symmetric form, exact Jacobian by dual numbers, and the
// float asin polynomial.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "tsf/common/error.h"
#include "tsf/crms/calibration.h"
#include "tsf/crms/dual.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/node_force.h"
#include "tsf/crms/node_force_planes.h"
#include "tsf/crms/stencil.h"

namespace tsf::crms {
namespace {

/// A small lattice held in host arrays, all nodes alive and linked, for calling the force
/// functions directly.
struct HostLattice {
  Int3 dims;
  float rest[3];
  std::vector<std::uint8_t> flags;
  std::vector<float> inv_mass;
  std::vector<std::uint8_t> material;                                  // one palette entry per node
  mutable std::vector<std::uint32_t> material_index, material_weight;  // its blends for the view
  std::vector<float> u[3], v[3];

  HostLattice(Int3 d, float h) : dims(d), rest{h, h, h} {
    const auto n = static_cast<std::size_t>(d.volume());
    flags.assign(n, 0);
    inv_mass.assign(n, 1.0f);
    material.assign(n, 0);
    for (auto& c : u) c.assign(n, 0.0f);
    for (auto& c : v) c.assign(n, 0.0f);
    for (int k = 0; k < d.z; ++k)
      for (int j = 0; j < d.y; ++j)
        for (int i = 0; i < d.x; ++i) {
          std::uint8_t f = kAliveBit;
          const int c[3] = {i, j, k};
          for (int dir = 0; dir < 6; ++dir) {
            const int a = direction_axis(dir), s = direction_sign(dir);
            const int dims_a = a == 0 ? d.x : (a == 1 ? d.y : d.z);
            if (c[a] + s >= 0 && c[a] + s < dims_a) f |= static_cast<std::uint8_t>(1u << dir);
          }
          flags[index(i, j, k)] = f;
        }
  }
  std::int64_t index(int i, int j, int k) const {
    return i + static_cast<std::int64_t>(dims.x) * (j + static_cast<std::int64_t>(dims.y) * k);
  }
  LatticeView view() const {
    LatticeView l;
    l.dims = dims;
    l.count = dims.volume();
    l.stride_y = dims.x;
    l.stride_z = static_cast<std::int64_t>(dims.x) * dims.y;
    for (int a = 0; a < 3; ++a) l.rest_length[a] = rest[a];
    l.flags = flags.data();
    l.inv_mass = inv_mass.data();
    material_index.assign(material.begin(), material.end());
    material_weight.assign(material.size(), 255u);
    l.material_index = material_index.data();
    l.material_weight = material_weight.data();
    return l;
  }
  ConstStateView state() const {
    ConstStateView s;
    for (int a = 0; a < 3; ++a) {
      s.u[a] = u[a].data();
      s.v[a] = v[a].data();
    }
    return s;
  }
  template <unsigned F>
  Vec3f force(int i, int j, int k, const MaterialPalette& p) const {
    const IndexedStencil st{view(), state(), index(i, j, k), i, j, k};
    return spring_force<F>(st, rest, p);
  }
  void set_u(int i, int j, int k, Vec3f d) {
    for (int a = 0; a < 3; ++a) u[a][index(i, j, k)] = d[a];
  }
};

MaterialPalette palette_of(const SpringConstants& s) {
  MaterialPalette p;
  p.entry[0] = s;
  p.count = 1;
  return p;
}

SpringConstants unit_springs() {
  SpringConstants s;
  for (int a = 0; a < 3; ++a) {
    s.ks_linear[a] = 2.0f;
    s.kd_linear[a] = 0.1f;
    s.k_angular[a] = 0.5f;
    s.c_angular[a] = 0.05f;
  }
  return s;
}

TEST(CrmsNodeForce, RestStateHasExactlyZeroForce) {
  HostLattice l({4, 3, 3}, 1.5f);
  const MaterialPalette p = palette_of(unit_springs());
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i) {
        EXPECT_EQ(l.force<0>(i, j, k, p), (Vec3f{0, 0, 0}));
        EXPECT_EQ(l.force<features::kSymmetricReactions>(i, j, k, p), (Vec3f{0, 0, 0}));
        EXPECT_EQ(l.force<features::kCosineAngular>(i, j, k, p), (Vec3f{0, 0, 0}));
      }
}

TEST(CrmsNodeForce, LinearSpringFollowsHookesLawInStrain) {
  // Two nodes along x: stretching the pair by 10% pulls each end towards the other with ks·0.1.
  HostLattice l({2, 1, 1}, 2.0f);
  SpringConstants s{};
  s.ks_linear[0] = 3.0f;
  const MaterialPalette p = palette_of(s);
  l.set_u(1, 0, 0, {0.2f, 0, 0});
  const Vec3f f0 = l.force<0>(0, 0, 0, p), f1 = l.force<0>(1, 0, 0, p);
  EXPECT_NEAR(f0.x, 3.0f * 0.1f, 1e-6f);
  EXPECT_NEAR(f1.x, -3.0f * 0.1f, 1e-6f);
  EXPECT_EQ(f0.y, 0.0f);
  // Damping: relative velocity 0.4 mm/s along the spring = strain rate 0.2/s.
  s.kd_linear[0] = 5.0f;
  l.set_u(1, 0, 0, {0, 0, 0});
  l.v[0][1] = 0.4f;
  EXPECT_NEAR(l.force<0>(0, 0, 0, palette_of(s)).x, 5.0f * 0.2f, 1e-6f);
}

TEST(CrmsNodeForce, AngularSpringOpensAClosedAngle) {
  // An L of three nodes (arm +x and arm +y at the corner). Closing the angle by moving the +y arm
  // towards +x pushes the corner along the bisector (towards the arms), opening the angle.
  HostLattice l({2, 2, 1}, 1.0f);
  // Kill node (1,1,0) so that the corner (0,0,0) has exactly one angle.
  l.flags[l.index(1, 1, 0)] = 0;
  l.flags[l.index(1, 0, 0)] &= static_cast<std::uint8_t>(~(1u << 3));
  l.flags[l.index(0, 1, 0)] &= static_cast<std::uint8_t>(~(1u << 1));
  SpringConstants s{};
  s.k_angular[2] = 1.0f;  // xy plane
  const MaterialPalette p = palette_of(s);
  const float delta = 0.2f;  // rad
  l.set_u(0, 1, 0, {std::sin(delta), std::cos(delta) - 1.0f, 0});
  const Vec3f f = l.force<0>(0, 0, 0, p);
  EXPECT_GT(f.x, 0.0f);
  EXPECT_GT(f.y, 0.0f);
  // Magnitude k·δ·|∇_B θ| with |∇_B θ| = sqrt(2(1 − c))/h for equal arms (c = cos θ).
  const float c = std::cos(1.5707963f - delta);
  EXPECT_NEAR(std::sqrt(dot(f, f)), delta * std::sqrt(2.0f * (1.0f - c)), 1e-4f);
  // The cosine form pushes the same way with k·cos θ instead of k·δ.
  const Vec3f fc = l.force<features::kCosineAngular>(0, 0, 0, p);
  EXPECT_GT(dot(f, fc), 0.0f);
}

template <unsigned F>
void expect_zero_total_force_for_random_deformation(unsigned seed) {
  HostLattice l({4, 4, 4}, 1.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.15f, 0.15f);
  for (int a = 0; a < 3; ++a)
    for (std::size_t n = 0; n < l.u[a].size(); ++n) {
      l.u[a][n] = jitter(rng);
      l.v[a][n] = 10.0f * jitter(rng);
    }
  const MaterialPalette p = palette_of(unit_springs());
  Vec3d total{0, 0, 0};
  double scale = 0;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        const Vec3f f = l.force<F>(i, j, k, p);
        total += to_double(f);
        scale += std::sqrt(static_cast<double>(dot(f, f)));
      }
  EXPECT_LT(std::sqrt(dot(total, total)), 1e-5 * scale) << "features " << F;
}

TEST(CrmsNodeForce, SymmetricReactionsConserveMomentum) {
  expect_zero_total_force_for_random_deformation<features::kSymmetricReactions>(1);
  expect_zero_total_force_for_random_deformation<features::kSymmetricReactions |
                                                 features::kCosineAngular>(2);
}

TEST(CrmsNodeForce, GatherFormDoesNotConserveMomentumOfAngles) {
  // Documented property of the thesis form: without arm reactions the angular forces do not sum
  // to zero (the reason the symmetric knob exists).
  HostLattice l({3, 3, 1}, 1.0f);
  l.set_u(1, 1, 0, {0.1f, 0.05f, 0});
  l.set_u(2, 1, 0, {0.0f, 0.2f, 0});
  SpringConstants s{};
  for (int a = 0; a < 3; ++a) s.k_angular[a] = 1.0f;
  const MaterialPalette p = palette_of(s);
  Vec3d total{0, 0, 0};
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) total += to_double(l.force<0>(i, j, 0, p));
  EXPECT_GT(std::sqrt(dot(total, total)), 1e-3);
}

/// The shared evaluation's decomposition: self(n) + the reactions its neighbours' angles put on
/// it equals the per-node force of the whole 19-node stencil, and reaction_towards() is exactly
/// node_spring_terms()'s reaction, on a deformed, moving lattice with a dead node, a broken link
/// and two materials.
/// A deformed, moving 5×4×4 lattice with a dead node, a broken link and two materials.
HostLattice deformed_two_material_lattice(unsigned seed, MaterialPalette& p) {
  HostLattice l({5, 4, 4}, 1.25f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.2f, 0.2f);
  for (int a = 0; a < 3; ++a)
    for (std::size_t n = 0; n < l.u[a].size(); ++n) {
      l.u[a][n] = jitter(rng);
      l.v[a][n] = 20.0f * jitter(rng);
    }
  // Node (2,2,2) dead: no links on either side; the +y spring of (1,1,1) broken on both ends.
  const std::int64_t dead = l.index(2, 2, 2);
  l.flags[dead] = 0;
  for (int d = 0; d < 6; ++d) {
    const Int3 o = direction_offset(d);
    l.flags[l.index(2 + o.x, 2 + o.y, 2 + o.z)] &=
        static_cast<std::uint8_t>(~(1u << opposite_direction(d)));
  }
  l.flags[l.index(1, 1, 1)] &= static_cast<std::uint8_t>(~(1u << 3));
  l.flags[l.index(1, 2, 1)] &= static_cast<std::uint8_t>(~(1u << 2));
  p = palette_of(unit_springs());
  p.entry[1] = unit_springs();
  for (int a = 0; a < 3; ++a) {
    p.entry[1].ks_linear[a] *= 3.0f;
    p.entry[1].k_angular[a] *= 5.0f;
    p.entry[1].c_angular[a] *= 0.5f;
  }
  p.count = 2;
  for (std::size_t n = 0; n < l.material.size(); ++n) l.material[n] = (n % 3 == 0) ? 1 : 0;
  return l;
}

template <unsigned F>
void expect_shared_terms_match_per_node_force(unsigned seed) {
  MaterialPalette p;
  HostLattice l = deformed_two_material_lattice(seed, p);
  const LatticeView view = l.view();
  const ConstStateView state = l.state();
  auto stencil = [&](int i, int j, int k) {
    return IndexedStencil{view, state, l.index(i, j, k), i, j, k};
  };
  double worst = 0, scale = 0;
  for (int k = 0; k < l.dims.z; ++k)
    for (int j = 0; j < l.dims.y; ++j)
      for (int i = 0; i < l.dims.x; ++i) {
        NodeSpringTerms<float> own;
        node_spring_terms<F>(stencil(i, j, k), l.rest, p, own);
        for (int d = 0; d < 6; ++d)
          EXPECT_EQ(reaction_towards<F>(stencil(i, j, k), d, l.rest, p), own.reaction[d])
              << "node (" << i << "," << j << "," << k << ") direction " << d;
        Vec3f shared = own.self;
        const unsigned links = l.flags[l.index(i, j, k)] & kLinkBits;
        for (int d = 0; d < 6; ++d) {
          if (!((links >> d) & 1u)) continue;
          const Int3 o = direction_offset(d);
          NodeSpringTerms<float> nb;
          node_spring_terms<F>(stencil(i + o.x, j + o.y, k + o.z), l.rest, p, nb);
          shared += nb.reaction[opposite_direction(d)];
        }
        const Vec3f per_node = spring_force<F>(stencil(i, j, k), l.rest, p);
        worst = std::max(worst, static_cast<double>(length(shared - per_node)));
        scale = std::max(scale, static_cast<double>(length(per_node)));
      }
  EXPECT_GT(scale, 0.1);
  EXPECT_LE(worst, 2e-6 * scale) << "features " << F;
}

TEST(CrmsNodeForce, SharedTermsEqualThePerNodeForce) {
  using namespace features;
  expect_shared_terms_match_per_node_force<kSymmetricReactions>(3);
  expect_shared_terms_match_per_node_force<kSymmetricReactions | kCosineAngular>(4);
  expect_shared_terms_match_per_node_force<kSymmetricReactions | kHeterogeneous>(5);
  expect_shared_terms_match_per_node_force<kSymmetricReactions | kHeterogeneous | kCosineAngular>(
      6);
}

/// The plane split of node_force_planes.h: on the same deformed lattice, the three planes' self
/// terms add up to node_spring_terms' self and the reactions of the two planes holding an arm add
/// up to its reaction, for every node (the CUDA node-parallel kernel's decomposition).
template <unsigned F>
void expect_plane_terms_sum_to_node_terms(unsigned seed) {
  MaterialPalette p;
  HostLattice l = deformed_two_material_lattice(seed, p);
  double worst = 0, scale = 0;
  for (int k = 0; k < l.dims.z; ++k)
    for (int j = 0; j < l.dims.y; ++j)
      for (int i = 0; i < l.dims.x; ++i) {
        const IndexedStencil st{l.view(), l.state(), l.index(i, j, k), i, j, k};
        NodeSpringTerms<float> own;
        node_spring_terms<F>(st, l.rest, p, own);
        Vec3f self[3], reaction[3][4];
        plane_spring_terms<F, 0>(st, l.rest, p, self[0], reaction[0]);
        plane_spring_terms<F, 1>(st, l.rest, p, self[1], reaction[1]);
        plane_spring_terms<F, 2>(st, l.rest, p, self[2], reaction[2]);
        const Vec3f total = self[0] + self[1] + self[2];
        worst = std::max(worst, static_cast<double>(length(total - own.self)));
        scale = std::max(scale, static_cast<double>(length(own.self)));
        for (int d = 0; d < 6; ++d) {
          Vec3f r{0, 0, 0};
          int planes = 0;
          for (int plane = 0; plane < 3; ++plane) {
            if (plane == direction_axis(d)) continue;
            const int q = plane_arm_slot(plane, d);
            EXPECT_EQ(plane_arm_direction(plane, q), d);
            r += reaction[plane][q];
            ++planes;
          }
          EXPECT_EQ(planes, 2);
          worst = std::max(worst, static_cast<double>(length(r - own.reaction[d])));
        }
      }
  EXPECT_GT(scale, 0.1);
  EXPECT_LE(worst, 1e-6 * scale) << "features " << F;
}

TEST(CrmsNodeForce, PlaneTermsSumToTheNodeTerms) {
  using namespace features;
  expect_plane_terms_sum_to_node_terms<kSymmetricReactions>(7);
  expect_plane_terms_sum_to_node_terms<kSymmetricReactions | kCosineAngular>(8);
  expect_plane_terms_sum_to_node_terms<kSymmetricReactions | kHeterogeneous>(9);
  expect_plane_terms_sum_to_node_terms<kSymmetricReactions | kHeterogeneous | kCosineAngular |
                                       kExternalForces>(10);
}

TEST(CrmsNodeForce, GatherFormSelfIsTheWholeForce) {
  // Without symmetric reactions a node's own terms are its whole spring force.
  HostLattice l({3, 3, 3}, 1.0f);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> jitter(-0.2f, 0.2f);
  for (int a = 0; a < 3; ++a)
    for (std::size_t n = 0; n < l.u[a].size(); ++n) l.u[a][n] = jitter(rng);
  const MaterialPalette p = palette_of(unit_springs());
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) {
        const IndexedStencil st{l.view(), l.state(), l.index(i, j, k), i, j, k};
        NodeSpringTerms<float> t;
        node_spring_terms<0>(st, l.rest, p, t);
        EXPECT_EQ(t.self, spring_force<0>(st, l.rest, p));
      }
}

TEST(CrmsEffects, UncompiledFeatureSetIsRejectedNamingItsBits) {
  const unsigned unknown = 1u << 9;
  EXPECT_FALSE(is_compiled_feature_set(unknown));
  for (unsigned set = 0; set <= features::kAll; ++set) EXPECT_TRUE(is_compiled_feature_set(set));
  try {
    dispatch_features(unknown | features::kSymmetricReactions, [](auto) {});
    ADD_FAILURE() << "an uncompiled feature set was dispatched";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("0x202"), std::string::npos) << what;
    EXPECT_NE(what.find("symmetric-reactions"), std::string::npos) << what;
    EXPECT_NE(what.find("CompiledFeatureSets"), std::string::npos) << what;
  }
}

/// Dual-number stencil over a HostLattice (double copies), seeding one node.
struct DualHostStencil {
  using Scalar = Dual<6>;
  const HostLattice& l;
  std::int64_t n;
  int i, j, k;
  std::int64_t seed;
  std::int64_t at(int slot) const { return stencil_node(l.view(), n, i, j, k, slot); }
  Vec3<Scalar> load(const std::vector<float>* a, int slot, int off) const {
    const std::int64_t m = at(slot);
    Vec3<Scalar> r{Scalar(a[0][m]), Scalar(a[1][m]), Scalar(a[2][m])};
    if (m == seed) {
      r.x.d[off] = 1;
      r.y.d[off + 1] = 1;
      r.z.d[off + 2] = 1;
    }
    return r;
  }
  Vec3<Scalar> u(int slot) const { return load(l.u, slot, 0); }
  Vec3<Scalar> v(int slot) const { return load(l.v, slot, 3); }
  unsigned flags(int slot) const { return l.flags[at(slot)]; }
  MaterialBlend material(int slot) const { return MaterialBlend::single(l.material[at(slot)]); }
};

template <unsigned F>
void expect_dual_jacobian_matches_finite_differences() {
  HostLattice l({3, 3, 3}, 1.0f);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> jitter(-0.1f, 0.1f);
  for (int a = 0; a < 3; ++a)
    for (std::size_t n = 0; n < l.u[a].size(); ++n) {
      l.u[a][n] = jitter(rng);
      l.v[a][n] = jitter(rng);
    }
  const MaterialPalette p = palette_of(unit_springs());
  const std::int64_t centre = l.index(1, 1, 1);
  // Derivative with respect to a face neighbour and to the node itself (and an edge node for
  // the symmetric form).
  const std::int64_t seeds[3] = {centre, l.index(2, 1, 1), l.index(2, 2, 1)};
  for (std::int64_t seed : seeds) {
    const DualHostStencil st{l, centre, 1, 1, 1, seed};
    const Vec3<Dual<6>> fd = spring_force<F>(st, l.rest, p);
    for (int q = 0; q < 6; ++q) {
      // Central difference in double through the Dual type with zero seeds.
      const float h = 1e-3f;
      auto eval = [&](float delta) {
        HostLattice m = l;
        std::vector<float>& component = q < 3 ? m.u[q] : m.v[q - 3];
        component[static_cast<std::size_t>(seed)] += delta;
        const DualHostStencil s2{m, centre, 1, 1, 1, -1};
        const Vec3<Dual<6>> f = spring_force<F>(s2, m.rest, p);
        return Vec3d{f.x.v, f.y.v, f.z.v};
      };
      const Vec3d numeric = (eval(h) - eval(-h)) / (2.0 * static_cast<double>(h));
      for (int r = 0; r < 3; ++r)
        EXPECT_NEAR(fd[r].d[q], numeric[r], 2e-3 * (1.0 + std::fabs(numeric[r])))
            << "features " << F << " seed " << seed << " variable " << q << " row " << r;
    }
  }
}

TEST(CrmsNodeForce, DualJacobianMatchesFiniteDifferences) {
  expect_dual_jacobian_matches_finite_differences<0>();
  expect_dual_jacobian_matches_finite_differences<features::kCosineAngular>();
  expect_dual_jacobian_matches_finite_differences<features::kSymmetricReactions>();
}

TEST(CrmsNodeForce, FloatAsinPolynomialIsAccurate) {
  double worst = 0;
  for (int s = -10000; s <= 10000; ++s) {
    const float x = static_cast<float>(s) / 10000.0f;
    worst = std::max(
        worst, std::fabs(static_cast<double>(crms_asin(x)) - std::asin(static_cast<double>(x))));
  }
  EXPECT_LT(worst, 5e-7);
}

TEST(CrmsNodeForce, FoldedAngleStaysFinite) {
  // A fully folded corner (arm +y pushed onto arm +x, sin θ = 0) must not produce Inf/NaN.
  HostLattice l({2, 2, 1}, 1.0f);
  l.set_u(0, 1, 0, {1.0f, -1.0f, 0.0f});  // node (0,1) on top of node (1,0)
  SpringConstants s = unit_springs();
  const MaterialPalette p = palette_of(s);
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const Vec3f f = l.force<0>(i, j, 0, p);
      EXPECT_TRUE(std::isfinite(f.x) && std::isfinite(f.y) && std::isfinite(f.z));
      const Vec3f fs = l.force<features::kSymmetricReactions>(i, j, 0, p);
      EXPECT_TRUE(std::isfinite(fs.x) && std::isfinite(fs.y) && std::isfinite(fs.z));
    }
}

}  // namespace
}  // namespace tsf::crms
