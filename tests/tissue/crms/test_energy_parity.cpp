// CPU vs CUDA energy: Solver::energy() evaluates one per-node formula (node_energy.h) on both
// backends and the effects' share on the host (effect_energy.h). With the same state the terms
// agree to 1e-4 of the largest term (float elastic terms, double sums in a different order);
// after stepping, where the states themselves differ by up to 1e-4 of the displacement
// (CrmsBackendParity), to 1e-3.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "physics_assertions.h"
#include "tsf/common/error.h"

namespace tsf::crms {
namespace {

/// Terms within `relative` × the largest term magnitude (of `a`).
::testing::AssertionResult same_energy(const EnergyReport& a, const EnergyReport& b,
                                       double relative) {
  const double scale =
      std::max({std::abs(a.kinetic_nj), std::abs(a.elastic_nj), std::abs(a.gravitational_nj)});
  if (!(scale > 0)) return ::testing::AssertionFailure() << "no energy to compare";
  const double terms[3][2] = {{a.kinetic_nj, b.kinetic_nj},
                              {a.elastic_nj, b.elastic_nj},
                              {a.gravitational_nj, b.gravitational_nj}};
  const char* names[3] = {"kinetic", "elastic", "gravitational"};
  for (int t = 0; t < 3; ++t)
    if (!(std::abs(terms[t][0] - terms[t][1]) <= relative * scale))
      return ::testing::AssertionFailure()
             << names[t] << " energy " << terms[t][0] << " nJ against " << terms[t][1]
             << " nJ: more than " << relative << " × " << scale << " nJ apart";
  return ::testing::AssertionSuccess();
}

/// A velocity field that gives every node some kinetic energy, mm/s.
Vec3f swirl(Vec3d p) {
  return to_float(Vec3d{20 * std::sin(p.y), 15 * std::cos(p.x), 10 * std::sin(p.x + p.z)});
}

/// The parity scene of CrmsBackendParity (anchored end, a dead node, optional second material
/// and external forces), its state set to a stretch-and-compress deformation with the swirl
/// velocity, under gravity.
std::unique_ptr<Solver> deformed_scene(Backend backend, unsigned combo,
                                       const EffectsConfig& effects) {
  auto [l, c] = test::parity_scene(backend, combo);
  c.gravity = {2000, -3000, -9810};  // x too: the deformation is along x
  c.effects = effects;
  auto s = std::make_unique<Solver>(std::move(l), c);
  test::with_parity_loads(*s, combo);
  const Lattice& lat = s->lattice();
  std::vector<Vec3f> u(static_cast<std::size_t>(lat.node_count())), v(u.size());
  for (std::int64_t n = 0; n < lat.node_count(); ++n) {
    const Vec3d p = lat.geometry().rest_position(n);
    u[n] = to_float(test::stretch_far_end_compress_rest(p) - p);
    v[n] = lat.fixed(n) ? Vec3f{0, 0, 0} : swirl(p);
  }
  s->set_state(u, v);
  return s;
}

/// Anisotropy, fluid and a rest keyframe: effects whose energy depends on the state alone (their
/// own arrays start at zero), so the same state must give the same energy.
EffectsConfig state_only_effects(std::int64_t nodes) {
  EffectsConfig e;
  e.anisotropy.enabled = true;
  e.anisotropy.axis = {1, 1, 0};
  e.anisotropy.stiffness_factor = 4;
  e.fluid.enabled = true;
  e.fluid.bulk_modulus_pa = 10e3;
  e.fluid.diffusion_rate = 100;
  e.animation.enabled = true;
  RestKeyframe key;
  key.time_s = 0.0;
  key.rest_displacement_mm.assign(static_cast<std::size_t>(nodes), Vec3f{0, 0, 0});
  for (std::size_t n = 0; n < key.rest_displacement_mm.size(); ++n)
    key.rest_displacement_mm[n] = Vec3f{0.02f * static_cast<float>(n % 7), 0, 0};
  e.animation.rest_keyframes.push_back(key);
  return e;
}

TEST(CrmsEnergyParity, SameStateSameEnergyOnEveryFeatureSet) {
  if (!cuda_status().available)
    GTEST_SKIP() << "CUDA energy parity not run: " << cuda_status().reason;
  for (unsigned combo = 0; combo < 16; ++combo) {
    const EnergyReport cpu = deformed_scene(Backend::kCpu, combo, {})->energy();
    const EnergyReport gpu = deformed_scene(Backend::kCuda, combo, {})->energy();
    EXPECT_GT(cpu.kinetic_nj, 0.0) << "combo " << combo;
    EXPECT_GT(cpu.elastic_nj, 0.0) << "combo " << combo;
    EXPECT_NE(cpu.gravitational_nj, 0.0) << "combo " << combo;
    EXPECT_TRUE(same_energy(cpu, gpu, 1e-4)) << "combo " << combo;
  }
}

TEST(CrmsEnergyParity, SameStateSameEnergyWithStateOnlyEffects) {
  if (!cuda_status().available)
    GTEST_SKIP() << "CUDA energy parity not run: " << cuda_status().reason;
  const std::int64_t nodes = test::box({12, 8, 6}, 1).node_count();
  for (unsigned combo : {0u, 1u, 8u, 9u}) {
    const EffectsConfig e = state_only_effects(nodes);
    const EnergyReport core = deformed_scene(Backend::kCpu, combo, {})->energy();
    const EnergyReport cpu = deformed_scene(Backend::kCpu, combo, e)->energy();
    const EnergyReport gpu = deformed_scene(Backend::kCuda, combo, e)->energy();
    EXPECT_NE(cpu.elastic_nj, core.elastic_nj) << "combo " << combo << ": effects add no energy";
    EXPECT_TRUE(same_energy(cpu, gpu, 1e-4)) << "combo " << combo;
  }
}

TEST(CrmsEnergyParity, EnergyAgreesAfterSteppingWithEveryEffect) {
  if (!cuda_status().available)
    GTEST_SKIP() << "CUDA energy parity not run: " << cuda_status().reason;
  EffectsConfig e = state_only_effects(test::box({12, 8, 6}, 1).node_count());
  e.plasticity.enabled = true;
  e.plasticity.recovery_rate = 50;
  std::vector<EnergyReport> energies;
  for (Backend backend : {Backend::kCpu, Backend::kCuda}) {
    const std::unique_ptr<Solver> s = deformed_scene(backend, 9, e);
    s->step(300, 0.5 * s->stable_dt());
    ASSERT_TRUE(test::assert_finite(*s)) << to_string(backend);
    energies.push_back(s->energy());
  }
  EXPECT_TRUE(same_energy(energies[0], energies[1], 1e-3));
}

}  // namespace
}  // namespace tsf::crms
