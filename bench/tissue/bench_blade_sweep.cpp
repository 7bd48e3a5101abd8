// A cut's blade sweep (the weights of ToolStroke::cut_blade before they are applied) against the
// direct form it replaced, in the same run: the sinus scene's cut on the segmented cranium, a
// 40 × 40 × 1 mm blade sweeping 70 mm down through the face while turning 1.6° (what the scene's
// cut becomes in rest space on the pressed face).
//
//   bench_blade_sweep [--repeats 20] [--backend cpu|cuda|auto]
//
// * direct: per sub-step, per voxel its box reaches, the voxel's own position rotated into the
//   blade (blade_distance) and its fall-off weight, the largest kept (the sweep's earlier row
//   loop, vectorised the same way, the sub-steps shared among the threads the same way);
// * stroke: the stroke's sweep: each row's voxels placed from the row's first one, the smallest
//   distance kept without a square root, the fall-off taken once per voxel;
// * cuda (with --backend cuda or auto and a device): the device sweeper, weights back on the host.
// Reported: the best and median time of each over the repeats, on one thread and on every
// thread, the ratio direct ÷ stroke (medians), and how far the forms' outcomes differ (rounding).
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "tsf/common/cuda_support.h"
#include "tsf/interaction/tool_stroke.h"
#include "tsf/io/nrrd_volume.h"

namespace {

using namespace tsf;
using namespace tsf::interaction;

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target_clones("avx512f", "avx2", "default")))
#endif
void direct_row(const BladeTool& blade, const ToolPose& pose, const VolumeGeometry& g, double h,
                int j, int k, int i0, int i1, float* row) {
  for (int i = i0; i < i1; ++i) {
    const double d =
        blade_distance(blade, pose, g.index_to_tissue({double(i), double(j), double(k)}));
    const float w = d < h ? falloff_weight(d, h) : 0.0f;
    row[i - i0] = std::max(row[i - i0], w);
  }
}

std::vector<float> direct_sweep(const BladeSweepPlan& plan, const VolumeGeometry& g, int threads) {
  const VoxelBox& box = plan.box;
  const Int3 ext = box.extent();
  std::vector<float> weight(static_cast<std::size_t>(box.voxel_count()), 0.0f);
  auto offset = [&](int j, int k) {
    return static_cast<std::size_t>(ext.x) *
           (static_cast<std::size_t>(j - box.lo.y) +
            static_cast<std::size_t>(ext.y) * static_cast<std::size_t>(k - box.lo.z));
  };
  auto sweep = [&](std::vector<float>& into, std::size_t first, std::size_t last) {
    for (std::size_t n = first; n < last; ++n) {
      const VoxelBox& sb = plan.steps[n].box;
      for (int k = sb.lo.z; k < sb.hi.z; ++k)
        for (int j = sb.lo.y; j < sb.hi.y; ++j)
          direct_row(plan.blade, plan.steps[n].pose, g, plan.h, j, k, sb.lo.x, sb.hi.x,
                     into.data() + offset(j, k) + static_cast<std::size_t>(sb.lo.x - box.lo.x));
    }
  };
  if (threads <= 1) {
    sweep(weight, 0, plan.steps.size());
    return weight;
  }
#pragma omp parallel num_threads(threads)
  {
    const auto t = static_cast<std::size_t>(omp_get_thread_num());
    const auto count = static_cast<std::size_t>(omp_get_num_threads());
    std::vector<float> own(weight.size(), 0.0f);
    sweep(own, plan.steps.size() * t / count, plan.steps.size() * (t + 1) / count);
#pragma omp critical(bench_direct_merge)
    for (std::size_t v = 0; v < own.size(); ++v) weight[v] = std::max(weight[v], own[v]);
  }
  return weight;
}

/// Hands over weights computed elsewhere (the direct form's), so the stroke applies them.
class Given final : public BladeSweeper {
 public:
  std::vector<float> weights;
  void sweep(const BladeSweepPlan&, const VolumeGeometry&, std::vector<float>& weight) override {
    weight = weights;
  }
};

/// Forwards to `inner` (the device), keeping the weights it returned.
class Recorder final : public BladeSweeper {
 public:
  explicit Recorder(BladeSweeper* inner) : inner_(inner) {}
  std::vector<float> weights;
  void sweep(const BladeSweepPlan& plan, const VolumeGeometry& g,
             std::vector<float>& weight) override {
    inner_->sweep(plan, g, weight);
    weights = weight;
  }

 private:
  BladeSweeper* inner_;
};

struct Times {
  double best = 1e300, median = 0;
};
template <typename F>
Times time_it(int repeats, F&& f) {
  std::vector<double> t;
  for (int r = 0; r < repeats; ++r) t.push_back(f());
  std::sort(t.begin(), t.end());
  return {t.front(), t[t.size() / 2]};
}

double largest_difference(const std::vector<float>& a, const std::vector<float>& b) {
  double worst = a.size() == b.size() ? 0.0 : 1e300;
  for (std::size_t v = 0; v < std::min(a.size(), b.size()); ++v)
    worst = std::max(worst, std::fabs(double(a[v]) - double(b[v])));
  return worst;
}

}  // namespace

int main(int argc, char** argv) {
  int repeats = 20;
  std::string backend = "cpu";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--repeats" && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--backend" && i + 1 < argc) {
      backend = argv[++i];
    } else if (a.rfind("--benchmark", 0) == 0) {
      // Google Benchmark's flags (scripts/gpu-check.sh passes them to every bench): ignored.
    } else {
      std::fprintf(stderr,
                   "usage: bench_blade_sweep [--repeats 20] [--backend cpu|cuda|auto]\n"
                   "  times a cut's blade sweep (the sinus scene's, on the segmented cranium) "
                   "against the direct form it replaced\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (backend != "cpu" && backend != "cuda" && backend != "auto") {
    std::fprintf(stderr, "bench_blade_sweep: --backend must be cpu, cuda or auto, got '%s'\n",
                 backend.c_str());
    return 2;
  }
  const std::string path =
      std::string(TSF_SOURCE_DIR) + "/data-samples/ct-head-cranium/segmented/cranium-density.nrrd";
  VoxelVolume sample;
  try {
    sample = io::read_tissue_volume_nrrd(path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_blade_sweep: %s: %s\n", path.c_str(), e.what());
    return 1;
  }
  const VolumeGeometry& g = sample.geometry();
  const BladeTool blade{{20, 20, 0.5}};
  const Rotation from_r = Rotation::about_axis({1, 0, 0}, M_PI / 2);
  const Rotation to_r = Rotation::about_axis({1, 0, 0}, M_PI / 2 + 0.028);
  const Vec3d c = g.index_to_tissue({g.dims.x * 0.5, g.dims.y * 0.3, g.dims.z * 0.5});
  const RemovalOptions o;
  const BladeSweepPlan plan =
      plan_blade_sweep(g, blade, {c + Vec3d{0, 0, 40}, from_r}, {c + Vec3d{0, 0, -30}, to_r}, o);
  std::printf(
      "blade sweep: %zu sub-steps over %lld voxels (%lld visits, %.1f per voxel), turning "
      "%.2f°, %s\n",
      plan.steps.size(), static_cast<long long>(plan.box.voxel_count()),
      static_cast<long long>(plan.visits),
      static_cast<double>(plan.visits) / static_cast<double>(plan.box.voxel_count()),
      from_r.angle_to(to_r) * 180.0 / M_PI, path.c_str());

  const int all = omp_get_max_threads();
  std::vector<float> reference;
  // The last column: the direct form's weights against the one-thread run's (they agree), the
  // stroke's edit against the direct weights applied by the same stroke (largest density
  // difference over the volume), the device's weights against the direct ones.
  std::printf("%-8s %-8s %12s %12s %10s %14s\n", "form", "threads", "best ms", "median ms",
              "direct ÷", "max |Δ|");
  for (const int threads : {1, all}) {
    if (threads == 1 && all == 1 && !reference.empty()) break;
    omp_set_num_threads(threads);
    std::vector<float> direct;
    const Times td = time_it(repeats, [&] {
      const auto t0 = std::chrono::steady_clock::now();
      direct = direct_sweep(plan, g, threads);
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    });
    if (reference.empty()) reference = direct;
    // The stroke's own sweep; its edit against the direct weights applied by the same stroke.
    VoxelVolume by_stroke(sample);
    const Times ts = time_it(repeats, [&] {
      VoxelVolume v(sample);
      ToolStroke s;
      s.cut_blade(v, plan, o);
      if (threads == all) by_stroke = std::move(v);
      return s.last_sweep_seconds();
    });
    Given given;
    given.weights = direct;
    VoxelVolume by_direct(sample);
    ToolStroke applier;
    applier.cut_blade(by_direct, plan, o, &given);
    double worst = 0;
    const std::vector<float>& a = std::as_const(by_stroke).density_data();
    const std::vector<float>& b = std::as_const(by_direct).density_data();
    for (std::size_t v = 0; v < a.size(); ++v)
      worst = std::max(worst, std::fabs(double(a[v]) - double(b[v])));
    std::printf("%-8s %-8d %12.3f %12.3f %10s %14.2e\n", "direct", threads, td.best * 1e3,
                td.median * 1e3, "1.00", largest_difference(direct, reference));
    char diff[32] = "-";
    if (threads == all) std::snprintf(diff, sizeof diff, "%.2e", worst);
    std::printf("%-8s %-8d %12.3f %12.3f %10.2f %14s\n", "stroke", threads, ts.best * 1e3,
                ts.median * 1e3, td.median / ts.median, diff);
  }
  if (backend != "cpu") {
    if (!cuda_status().available) {
      if (backend == "cuda") {
        std::fprintf(stderr, "bench_blade_sweep: --backend cuda: %s\n",
                     cuda_status().reason.c_str());
        return 1;
      }
      std::printf("cuda: not run (%s)\n", cuda_status().reason.c_str());
    } else {
      std::unique_ptr<BladeSweeper> device = make_cuda_blade_sweeper();
      Recorder rec(device.get());
      const Times tc = time_it(repeats, [&] {
        VoxelVolume v(sample);
        ToolStroke s;
        s.cut_blade(v, plan, o, &rec);
        return s.last_sweep_seconds();
      });
      std::printf("%-8s %-8s %12.3f %12.3f %10s %14.2e\n", "cuda", "device", tc.best * 1e3,
                  tc.median * 1e3, "", largest_difference(rec.weights, reference));
    }
  }
  return 0;
}
