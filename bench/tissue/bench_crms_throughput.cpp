// CRMS throughput: node-steps/s for cubic lattices 32³…256³ on the CPU (OpenMP) and CUDA
// backends, the step rate of the thesis's 64×32×32 lattice, and bytes per node. On the GPU each
// kernel's traffic (a counted model of bytes per node-step) is set against the device-to-device
// copy bandwidth measured in the same run.
//
//   build/bench/bench_crms_throughput                      (both backends where available)
//   build/bench/bench_crms_throughput --benchmark_filter=Cpu
//
// Bytes per node-step (the minimum DRAM traffic of one step when neighbour reads hit in cache):
// read u, v (6 floats), flags (1 B), 1/m (4 B); write u', v' (6 floats) = 53 B. Knobs and effects
// add their arrays (none for the formulations measured here).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <memory>
#include <string>

#include "tsf/common/cuda_support.h"
#include "tsf/crms/device_bandwidth.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/solver.h"

namespace {

using namespace tsf;
using namespace tsf::crms;

constexpr double kBytesPerNodeStep = 6 * 4 + 1 + 4 + 6 * 4;

double copy_bandwidth() {
  static const double bw = [] {
    if (!cuda_status().available) return 0.0;
    return measure_device_copy_bandwidth(std::size_t{512} << 20, 20);
  }();
  return bw;
}

std::unique_ptr<Solver> make_solver(Int3 dims, Backend backend, AngularReactions reactions,
                                    AngularForm form = AngularForm::kExact) {
  BoxLatticeOptions o;
  o.size_mm = {double(dims.x), double(dims.y), double(dims.z)};
  o.spacing_mm = 1.0;
  Lattice l = build_box_lattice(o);
  fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
  SolverConfig c;
  c.backend = backend;
  c.angular_reactions = reactions;
  c.angular_form = form;
  Material m;
  m.youngs_modulus_pa = 10e3;
  m.viscosity_pa_s = 2.0;
  c.materials = {m};
  c.gravity = {0, 0, -9810};
  c.cuda_steps_per_graph = 64;
  return std::make_unique<Solver>(std::move(l), c);
}

/// args: edge length, backend (0 cpu, 1 cuda), reactions (0 gather, 1 symmetric), form (0, 1)
void BM_CrmsNodeSteps(benchmark::State& state) {
  const int edge = static_cast<int>(state.range(0));
  const Backend backend = state.range(1) ? Backend::kCuda : Backend::kCpu;
  const AngularReactions reactions =
      state.range(2) ? AngularReactions::kSymmetric : AngularReactions::kGather;
  const AngularForm form = state.range(3) ? AngularForm::kCosine : AngularForm::kExact;
  if (backend == Backend::kCuda && !cuda_status().available) {
    state.SkipWithError(("no CUDA: " + cuda_status().reason).c_str());
    return;
  }
  auto solver = make_solver({edge, edge, edge}, backend, reactions, form);
  const double dt = 0.5 * solver->stable_dt();
  const std::int64_t nodes = solver->lattice().node_count();
  // Enough steps per timed iteration that launch and synchronisation costs vanish.
  int steps = 1;
  if (backend == Backend::kCuda) steps = edge >= 256 ? 16 : (edge >= 128 ? 64 : 256);
  solver->step(steps, dt);  // warm-up: graphs captured, caches warm
  for (auto _ : state) solver->step(steps, dt);
  const double node_steps = double(nodes) * steps * double(state.iterations());
  state.counters["node_steps_per_s"] = benchmark::Counter(node_steps, benchmark::Counter::kIsRate);
  state.counters["steps_per_s"] =
      benchmark::Counter(double(steps) * double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["bytes_per_node"] = solver->bytes_per_node();
  state.counters["bytes_per_node_step"] = kBytesPerNodeStep;
  if (backend == Backend::kCuda) {
    state.counters["copy_bandwidth_GBps"] = copy_bandwidth() * 1e-9;
    state.counters["model_bandwidth_GBps"] =
        benchmark::Counter(node_steps * kBytesPerNodeStep * 1e-9, benchmark::Counter::kIsRate);
  }
  state.SetLabel(solver->backend_name() + ", " + to_string(reactions) + ", " + to_string(form));
}

void node_step_args(benchmark::internal::Benchmark* b) {
  for (int backend : {0, 1})
    for (int edge : {32, 64, 128, 256})
      for (int reactions : {0, 1}) b->Args({edge, backend, reactions, 0});
  for (int backend : {0, 1}) b->Args({128, backend, 0, 1});  // cheaper angular form
  b->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(0.5);
}
BENCHMARK(BM_CrmsNodeSteps)->Apply(node_step_args);

/// The thesis's 64×32×32 lattice: steps per second (the thesis: above 30 Hz on a GTX 280).
void BM_CrmsThesisLatticeStepRate(benchmark::State& state) {
  const Backend backend = state.range(0) ? Backend::kCuda : Backend::kCpu;
  const AngularReactions reactions =
      state.range(1) ? AngularReactions::kSymmetric : AngularReactions::kGather;
  if (backend == Backend::kCuda && !cuda_status().available) {
    state.SkipWithError(("no CUDA: " + cuda_status().reason).c_str());
    return;
  }
  auto solver = make_solver({64, 32, 32}, backend, reactions);
  const double dt = 0.5 * solver->stable_dt();
  const int steps = backend == Backend::kCuda ? 1024 : 4;
  solver->step(steps, dt);
  for (auto _ : state) solver->step(steps, dt);
  state.counters["steps_per_s"] =
      benchmark::Counter(double(steps) * double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["node_steps_per_s"] = benchmark::Counter(
      double(solver->lattice().node_count()) * steps * double(state.iterations()),
      benchmark::Counter::kIsRate);
  state.SetLabel(solver->backend_name() + ", " + to_string(reactions));
}
BENCHMARK(BM_CrmsThesisLatticeStepRate)
    ->Args({0, 0})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({1, 1})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime()
    ->MinTime(0.5);

}  // namespace

BENCHMARK_MAIN();
