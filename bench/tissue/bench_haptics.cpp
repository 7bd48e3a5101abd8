// Cost of one haptic force evaluation per model and what its resolution buys (accuracy beside
// time). The case is the thesis's: a stylus of radius 2.5 mm against a rigid sphere of radius
// 8 mm (0.5 mm voxels, density ramp over ±0.25 mm), half a stylus radius deep for the timed call.
//
//   VoxelForce/n          voxel model, n cells across the stylus (trilinear density); counters:
//                         cells, err_pct = max |F − law(V_exact)| over a pass / peak (%),
//                         jitter_pct = jitter of a 20 mm/s skim / peak (%)
//   VoxelForceNoSkip/n    the voxel model reading all 8 densities of every cell (no skipping of
//                         uniform cubes): the peer of the uniform-cube classification
//   VoxelForceBinary/n    baseline peer in the same run: the thesis's binary nearest-voxel test
//                         (same cells, one load each, no interpolation), with its error and jitter
//   VoxelForceWarped/n    the voxel model with a lattice window (the inverse warp's extra cost)
//   MeshForce/n           mesh model, n spheres across (1 = the stylus sphere itself), against
//                         the sphere's IMT triangles near the stylus; err_V_pct: max error of
//                         the intersection volume over the first third of a radius, % of its end
//   LatticeForce          lattice model (reads the summed reactions: the floor)
//   Filter/w              the moving average, window w; counters: jitter_pct of a coarse skim
//                         (n = 4, nearest voxels) after filtering, delay_ms (group delay, 1 kHz)
//
//   bench_haptics [--benchmark_filter=VoxelForce] [--benchmark_repetitions=5]
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>

#include "tsf/haptics/force_models.h"
#include "tsf/haptics/frame_capture.h"
#include "tsf/haptics/haptic_metrics.h"
#include "tsf/haptics/haptic_playback.h"
#include "tsf/haptics/haptic_trajectory.h"
#include "tsf/haptics/moving_average.h"
#include "tsf/haptics/sphere_intersection.h"
#include "tsf/haptics/voxel_force.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/volume/analytic_volumes.h"

namespace {

using namespace tsf;
using namespace tsf::haptics;

constexpr double kR = 8.0, kr = 2.5;

struct Case {
  VoxelVolume tissue;
  Vec3d centre;
  imt::SurfaceMesh mesh;
};

const Case& sphere_case() {
  static const Case c = [] {
    const double voxel = 0.5;
    const int n = 56;  // 28 mm: the stylus window stays inside the volume
    const Vec3d centre{0.5 * (n - 1) * voxel, 0.5 * (n - 1) * voxel, 0.5 * (n - 1) * voxel};
    Case k{make_sdf_volume(
               cube_geometry({n, n, n}, voxel),
               [centre](const Vec3d& p) { return length(p - centre) - kR; }, 0.25),
           centre,
           {}};
    k.mesh = imt::extract_surface(k.tissue);
    return k;
  }();
  return c;
}

ForceModelOptions options(int voxel_res, int sphere_res) {
  ForceModelOptions o;
  o.stylus_radius_mm = kr;
  o.voxel_resolution = voxel_res;
  o.sphere_resolution = sphere_res;
  return o;
}

/// Max |F − law(V_exact)| over a pass from outside to the centre, % of the law's peak.
double law_error_pct(const ForceModel& model, const ForceLaw& law) {
  const Case& c = sphere_case();
  StaticFrameSource source(c.tissue, nullptr, {kr, 1.0});
  HapticFrame frame;
  double worst = 0, peak = 0;
  for (int i = 0; i <= 200; ++i) {
    StylusPose pose;
    const double d = (kR + kr + 0.5) * (1.0 - i / 200.0);
    pose.position = c.centre + Vec3d{d, 0, 0};
    source.step(0, pose, false, frame);
    const double expected = law.magnitude(sphere_intersection_volume(kr, kR, d), sphere_volume(kr));
    peak = std::max(peak, expected);
    worst =
        std::max(worst, std::fabs(length(model.evaluate(frame.view(), pose).force_un) - expected));
  }
  return 100.0 * worst / peak;
}

/// Jitter of a 1 mm deep skim along the sphere at 20 mm/s, 1 kHz, % of its peak force.
double skim_jitter_pct(const ForceModel& model, int filter_window) {
  const Case& c = sphere_case();
  StaticFrameSource source(c.tissue, nullptr, {kr, 1.0});
  PlaybackOptions p;
  p.sim_rate_hz = 1000;
  p.filter_window = filter_window;
  const Vec3d a = c.centre + Vec3d{kR + kr - 1.0, -6, 0}, b = c.centre + Vec3d{kR + kr - 1.0, 6, 0};
  const auto samples = play_trajectory(straight_pass(a, b, 20.0), source, model, p);
  MetricOptions m;
  m.filter_window = filter_window;
  return 100.0 * compute_metrics(samples, m).jitter_relative;
}

HapticFrame frame_at(const StylusPose& pose, bool mesh) {
  const Case& c = sphere_case();
  StaticFrameSource source(c.tissue, mesh ? &c.mesh : nullptr, {kr, 1.0});
  HapticFrame frame;
  source.step(0, pose, false, frame);
  return frame;
}

StylusPose contact_pose() {
  StylusPose pose;
  pose.position = sphere_case().centre + Vec3d{kR + 0.5 * kr, 0, 0};  // half a radius deep
  return pose;
}

template <class Model>
void run_model(benchmark::State& state, const Model& model, const HapticFrame& frame,
               const StylusPose& pose) {
  const HapticFrameView view = frame.view();
  for (auto _ : state) {
    HapticForce f = model.evaluate(view, pose);
    benchmark::DoNotOptimize(f);
  }
  state.SetItemsProcessed(state.iterations());
}

void VoxelForce(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const VoxelForceModel model(options(n, 4));
  const StylusPose pose = contact_pose();
  run_model(state, model, frame_at(pose, false), pose);
  state.counters["cells"] = static_cast<double>(model.stylus().offsets.size());
  state.counters["err_pct"] = law_error_pct(model, model.law());
  state.counters["jitter_pct"] = skim_jitter_pct(model, 1);
}
BENCHMARK(VoxelForce)
    ->Arg(4)
    ->Arg(6)
    ->Arg(8)
    ->Arg(12)
    ->Arg(16)
    ->Arg(24)
    ->Arg(32)
    ->Unit(benchmark::kMicrosecond);

void VoxelForceNoSkip(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const VoxelForceModel model(options(n, 4));
  const StylusPose pose = contact_pose();
  HapticFrame frame = frame_at(pose, false);
  frame.density_cells.clear();  // every cell interpolated: the uniform-cube skip's peer
  run_model(state, model, frame, pose);
}
BENCHMARK(VoxelForceNoSkip)->Arg(16)->Unit(benchmark::kMicrosecond);

void VoxelForceBinary(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  ForceModelOptions o = options(n, 4);
  o.sampling = DensitySampling::kNearest;
  const VoxelForceModel model(o);
  const StylusPose pose = contact_pose();
  run_model(state, model, frame_at(pose, false), pose);
  state.counters["err_pct"] = law_error_pct(model, o.law);
  state.counters["jitter_pct"] = skim_jitter_pct(model, 1);
}
BENCHMARK(VoxelForceBinary)->Arg(8)->Arg(16)->Arg(32)->Unit(benchmark::kMicrosecond);

void VoxelForceWarped(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const VoxelForceModel model(options(n, 4));
  const StylusPose pose = contact_pose();
  HapticFrame frame = frame_at(pose, false);
  // A sheared lattice window around the stylus (u = 0.1·z along x).
  frame.lattice_dims = {6, 6, 6};
  frame.lattice_spacing = {2, 2, 2};
  frame.lattice_origin = pose.position - Vec3d{5, 5, 5};
  frame.displacement.resize(216);
  frame.alive.assign(216, 1);
  for (int k = 0; k < 6; ++k)
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 6; ++i) frame.displacement[i + 6 * (j + 6 * k)] = {0.1f * 2.0f * k, 0, 0};
  run_model(state, model, frame, pose);
}
BENCHMARK(VoxelForceWarped)->Arg(16)->Unit(benchmark::kMicrosecond);

void MeshForce(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const MeshForceModel model(options(8, n));
  const StylusPose pose = contact_pose();
  const HapticFrame frame = frame_at(pose, true);
  run_model(state, model, frame, pose);
  state.counters["spheres"] = static_cast<double>(model.stylus().offsets.size());
  state.counters["triangles"] = static_cast<double>(frame.corners.size() / 3);
  // Intersection-volume error over the shallow part of the pass (the first third of a radius).
  const Case& c = sphere_case();
  StaticFrameSource source(c.tissue, &c.mesh, {kr, 1.0});
  HapticFrame f;
  double worst = 0;
  for (int i = 0; i <= 40; ++i) {
    StylusPose p;
    const double d = kR + kr - (kr / 3.0) * i / 40.0;
    p.position = c.centre + Vec3d{d, 0, 0};
    source.step(0, p, false, f);
    const double V = sphere_intersection_volume(kr, kR, d);
    worst = std::max(worst, std::fabs(model.evaluate(f.view(), p).intersection_mm3 - V));
  }
  state.counters["err_V_pct"] =
      100.0 * worst / sphere_intersection_volume(kr, kR, kR + kr - kr / 3.0);
}
BENCHMARK(MeshForce)->Arg(1)->Arg(2)->Arg(4)->Arg(6)->Arg(8)->Unit(benchmark::kMicrosecond);

void LatticeForce(benchmark::State& state) {
  const LatticeForceModel model(options(8, 4));
  HapticFrame frame;
  frame.contact_force_un = {1, 2, 3};
  run_model(state, model, frame, contact_pose());
}
BENCHMARK(LatticeForce)->Unit(benchmark::kMicrosecond);

void Filter(benchmark::State& state) {
  const int w = static_cast<int>(state.range(0));
  MovingAverageFilter filter(w);
  Vec3d x{1, 2, 3};
  for (auto _ : state) {
    x.x += 1e-3;
    benchmark::DoNotOptimize(filter.filter(x));
  }
  ForceModelOptions o = options(4, 4);
  o.sampling = DensitySampling::kNearest;  // where the filter matters: a stepwise force
  const VoxelForceModel coarse(o);
  state.counters["jitter_pct"] = skim_jitter_pct(coarse, w);
  state.counters["delay_ms"] = filter.group_delay_samples() * 1.0;  // at 1 kHz
}
BENCHMARK(Filter)->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Unit(benchmark::kNanosecond);

}  // namespace

BENCHMARK_MAIN();
