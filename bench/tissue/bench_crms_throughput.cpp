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

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "tsf/common/cuda_support.h"
#include "tsf/crms/device_bandwidth.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/solver.h"
#include "tsf/io/nrrd_volume.h"
#include "tsf/volume/tissue_labels.h"
#include "tsf/volume/volume_edits.h"

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
                                    AngularForm form = AngularForm::kExact,
                                    CudaLaunch launch = CudaLaunch::kAuto, int tile_rows = 0,
                                    int planes_per_block = 0,
                                    CudaTileKernel tile_kernel = CudaTileKernel::kStaged) {
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
  c.cuda_launch = launch;
  c.cuda_tile_rows = tile_rows;
  c.cuda_planes_per_block = planes_per_block;
  c.cuda_tile_kernel = tile_kernel;
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
  b->Args({256, 1, 1, 1});  // the symmetric form's cosine variant at 256³
  b->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(0.5);
}
BENCHMARK(BM_CrmsNodeSteps)->Apply(node_step_args);

/// The default (symmetric) tile kernel at 256³ by tile shape: rows per tile (4, 8) and z-planes
/// per block (0: automatic, about eight blocks per multiprocessor), against the automatic choice
/// in the same run (docs/crms.md "The default kernel against the roofline"). args: rows, planes.
void BM_CrmsSymmetricTiling(benchmark::State& state) {
  if (!cuda_status().available) {
    state.SkipWithError(("no CUDA: " + cuda_status().reason).c_str());
    return;
  }
  auto solver = make_solver({256, 256, 256}, Backend::kCuda, AngularReactions::kSymmetric,
                            AngularForm::kExact, CudaLaunch::kAuto,
                            static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const double dt = 0.5 * solver->stable_dt();
  const int steps = 16;
  solver->step(steps, dt);
  for (auto _ : state) solver->step(steps, dt);
  const double node_steps =
      double(solver->lattice().node_count()) * steps * double(state.iterations());
  state.counters["node_steps_per_s"] = benchmark::Counter(node_steps, benchmark::Counter::kIsRate);
  state.counters["copy_bandwidth_GBps"] = copy_bandwidth() * 1e-9;
  state.counters["of_roofline"] =
      benchmark::Counter(node_steps * kBytesPerNodeStep / std::max(copy_bandwidth(), 1.0),
                         benchmark::Counter::kIsRate);
  state.SetLabel(solver->backend_name());
}
BENCHMARK(BM_CrmsSymmetricTiling)
    ->ArgsProduct({{4, 8}, {0, 16, 128}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(0.5);

/// The default tile kernel (staged: each plane's state in shared memory) against the previous one
/// (direct: neighbours from L1/L2) at 256³, in the same run, against the copy roofline measured in
/// the same run (docs/crms.md "The default kernel against the roofline"). The previous kernel of
/// a form runs first, so the default's row reports `x_previous`, its rate over the previous
/// kernel's. args: kernel (1 direct, 0 staged), form (0 exact, 1 cosine).
void BM_CrmsTileKernel(benchmark::State& state) {
  if (!cuda_status().available) {
    state.SkipWithError(("no CUDA: " + cuda_status().reason).c_str());
    return;
  }
  const auto kernel = state.range(0) ? CudaTileKernel::kDirect : CudaTileKernel::kStaged;
  const AngularForm form = state.range(1) ? AngularForm::kCosine : AngularForm::kExact;
  static double previous[2] = {0.0, 0.0};  // the direct kernel's rate, per form
  auto solver = make_solver({256, 256, 256}, Backend::kCuda, AngularReactions::kSymmetric, form,
                            CudaLaunch::kAuto, 0, 0, kernel);
  const double dt = 0.5 * solver->stable_dt();
  const int steps = 16;
  solver->step(steps, dt);
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) solver->step(steps, dt);  // synchronous
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double node_steps =
      double(solver->lattice().node_count()) * steps * double(state.iterations());
  const double rate = node_steps / seconds;
  state.counters["node_steps_per_s"] = benchmark::Counter(node_steps, benchmark::Counter::kIsRate);
  state.counters["copy_bandwidth_GBps"] = copy_bandwidth() * 1e-9;
  state.counters["of_roofline"] =
      benchmark::Counter(node_steps * kBytesPerNodeStep / std::max(copy_bandwidth(), 1.0),
                         benchmark::Counter::kIsRate);
  if (kernel == CudaTileKernel::kDirect)
    previous[state.range(1)] = rate;
  else if (previous[state.range(1)] > 0.0)
    state.counters["x_previous"] = rate / previous[state.range(1)];
  state.SetLabel(solver->backend_name() + ", " + to_string(form));
}
BENCHMARK(BM_CrmsTileKernel)
    ->Args({1, 0})
    ->Args({0, 0})
    ->Args({1, 1})
    ->Args({0, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(0.5);

/// Small lattices, where a step's arithmetic is shorter than a kernel launch: microseconds per
/// step of the symmetric form (the default), in the same run: CUDA graphs of one launch per step
/// (the earlier form), one persistent launch over the same tiles (a grid barrier between steps),
/// the node-parallel persistent launch (three threads per node, two barriers per step) and the
/// brick launch (bricks in shared memory, one barrier per step; the default).
/// args: edge (nodes per axis), launch (1 graphs, 2 persistent tiles, 3 node-parallel, 4 bricks).
void BM_CrmsSmallLatticeStep(benchmark::State& state) {
  const int edge = static_cast<int>(state.range(0));
  const auto launch = static_cast<CudaLaunch>(state.range(1));
  if (!cuda_status().available) {
    state.SkipWithError(("no CUDA: " + cuda_status().reason).c_str());
    return;
  }
  auto solver = make_solver({edge, edge, edge}, Backend::kCuda, AngularReactions::kSymmetric,
                            AngularForm::kExact, launch);
  const double dt = 0.5 * solver->stable_dt();
  const int steps = 1024;
  solver->step(steps, dt);
  for (auto _ : state) solver->step(steps, dt);
  const double total = double(steps) * double(state.iterations());
  state.counters["steps_per_s"] = benchmark::Counter(total, benchmark::Counter::kIsRate);
  state.counters["us_per_step"] =
      benchmark::Counter(total * 1e-6, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["nodes"] = double(solver->lattice().node_count());
  state.counters["node_steps_per_s"] = benchmark::Counter(
      double(solver->lattice().node_count()) * total, benchmark::Counter::kIsRate);
  state.SetLabel(solver->backend_name());
}
BENCHMARK(BM_CrmsSmallLatticeStep)
    ->ArgsProduct({{8, 16, 24, 28, 32, 40, 48, 58, 64, 80}, {1, 2, 3, 4}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime()
    ->MinTime(0.3);

/// The sinus scene's lattice on the segmented cranium (data-samples/ct-head-cranium/segmented,
/// scripts/segmented-sample.sh): the face region of scenes/sinus.yaml (50 × 56 × 60 mm around the
/// nose tip of the segment report, (122.4, 231.2, 34.3) mm, 25 mm posterior and 5 mm superior of
/// it; this CT's anterior is +y), bone and the face 47 mm behind the nose tip anchored, the sinus
/// scene's material (turbinate soft tissue: 7.6 kPa, damping time 0.5 ms; gravity). Microseconds
/// per step and the real-time factor at the scene's automatic dt, per launch form. args: voxels per
/// node (2: the scene, ~13 k alive nodes; 1: ~100 k), launch (1 graphs, 2 persistent tiles, 3
/// node-parallel, 4 bricks), Poisson ratio (0: ν = 0, the lattice alone; 1: ν = 0.45, the
/// volumetric term the shipped scenes run, folded into the launch where it can be; the same
/// lattice with the term's effect passes around one-step launches is timed in the same run:
/// passes_us_per_step and x_passes, its time over the measured one).
void BM_CrmsSinusLatticeStep(benchmark::State& state) {
  const int k = static_cast<int>(state.range(0));
  const auto launch = static_cast<CudaLaunch>(state.range(1));
  const bool volumetric = state.range(2) != 0;
  if (!cuda_status().available) {
    state.SkipWithError(("no CUDA: " + cuda_status().reason).c_str());
    return;
  }
  static const VoxelVolume face = [] {
    const VoxelVolume v =
        io::read_tissue_volume_nrrd(std::string(TSF_SOURCE_DIR) +
                                    "/data-samples/ct-head-cranium/segmented/cranium-density.nrrd");
    const VoxelBox box = voxels_near_box(v.geometry(), {97.5, 178.2, 9.3}, {147.5, 234.2, 69.3}, 0);
    VolumeGeometry g = v.geometry();
    g.dims = box.extent();
    g.origin = v.geometry().index_to_tissue({double(box.lo.x), double(box.lo.y), double(box.lo.z)});
    VoxelVolume out(g);
    for (int z = 0; z < g.dims.z; ++z)
      for (int y = 0; y < g.dims.y; ++y)
        for (int x = 0; x < g.dims.x; ++x) {
          const std::size_t from = v.index(x + box.lo.x, y + box.lo.y, z + box.lo.z);
          out.density_data()[out.index(x, y, z)] = v.density_data()[from];
          out.label_data()[out.index(x, y, z)] = v.label_data()[from];
        }
    return out;
  }();
  auto make = [&](bool fold) {
    VolumeLatticeOptions o;
    o.node_spacing_voxels = k;
    Lattice l = build_lattice_from_volume(face, o);
    fix_nodes_with_labels(l, {kLabelCancellousBone, kLabelCorticalBone});
    fix_nodes_behind_plane(l, {122.4, 231.2 - 47.0, 34.3}, {0, 1, 0});
    SolverConfig c;
    c.backend = Backend::kCuda;
    c.cuda_launch = launch;
    c.cuda_fold_volume_term = fold;
    c.materials[0].youngs_modulus_pa = 7.6e3;  // turbinate_soft_tissue, materials/tissues.yaml
    c.materials[0].viscosity_pa_s = 7.6e3 * 0.5e-3;
    c.materials[0].density_g_per_mm3 = 1.05e-3;
    if (volumetric) c.materials[0].poisson_ratio = 0.45;
    c.gravity = {0, 0, -9810};
    c.stability.kinetic_damping = 0.01;
    return std::make_unique<Solver>(std::move(l), c);
  };
  std::unique_ptr<Solver> solver = make(true);
  const double dt = 0.9 * solver->stable_dt();
  const int steps = 1024;
  double passes_us = 0;
  if (volumetric) {  // the effect passes around one-step launches, in the same run
    std::unique_ptr<Solver> passes = make(false);
    passes->step(steps, dt);
    const auto t0 = std::chrono::steady_clock::now();
    passes->step(steps, dt);
    passes_us =
        std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() /
        steps;
  }
  solver->step(steps, dt);
  for (auto _ : state) solver->step(steps, dt);
  const double total = double(steps) * double(state.iterations());
  state.counters["steps_per_s"] = benchmark::Counter(total, benchmark::Counter::kIsRate);
  state.counters["us_per_step"] =
      benchmark::Counter(total * 1e-6, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["real_time_factor"] = benchmark::Counter(total * dt, benchmark::Counter::kIsRate);
  state.counters["alive_nodes"] = double(solver->lattice().alive_count());
  state.counters["nodes"] = double(solver->lattice().node_count());
  state.counters["dt_us"] = dt * 1e6;
  if (volumetric) {
    state.counters["passes_us_per_step"] = passes_us;
    state.counters["x_passes"] =
        benchmark::Counter(passes_us * total * 1e-6, benchmark::Counter::kIsRate);
  }
  state.SetLabel(
      solver->backend_name() +
      (volumetric ? (solver->volume_term_folded() ? ", nu 0.45 folded" : ", nu 0.45 passes") : ""));
}
BENCHMARK(BM_CrmsSinusLatticeStep)
    ->ArgsProduct({{2, 1}, {1, 2, 3, 4}, {0, 1}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime()
    ->MinTime(0.3);

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
