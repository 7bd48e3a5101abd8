// What the stability verdict costs (docs/stability.md "Signals"): one frame of steps through
// Solver::step against the same frame through StabilityMonitor::step (energy after the frame,
// two velocity copies, the last step taken alone; a second energy pass only after an edit), on
// a 64×32×32 lattice (the thesis's size) with 10 and 50 steps a frame, CPU and CUDA.
//
//   build/bench/bench_stability_monitor
//   build/bench/bench_stability_monitor --benchmark_filter=Cpu
#include <benchmark/benchmark.h>

#include <memory>

#include "tsf/common/cuda_support.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/solver.h"
#include "tsf/crms/stability_monitor.h"

namespace {

using namespace tsf;
using namespace tsf::crms;

std::unique_ptr<Solver> make_solver(Backend backend) {
  BoxLatticeOptions o;
  o.size_mm = {64, 32, 32};
  o.spacing_mm = 1.0;
  Lattice l = build_box_lattice(o);
  fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
  SolverConfig c;
  c.backend = backend;
  Material m;
  m.youngs_modulus_pa = 10e3;
  m.viscosity_pa_s = 2.0;
  c.materials = {m};
  c.gravity = {0, 0, -9810};
  return std::make_unique<Solver>(std::move(l), c);
}

/// args: steps per frame, backend (0 cpu, 1 cuda), monitored (0 Solver::step, 1 the monitor)
void BM_Frame(benchmark::State& state) {
  const int steps = static_cast<int>(state.range(0));
  const Backend backend = state.range(1) ? Backend::kCuda : Backend::kCpu;
  const bool monitored = state.range(2) != 0;
  if (backend == Backend::kCuda && !cuda_status().available) {
    state.SkipWithError(("no CUDA: " + cuda_status().reason).c_str());
    return;
  }
  auto solver = make_solver(backend);
  const double dt = 0.9 * solver->stable_dt();
  StabilityMonitor monitor;
  solver->step(steps, dt);  // warm-up
  for (auto _ : state) {
    if (monitored)
      monitor.step(*solver, steps, dt);
    else
      solver->step(steps, dt);
  }
  state.counters["frames_per_s"] =
      benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.SetLabel(monitored ? "monitored" : "Solver::step");
}

BENCHMARK(BM_Frame)
    ->ArgNames({"steps", "cuda", "monitored"})
    ->ArgsProduct({{10, 50}, {0, 1}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
