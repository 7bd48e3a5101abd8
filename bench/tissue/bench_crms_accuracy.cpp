// What accuracy costs in time, for the CRMS knobs: integrator, dt (sub-steps per frame), exact
// acos vs the cheaper cosine angular form, gather vs symmetric angular reactions. Each variant
// simulates the same 3 ms of a cantilever (10×3×3 nodes, 1 mm, E = 20 kPa, τ = 0.5 ms) falling
// under gravity from rest; the error is the RMS node-position difference to an implicit Euler
// reference (symmetric, exact form, dt = 1/8 of the stable step, Newton to 1e-9), relative to the
// reference's RMS displacement. Time: wall time to simulate the 5 ms on this backend (CPU), and
// node-steps/s of the same formulation from bench_crms_throughput for large lattices.
//
//   build/bench/bench_crms_accuracy
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <vector>

#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/solver.h"

namespace {

using namespace tsf;
using namespace tsf::crms;

constexpr double kSimulatedTime = 3e-3;

struct Variant {
  const char* name;
  Integrator integrator;
  double dt_fraction;  ///< of the variant's own stable dt estimate
  AngularForm form;
  AngularReactions reactions;
};

const Variant kVariants[] = {
    {"symplectic dt=0.9", Integrator::kSymplecticEuler, 0.9, AngularForm::kExact,
     AngularReactions::kSymmetric},
    {"symplectic dt=0.5", Integrator::kSymplecticEuler, 0.5, AngularForm::kExact,
     AngularReactions::kSymmetric},
    {"symplectic dt=0.25", Integrator::kSymplecticEuler, 0.25, AngularForm::kExact,
     AngularReactions::kSymmetric},
    {"explicit-euler dt=0.9", Integrator::kExplicitEuler, 0.9, AngularForm::kExact,
     AngularReactions::kSymmetric},
    {"explicit-euler dt=0.5", Integrator::kExplicitEuler, 0.5, AngularForm::kExact,
     AngularReactions::kSymmetric},
    {"implicit dt=1", Integrator::kImplicitEuler, 1.0, AngularForm::kExact,
     AngularReactions::kSymmetric},
    {"implicit dt=10", Integrator::kImplicitEuler, 10.0, AngularForm::kExact,
     AngularReactions::kSymmetric},
    {"symplectic dt=0.5 cosine", Integrator::kSymplecticEuler, 0.5, AngularForm::kCosine,
     AngularReactions::kSymmetric},
    {"symplectic dt=0.5 gather", Integrator::kSymplecticEuler, 0.5, AngularForm::kExact,
     AngularReactions::kGather},
    {"symplectic dt=0.5 gather cosine", Integrator::kSymplecticEuler, 0.5, AngularForm::kCosine,
     AngularReactions::kGather},
};

std::unique_ptr<Solver> make_scene(Integrator integrator, AngularForm form,
                                   AngularReactions reactions) {
  BoxLatticeOptions o;
  o.size_mm = {10, 3, 3};
  o.spacing_mm = 1.0;
  Lattice l = build_box_lattice(o);
  fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
  SolverConfig c;
  c.backend = Backend::kCpu;
  c.integrator = integrator;
  c.angular_form = form;
  c.angular_reactions = reactions;
  Material m;
  m.youngs_modulus_pa = 20e3;
  m.viscosity_pa_s = 20e3 * 5e-4;
  c.materials = {m};
  c.gravity = {0, 0, -9810};
  c.stability.velocity_limit = 0;  // measure the integrator, not the limiter
  c.implicit_tolerance = 1e-9;
  return std::make_unique<Solver>(std::move(l), c);
}

/// Advances to kSimulatedTime with steps of at most dt (the last one shortened to land on it).
void simulate(Solver& s, double dt) {
  const auto whole = static_cast<int>(std::floor(kSimulatedTime / dt));
  s.step(whole, dt);
  const double rest = kSimulatedTime - whole * dt;
  if (rest > 1e-12 * kSimulatedTime) s.step(1, rest);
}

const std::vector<Vec3f>& reference() {
  static const std::vector<Vec3f> positions = [] {
    auto s =
        make_scene(Integrator::kImplicitEuler, AngularForm::kExact, AngularReactions::kSymmetric);
    simulate(*s, s->stable_dt() / 8);
    return s->positions();
  }();
  return positions;
}

void BM_CrmsAccuracyVsTime(benchmark::State& state) {
  const Variant& v = kVariants[state.range(0)];
  const std::vector<Vec3f>& ref = reference();
  double error = 0, steps = 0;
  for (auto _ : state) {
    auto s = make_scene(v.integrator, v.form, v.reactions);
    const double dt =
        v.dt_fraction *
        (v.integrator == Integrator::kImplicitEuler
             ? make_scene(Integrator::kSymplecticEuler, v.form, v.reactions)->stable_dt()
             : s->stable_dt());
    simulate(*s, dt);
    steps = std::ceil(kSimulatedTime / dt);
    state.PauseTiming();
    const auto p = s->positions();
    const Lattice& l = s->lattice();
    double diff2 = 0, disp2 = 0;
    for (std::size_t n = 0; n < p.size(); ++n) {
      const Vec3d d = to_double(p[n]) - to_double(ref[n]);
      const Vec3d u = to_double(ref[n]) - l.geometry().rest_position(static_cast<std::int64_t>(n));
      diff2 += dot(d, d);
      disp2 += dot(u, u);
    }
    error = s->instability() ? static_cast<double>(INFINITY) : std::sqrt(diff2 / disp2);
    state.ResumeTiming();
  }
  state.counters["relative_error"] = error;
  state.counters["steps"] = steps;
  state.SetLabel(v.name);
}
BENCHMARK(BM_CrmsAccuracyVsTime)
    ->DenseRange(0, static_cast<int>(sizeof(kVariants) / sizeof(kVariants[0])) - 1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
