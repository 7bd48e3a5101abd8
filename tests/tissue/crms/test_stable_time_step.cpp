// The stable time-step estimate (stable_time_step.h) against the measured spectrum: the highest
// frequency of the linearised lattice by power iteration on M⁻¹K (K·x from spring forces of a
// small displacement), on uniform, heterogeneous and voxel-built lattices; and the dynamics on
// either side of the bound.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "physics_assertions.h"

namespace tsf::crms {
namespace {

using test::box;

/// ω_max² of the linearised lattice at rest: power iteration of x ← M⁻¹·K·x.
double measured_omega_max_sq(Solver& s) {
  const Lattice& l = s.lattice();
  const auto count = static_cast<std::size_t>(l.node_count());
  std::mt19937 rng(3);
  std::normal_distribution<float> normal;
  std::vector<Vec3f> x(count), zero(count);
  for (std::size_t n = 0; n < count; ++n)
    if (l.alive(n) && !l.fixed(n)) x[n] = {normal(rng), normal(rng), normal(rng)};
  double lambda = 0;
  for (int it = 0; it < 300; ++it) {
    double norm = 0;
    for (const auto& q : x) norm += static_cast<double>(dot(q, q));
    norm = std::sqrt(norm);
    const float eps = static_cast<float>(1e-4 * l.geometry().min_spacing() / norm);
    std::vector<Vec3f> u(count);
    for (std::size_t n = 0; n < count; ++n) u[n] = x[n] * eps;
    s.set_state(u, zero);
    auto f = s.spring_forces();
    if (!s.active_effects().empty()) {  // the volumetric term (the only effect used here)
      const auto v = test::volume_forces(s);
      for (std::size_t n = 0; n < count; ++n) f[n] += v[n];
    }
    double next_norm = 0;
    for (std::size_t n = 0; n < count; ++n) {
      x[n] = (l.alive(n) && !l.fixed(n)) ? f[n] * (-1.0f / (eps * l.mass(n))) : Vec3f{0, 0, 0};
      next_norm += static_cast<double>(dot(x[n], x[n]));
    }
    lambda = std::sqrt(next_norm) / norm;
    const float rescale = static_cast<float>(1.0 / std::sqrt(next_norm));
    for (auto& q : x) q *= rescale;
  }
  s.set_state(zero, zero);
  return lambda;
}

void expect_estimate_brackets_spectrum(Solver& s, const char* what) {
  const double measured = std::sqrt(measured_omega_max_sq(s));
  const double estimate = s.stable_time_step().omega_max;
  // The estimate is the plane-wave top of the spectrum: never below the measured radius by more
  // than round-off, and not so far above that dt is wasted.
  EXPECT_GE(estimate, 0.98 * measured) << what;
  EXPECT_LE(estimate, 1.35 * measured) << what;
}

/// Sets a random displacement of up to ±0.01 mm per component (fixed seed) at rest velocity;
/// returns it.
std::vector<Vec3f> set_jittered_state(Solver& s) {
  std::vector<Vec3f> u(static_cast<std::size_t>(s.lattice().node_count())), v(u.size());
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> jitter(-0.01f, 0.01f);
  for (auto& q : u) q = {jitter(rng), jitter(rng), jitter(rng)};
  s.set_state(u, v);
  return u;
}

/// 8 × 8 × 12 mm at 1 mm with a 4 mm cube of palette entry 1 (a stiff inclusion) in its middle.
Lattice inclusion_lattice() {
  BoxLatticeOptions o;
  o.size_mm = {8, 8, 12};
  o.spacing_mm = 1;
  Lattice l = build_box_lattice(o);
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    const Vec3d p = l.geometry().rest_position(n);
    if (std::fabs(p.x - 4) < 2 && std::fabs(p.y - 4) < 2 && std::fabs(p.z - 6) < 2)
      l.set_material(n, 1);
  }
  return l;
}

TEST(CrmsStableTimeStep, EstimateBracketsTheMeasuredSpectrum) {
  for (AngularReactions r : {AngularReactions::kGather, AngularReactions::kSymmetric}) {
    SolverConfig c;
    c.backend = Backend::kCpu;
    c.angular_reactions = r;
    c.materials = {test::soft_material()};
    Solver uniform(box({8, 8, 8}, 1), c);
    expect_estimate_brackets_spectrum(uniform, to_string(r));

    // Anisotropic spacing and a stiff inclusion (100×).
    c.materials = {test::soft_material(10e3), test::soft_material(1e6)};
    Solver mixed(inclusion_lattice(), c);
    expect_estimate_brackets_spectrum(mixed, "stiff inclusion");
  }
}

TEST(CrmsStableTimeStep, EstimateBracketsTheSpectrumWithTheVolumetricTerm) {
  // The volumetric term's checkerboard stiffness (stable_time_step.h) added per node: uniform
  // lattices of ν = 0.3, 0.45 and 0.49 (λ up to 16·E), and the stiff inclusion with its own ν.
  for (double nu : {0.3, 0.45, 0.49}) {
    SolverConfig c;
    c.backend = Backend::kCpu;
    c.materials = {test::poisson_material(nu)};
    Solver uniform(box({8, 8, 8}, 1), c);
    expect_estimate_brackets_spectrum(uniform, "uniform");
  }
  SolverConfig c;
  c.backend = Backend::kCpu;
  c.materials = {test::poisson_material(0.45, 10e3), test::poisson_material(0.3, 1e6)};
  Solver mixed(inclusion_lattice(), c);
  expect_estimate_brackets_spectrum(mixed, "stiff inclusion with ν");
}

TEST(CrmsStableTimeStep, SymplecticEulerIsBoundedBelowAndDivergesWellAbove) {
  // Undamped: the bound is 2/ω_max. Just below it the energy stays bounded for many periods of
  // the highest mode; 30% above it the highest mode grows until the guard or the limits act.
  // The springs alone, and with the volumetric term of ν = 0.45.
  for (double nu : {0.0, 0.45}) {
    SolverConfig c;
    c.backend = Backend::kCpu;
    c.materials = {test::poisson_material(nu, 10e3, 0.0)};
    c.stability.velocity_limit = 0;
    Solver s(box({6, 6, 6}, 1), c);
    const double omega = std::sqrt(measured_omega_max_sq(s));
    const std::vector<Vec3f> u = set_jittered_state(s);
    const double e0 = s.energy().total_nj();
    const double dt = 0.95 * s.stable_dt();
    const auto below = test::run_recording_energy(s, 20, 500, dt);
    // Symplectic Euler conserves a modified energy; the sampled energy of a mode oscillates within
    // 1/(1 − (ω·dt/2)²) of it (harmonic oscillator), so that, not 1, is the bound.
    const double q = omega * dt / 2;
    EXPECT_TRUE(test::assert_energy_bounded(below, 1.1 * e0 / (1 - q * q))) << "ν = " << nu;

    Solver t(box({6, 6, 6}, 1), c);
    t.set_state(u, std::vector<Vec3f>(u.size()));
    const auto above = test::run_recording_energy(t, 20, 500, 1.3 * 2.0 / omega);
    const bool blew_up = t.instability().has_value() || !(above.back() < 1e6 * e0);
    EXPECT_TRUE(blew_up) << "ν = " << nu << ": energy " << above.back() << " from " << e0;
  }
}

TEST(CrmsStableTimeStep, GatherFormFluttersWithoutDamping) {
  // The thesis's vertex-only angular forces are not the gradient of a potential: undamped, the
  // energy of a slightly perturbed block grows by orders of magnitude even at a tenth of the
  // stable step, where the symmetric form keeps it constant. With enough material damping the
  // gather form settles (the thesis always ran it damped).
  auto run = [](AngularReactions r, double damping_time) {
    SolverConfig c;
    c.backend = Backend::kCpu;
    c.angular_reactions = r;
    c.materials = {test::soft_material(10e3, damping_time)};
    c.stability.velocity_limit = 0;
    Solver s(box({6, 6, 6}, 1), c);
    set_jittered_state(s);
    const double e0 = s.energy().total_nj();
    s.step(8000, 0.1 * s.stable_dt());
    return s.energy().total_nj() / e0;
  };
  EXPECT_GT(run(AngularReactions::kGather, 0.0), 100.0);
  EXPECT_NEAR(run(AngularReactions::kSymmetric, 0.0), 1.0, 0.05);
  EXPECT_LT(run(AngularReactions::kGather, 1e-5), 1.0);
}

TEST(CrmsStableTimeStep, ExplicitEulerNeedsDamping) {
  SolverConfig c;
  c.integrator = Integrator::kExplicitEuler;
  c.materials = {test::soft_material(10e3, 0.0)};
  Solver undamped(box({3, 3, 3}, 1), c);
  EXPECT_EQ(undamped.stable_dt(), 0.0);
  c.materials = {test::soft_material(10e3, 1e-4)};
  Solver damped(box({3, 3, 3}, 1), c);
  EXPECT_GT(damped.stable_dt(), 0.0);
  EXPECT_LE(damped.stable_dt(), 1e-4 + 1e-12);  // dt < τ = η/E
}

}  // namespace
}  // namespace tsf::crms
