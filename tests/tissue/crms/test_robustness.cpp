// CrmsRobustness (also run under ASan + UBSan in CI): random parameters inside the documented
// ranges never produce NaN/Inf, and values outside them are rejected naming the field.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "physics_assertions.h"
#include "tsf/common/error.h"

namespace tsf::crms {
namespace {

double log_uniform(std::mt19937& rng, double lo, double hi) {
  return std::exp(std::uniform_real_distribution<double>(std::log(lo), std::log(hi))(rng));
}

TEST(CrmsRobustness, RandomParametersInRangeNeverGoNonFinite) {
  std::mt19937 rng(20261121);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 60; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    BoxLatticeOptions o;
    o.spacing_mm = log_uniform(rng, 0.05, 5.0);
    for (int a = 0; a < 3; ++a) o.size_mm[a] = o.spacing_mm * (1 + static_cast<int>(unit(rng) * 5));
    Lattice l = build_box_lattice(o);
    for (std::int64_t n = 0; n < l.node_count(); ++n) {
      if (unit(rng) < 0.1) l.set_alive(n, false);
      if (unit(rng) < 0.1) l.set_fixed(n, true);
      if (unit(rng) < 0.05) l.break_spring(n, static_cast<int>(unit(rng) * 6));
      l.set_material(n, unit(rng) < 0.3 ? 1 : 0);
    }
    SolverConfig c;
    c.backend = Backend::kCpu;
    c.integrator = unit(rng) < 0.5 ? Integrator::kSymplecticEuler : Integrator::kExplicitEuler;
    c.angular_form = unit(rng) < 0.5 ? AngularForm::kExact : AngularForm::kCosine;
    c.angular_reactions =
        unit(rng) < 0.5 ? AngularReactions::kGather : AngularReactions::kSymmetric;
    c.materials.clear();
    for (int m = 0; m < 2; ++m) {
      Material mat;
      mat.youngs_modulus_pa = log_uniform(rng, 1.0, 1e11);
      mat.shear_modulus_pa =
          unit(rng) < 0.5 ? 0.0 : mat.youngs_modulus_pa * log_uniform(rng, 1e-3, 10);
      mat.viscosity_pa_s = unit(rng) < 0.2 ? 0.0 : log_uniform(rng, 1e-6, 1e6);
      mat.density_g_per_mm3 = log_uniform(rng, 1e-6, 1e-1);
      c.materials.push_back(mat);
    }
    const double g = unit(rng) * 1e7;
    c.gravity = {g * (unit(rng) - 0.5), g * (unit(rng) - 0.5), -g * unit(rng)};
    c.stability.kinetic_damping = unit(rng) < 0.5 ? 0.0 : log_uniform(rng, 1e-6, 1e3);
    c.stability.velocity_limit =
        unit(rng) < 0.3 ? -1.0 : (unit(rng) < 0.5 ? 0.0 : log_uniform(rng, 1e-3, 1e9));
    // Explicit Euler with an undamped material has no stable step at all (documented): that
    // configuration is covered by TimeStepBelowAndAboveTheEstimate's limits, not here.
    {
      const Solver probe(Lattice(l), c);
      if (probe.stable_dt() == 0.0) c.integrator = Integrator::kSymplecticEuler;
    }
    Solver s(std::move(l), c);
    const double dt = std::min(0.05 + 0.9 * unit(rng), 1.0) * std::min(s.stable_dt(), 1e-2);
    // A random deformation of up to half a spacing and random velocities.
    std::vector<Vec3f> u(static_cast<std::size_t>(s.lattice().node_count())), v(u.size());
    const float amp = static_cast<float>(0.5 * o.spacing_mm);
    for (std::size_t n = 0; n < u.size(); ++n) {
      u[n] = Vec3f{static_cast<float>(unit(rng) - 0.5), static_cast<float>(unit(rng) - 0.5),
                   static_cast<float>(unit(rng) - 0.5)} *
             amp;
      v[n] = Vec3f{static_cast<float>(unit(rng) - 0.5), 0.0f, 0.0f} *
             (amp / static_cast<float>(dt) * 0.01f);
    }
    s.set_state(u, v);
    s.step(150, dt);
    EXPECT_TRUE(test::assert_finite(s))
        << "E " << c.materials[0].youngs_modulus_pa << " η " << c.materials[0].viscosity_pa_s
        << " ρ " << c.materials[0].density_g_per_mm3 << " dt " << dt << " "
        << to_string(c.integrator) << " " << to_string(c.angular_reactions);
  }
}

void expect_rejected(SolverConfig c, const std::string& field) {
  try {
    Solver s(test::box({2, 2, 2}, 1), c);
    ADD_FAILURE() << "accepted an out-of-range " << field;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
  }
}

TEST(CrmsRobustness, OutOfRangeParametersAreRejectedNamingTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  SolverConfig good;
  good.materials = {test::soft_material()};
  for (double e : {0.0, -1.0, 1e12, nan}) {
    SolverConfig c = good;
    c.materials[0].youngs_modulus_pa = e;
    expect_rejected(c, "materials[0].youngs_modulus");
  }
  for (double g : {-1.0, 1e9, nan}) {
    SolverConfig c = good;
    c.materials[0].shear_modulus_pa = g;
    expect_rejected(c, "materials[0].shear_modulus");
  }
  for (double eta : {-1.0, 1e7}) {
    SolverConfig c = good;
    c.materials[0].viscosity_pa_s = eta;
    expect_rejected(c, "materials[0].viscosity");
  }
  for (double rho : {0.0, 1.0}) {
    SolverConfig c = good;
    c.materials[0].density_g_per_mm3 = rho;
    expect_rejected(c, "materials[0].density");
  }
  {
    SolverConfig c = good;
    c.stability.kinetic_damping = -1;
    expect_rejected(c, "stability.kinetic_damping");
    c = good;
    c.stability.velocity_limit_auto_fraction = 0;
    expect_rejected(c, "stability.velocity_limit_auto_fraction");
    c = good;
    c.gravity = {0, 0, 1e8};
    expect_rejected(c, "gravity");
    c = good;
    c.cuda_steps_per_graph = 63;
    expect_rejected(c, "cuda_steps_per_graph");
    c = good;
    c.cpu_tile_rows = -1;
    expect_rejected(c, "cpu_tile_rows");
    c = good;
    c.cuda_tile_rows = 5;
    expect_rejected(c, "cuda_tile_rows");
    c = good;
    c.cuda_planes_per_block = 5000;
    expect_rejected(c, "cuda_planes_per_block");
    c = good;
    c.materials.clear();
    expect_rejected(c, "materials");
  }
  Solver s(test::box({2, 2, 2}, 1), good);
  for (double dt : {0.0, -1e-3, 2.0, nan}) {
    try {
      s.step(1, dt);
      ADD_FAILURE() << "accepted dt " << dt;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("dt"), std::string::npos);
    }
  }
}

}  // namespace
}  // namespace tsf::crms
