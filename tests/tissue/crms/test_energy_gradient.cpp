// Energy consistency (docs/stability.md "Energy consistency"): on random states, the force the
// kernels apply is minus the gradient of the energy the solver reports, by central finite
// differences, for the core elastic term (both angular forms, symmetric reactions) and for each
// effect that has an energy (anisotropy, plasticity's rest offsets, fluid, the volumetric term of a
// material with ν > 0; effect_energy.h, effect_physics.h and volume_term.h). An energy whose
// gradient is not the force would let the energy balance of the stability monitor pass a run that
// gains energy, or fail one that does not.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "physics_assertions.h"
#include "tsf/crms/effect_physics.h"

namespace tsf::crms {
namespace {

using test::box;
using test::soft_material;

/// A random state: displacements up to `amplitude` mm per component, zero velocity (the damping
/// forces vanish, leaving the elastic ones).
void randomise(Solver& s, double amplitude, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(static_cast<float>(-amplitude),
                                          static_cast<float>(amplitude));
  std::vector<Vec3f> u(static_cast<std::size_t>(s.lattice().node_count())), v(u.size());
  for (Vec3f& x : u) x = {d(rng), d(rng), d(rng)};
  s.set_state(u, v);
}

/// Central differences of the elastic energy at every coordinate of a few nodes against the
/// force `force(s)` (µN per node); the worst difference relative to the largest force.
template <typename Force>
double worst_gradient_error(Solver& s, Force force, double h = 1e-3) {
  const std::vector<Vec3f> u0 = s.displacements();
  const std::vector<Vec3f> v0(u0.size(), Vec3f{0, 0, 0});
  const std::vector<Vec3f> f = force(s);
  double scale = 0;
  for (const Vec3f& x : f) scale = std::max(scale, static_cast<double>(length(x)));
  double worst = 0;
  const std::int64_t count = s.lattice().node_count();
  for (std::int64_t n = 0; n < count; n += 7) {
    if (!s.lattice().alive(n) || s.lattice().fixed(n)) continue;
    for (int a = 0; a < 3; ++a) {
      std::vector<Vec3f> u = u0;
      u[n][a] = u0[n][a] + static_cast<float>(h);
      s.set_state(u, v0);
      const double plus = s.energy().elastic_nj;
      u[n][a] = u0[n][a] - static_cast<float>(h);
      s.set_state(u, v0);
      const double minus = s.energy().elastic_nj;
      const double gradient = (plus - minus) / (2 * h);
      worst = std::max(worst, std::fabs(gradient + static_cast<double>(f[n][a])) / scale);
    }
  }
  s.set_state(u0, v0);
  return worst;
}

std::vector<Vec3f> core_forces(const Solver& s) {
  return s.spring_forces();
}

TEST(CrmsEnergyGradient, ElasticForceIsMinusTheEnergyGradient) {
  for (AngularForm form : {AngularForm::kExact, AngularForm::kCosine}) {
    SolverConfig c;
    c.backend = Backend::kCpu;
    c.angular_form = form;
    c.materials = {soft_material(10e3), soft_material(200e3)};
    Lattice l = box({5, 4, 4}, 1);
    for (std::int64_t n = 0; n < l.node_count(); n += 3) l.set_material(n, 1);
    Solver s(std::move(l), c);
    randomise(s, 0.2, 17);
    EXPECT_LT(worst_gradient_error(s, core_forces), 2e-3) << to_string(form);
  }
}

TEST(CrmsEnergyGradient, GatherFormIsNotAGradient) {
  // The gather form's forces come from no potential (docs/crms.md): the same check must see it,
  // or it could not see a wrong energy either.
  SolverConfig c;
  c.backend = Backend::kCpu;
  c.angular_reactions = AngularReactions::kGather;
  c.materials = {soft_material(10e3)};
  Solver s(box({5, 4, 4}, 1), c);
  randomise(s, 0.2, 17);
  EXPECT_GT(worst_gradient_error(s, core_forces), 1e-2);
}

/// The core force plus the effects' (effect_physics.h pass 2, evaluated on the host from the CPU
/// solver's arrays), with the fluid cubes' pressures of the current state.
std::vector<Vec3f> core_and_effect_forces(const Solver& s, unsigned bits) {
  std::vector<Vec3f> f = s.spring_forces();
  const LatticeView lat = s.lattice_view();
  const ConstStateView st = s.state_view();
  EffectsState state = s.effects_state();
  const std::int64_t count = s.lattice().node_count();
  std::vector<float> offset[3];
  EffectArrays arrays;
  if (bits & effect_bits::kPlasticity)
    for (int a = 0; a < 3; ++a) {
      offset[a].resize(static_cast<std::size_t>(count));
      for (std::int64_t n = 0; n < count; ++n) offset[a][n] = state.plastic_offset[n][a];
      arrays.plastic_offset[a] = offset[a].data();
    }
  EffectParameters p;
  p.enabled = bits;
  p.palette = s.palette();
  const EffectsConfig& e = s.config().effects;
  const Vec3d axis = e.anisotropy.axis;
  const double a2 = dot(axis, axis);
  for (int a = 0; a < 3; ++a)
    p.aniso_extra[a] =
        static_cast<float>((e.anisotropy.stiffness_factor - 1.0) * axis[a] * axis[a] / a2);
  p.bulk_modulus = static_cast<float>(e.fluid.bulk_modulus_pa);
  std::vector<float> pressure(static_cast<std::size_t>(count), 0.0f);
  if (bits & effect_bits::kFluid) {
    arrays.fluid_content = state.fluid_content.data();
    arrays.fluid_pressure = pressure.data();
  }
  const LatticeGeometry& g = s.lattice().geometry();
  if (bits & effect_bits::kFluid)
    for (std::int64_t n = 0; n < count; ++n) {
      const Int3 c = g.coordinates(n);
      pressure[n] = cube_pressure(lat, st, arrays, p, n, c.x, c.y, c.z);
    }
  for (std::int64_t n = 0; n < count; ++n) {
    const Int3 c = g.coordinates(n);
    f[n] += effect_force(lat, st, arrays, p, n, c.x, c.y, c.z);
  }
  return f;
}

TEST(CrmsEnergyGradient, EachEffectForceIsMinusItsEnergyGradient) {
  struct Case {
    const char* name;
    unsigned bits;
  };
  for (const Case& k :
       {Case{"anisotropy", effect_bits::kAnisotropy}, Case{"plasticity", effect_bits::kPlasticity},
        Case{"fluid", effect_bits::kFluid}}) {
    SolverConfig c;
    c.backend = Backend::kCpu;
    c.materials = {soft_material(10e3)};
    c.effects.anisotropy.enabled = k.bits == effect_bits::kAnisotropy;
    c.effects.anisotropy.axis = {1, 2, 0.5};
    c.effects.anisotropy.stiffness_factor = 3;
    c.effects.plasticity.enabled = k.bits == effect_bits::kPlasticity;
    c.effects.plasticity.yield_strain = 0.02;
    c.effects.fluid.enabled = k.bits == effect_bits::kFluid;
    c.effects.fluid.bulk_modulus_pa = 20e3;
    Solver s(box({5, 4, 4}, 1), c);
    // Plastic offsets (and any fluid content) from a strained run first, then a random state.
    test::deform(s, [](Vec3d p) { return Vec3d{0.5 + 1.3 * (p.x - 0.5), p.y, p.z}; });
    s.step(200, 0.5 * s.stable_dt());
    randomise(s, 0.2, 29);
    if (k.bits == effect_bits::kPlasticity) {
      double largest = 0;
      for (const Vec3f& d : s.effects_state().plastic_offset)
        largest = std::max(largest, static_cast<double>(length(d)));
      ASSERT_GT(largest, 1e-3) << "the strained run left no plastic offset to test";
    }
    EXPECT_LT(
        worst_gradient_error(s, [&](const Solver& x) { return core_and_effect_forces(x, k.bits); }),
        2e-3)
        << k.name;
  }
}

TEST(CrmsEnergyGradient, VolumetricForceIsMinusItsEnergyGradient) {
  // The volumetric term (volume_term.h) on a two-material lattice (ν = 0.45 and 0.3, blended
  // corners included), a cut node and a torn spring (cubes without their term), at
  // displacements large enough that some cubes are stretched (J > 1, the log branch)
  // and others compressed.
  for (double amplitude : {0.05, 0.3}) {
    SolverConfig c;
    c.backend = Backend::kCpu;
    c.materials = {test::poisson_material(0.45, 10e3), test::poisson_material(0.3, 40e3)};
    Lattice l = box({5, 4, 4}, 1);
    for (std::int64_t n = 0; n < l.node_count(); n += 3) l.set_material(n, 1);
    l.set_material(7, make_material_blend({0, 1, 0, 0}, {0.5, 0.5, 0, 0}));
    l.set_alive(l.geometry().index(2, 2, 2), false);
    l.break_spring(l.geometry().index(1, 1, 1), make_direction(1, 1));
    Solver s(std::move(l), c);
    randomise(s, amplitude, 31);
    EXPECT_LT(worst_gradient_error(s,
                                   [](const Solver& x) {
                                     std::vector<Vec3f> f = x.spring_forces();
                                     const std::vector<Vec3f> v = test::volume_forces(x);
                                     for (std::size_t n = 0; n < f.size(); ++n) f[n] += v[n];
                                     return f;
                                   }),
              2e-3)
        << "amplitude " << amplitude;
  }
}

}  // namespace
}  // namespace tsf::crms
