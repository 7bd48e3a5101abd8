// Coupler throughput and what its knob costs: every render vertex of the cranium tissue coupled
// to a deformed lattice, trilinear (8 corners, continuous across cubes) vs the thesis's local
// frame (4 corners), on the CPU (1 and all threads) and on CUDA where a device is usable.
//
// Reported per mode: vertices/s of a full couple() (median of --reps, after a warm-up), and the
// surface error against the lattice's trilinear field (mean and max distance of the coupled
// vertices from the trilinear interpolation of their cube's nodes, in voxels; the trilinear mode
// is that field by construction where all corners are present) and the normal error (degrees)
// against the normals of the trilinear field. Baseline in the same run: a plain copy of the
// render buffer (memory bound), to show how far from bandwidth the per-vertex math is.
//
//   bench_coupler [--reps 5] [--k 2] [--backend cpu|cuda|auto] [--bend 0.5]
//
// --bend is the amplitude (mm) of the deformation applied to the lattice: waves of 16 mm
// wavelength along each axis (curvature at the scale of a few cubes, where the two modes differ;
// the strain peaks at 2π·amplitude/16 mm), under a sag that grows with height.
#include <omp.h>

#include <chrono>
#include <cstring>

#include "bench_cut_scenes.h"
#include "tsf/coupler/coupler.h"

namespace {

using namespace tsf;
using Clock = std::chrono::steady_clock;

void deform(interaction::TissueModel& model, double amplitude) {
  const crms::Lattice& l = model.solver().lattice();
  const crms::LatticeGeometry& g = l.geometry();
  const Vec3d size{g.spacing.x * (g.dims.x - 1), g.spacing.y * (g.dims.y - 1),
                   g.spacing.z * (g.dims.z - 1)};
  std::vector<Vec3f> u(static_cast<std::size_t>(l.node_count())), v(u.size());
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    const Vec3d p = g.rest_position(n);
    const double sz = (p.z - g.origin.z) / size.z;
    const double k = 2.0 * 3.14159265358979323846 / 16.0;
    u[static_cast<std::size_t>(n)] = to_float(
        Vec3d{std::sin(k * p.y), std::sin(k * p.z), std::sin(k * p.x) - 2.0 * sz * sz} * amplitude);
  }
  model.solver().set_state(u, v);
}

double median_seconds(int reps, const std::function<void()>& f) {
  std::vector<double> t;
  f();  // warm-up
  for (int r = 0; r < reps; ++r) {
    const auto t0 = Clock::now();
    f();
    t.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
  }
  return bench::percentile(t, 0.5);
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 5, k = 2;
  double bend = 0.5;
  std::string backend_text = "auto";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--reps" && i + 1 < argc)
      reps = std::atoi(argv[++i]);
    else if (a == "--k" && i + 1 < argc)
      k = std::atoi(argv[++i]);
    else if (a == "--bend" && i + 1 < argc)
      bend = std::atof(argv[++i]);
    else if (a == "--backend" && i + 1 < argc)
      backend_text = argv[++i];
    else if (bench::ignorable_argument(a))
      continue;
    else {
      std::fprintf(
          stderr,
          "usage: bench_coupler [--reps N] [--k K] [--backend cpu|cuda|auto] [--bend MM]\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (reps < 1 || k < 1) {
    std::fprintf(stderr, "--reps and --k must be >= 1\n");
    return 2;
  }
  bench::BenchTissue tissue = bench::cranium_or_blobs();
  const double voxel =
      std::min(tissue.volume.geometry().spacing.x,
               std::min(tissue.volume.geometry().spacing.y, tissue.volume.geometry().spacing.z));
  std::vector<crms::Backend> backends = {crms::Backend::kCpu};
  const crms::Backend wanted = bench::parse_backend(backend_text);
  if (wanted == crms::Backend::kCuda) backends.push_back(crms::Backend::kCuda);
  if (backend_text != "cpu" && !cuda_status().available)
    std::printf("CUDA not measured: %s\n", cuda_status().reason.c_str());

  std::printf("tissue: %s; lattice k = %d; bending amplitude %.1f mm; median of %d\n",
              tissue.name.c_str(), k, bend, reps);
  bool header = false;
  struct Variant {
    crms::Backend backend;
    coupler::CouplerMode mode;
    bool page_locked;
  };
  std::vector<Variant> variants;
  for (crms::Backend backend : backends)
    for (coupler::CouplerMode mode :
         {coupler::CouplerMode::kTrilinear, coupler::CouplerMode::kLocalFrame})
      variants.push_back({backend, mode, true});
  // The earlier CUDA coupler in the same run: outputs copied into pageable host memory.
  if (backends.back() == crms::Backend::kCuda)
    variants.push_back({crms::Backend::kCuda, coupler::CouplerMode::kTrilinear, false});
  for (const Variant& variant : variants) {
    const crms::Backend backend = variant.backend;
    const coupler::CouplerMode mode = variant.mode;
    {
      auto o = bench::soft_tissue(k, backend);
      o.coupler_mode = mode;

      interaction::TissueModel model(VoxelVolume(tissue.volume), o);
      deform(model, bend);
      const std::size_t vertices = model.coupler().bound_count();
      if (!header) {
        std::printf("%zu bound vertices (%u slots), %lld alive nodes\n\n", vertices,
                    model.coupler().slot_count(), static_cast<long long>(model.alive_nodes()));
        std::printf("%-26s %-12s %8s %10s %12s | %14s %14s %10s\n", "backend", "mode", "threads",
                    "ms", "Mvertices/s", "err mean/max", "(voxels)", "normal °");
        header = true;
      }
      // Reference: the trilinear field with the same bindings and inference.
      std::vector<Vec3f> reference_p, reference_n;
      {
        auto ro = bench::soft_tissue(k, crms::Backend::kCpu);
        ro.coupler_mode = coupler::CouplerMode::kTrilinear;
        interaction::TissueModel ref(VoxelVolume(tissue.volume), ro);
        deform(ref, bend);
        ref.couple();
        reference_p = ref.coupler().positions();
        reference_n = ref.coupler().normals();
      }
      auto& coupler = const_cast<coupler::Coupler&>(model.coupler());
      coupler.set_page_locked_outputs(variant.page_locked);
      const int max_threads = omp_get_num_procs();
      for (int threads : backend == crms::Backend::kCpu ? std::vector<int>{1, max_threads}
                                                        : std::vector<int>{1}) {
        omp_set_num_threads(threads);
        // Alternate two states so every coupling really rewrites the buffer; only couple() is
        // timed (on CUDA it includes copying the changed blocks of the render buffer to the
        // host, where the viewer reads it).
        std::vector<double> times;
        for (int r = 0; r <= reps; ++r) {
          deform(model, r % 2 ? bend : 0.9 * bend);
          const auto t0 = Clock::now();
          coupler.couple(model.solver());
          if (r > 0) times.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
        }
        deform(model, bend);
        coupler.couple(model.solver());
        const double t = bench::percentile(times, 0.5);
        double err_sum = 0, err_max = 0, ang_sum = 0;
        std::size_t counted = 0, with_normal = 0;
        for (std::uint32_t slot = 1; slot < model.surface().vertex_slot_count(); ++slot) {
          if (!model.surface().vertex_live(slot)) continue;
          const double e = length(to_double(coupler.positions()[slot] - reference_p[slot])) / voxel;
          err_sum += e;
          err_max = std::max(err_max, e);
          ++counted;
          if (length(reference_n[slot]) < 0.5f) continue;  // IMT gives zero-area vertices no normal
          const double c = std::clamp(
              dot(to_double(coupler.normals()[slot]), to_double(reference_n[slot])), -1.0, 1.0);
          ang_sum += std::acos(c) * 180.0 / 3.14159265358979323846;
          ++with_normal;
        }
        std::printf("%-26s %-12s %8d %10.2f %12.1f | %7.4f/%-6.3f %14s %10.3f\n",
                    variant.page_locked ? model.solver().backend_name().substr(0, 26).c_str()
                                        : "cuda, pageable outputs",
                    mode == coupler::CouplerMode::kTrilinear ? "trilinear" : "local-frame", threads,
                    t * 1e3, static_cast<double>(vertices) / t * 1e-6,
                    err_sum / static_cast<double>(counted), err_max, "",
                    ang_sum / static_cast<double>(std::max<std::size_t>(with_normal, 1)));
      }
      omp_set_num_threads(omp_get_num_procs());
      if (mode == coupler::CouplerMode::kTrilinear && backend == crms::Backend::kCpu &&
          variant.page_locked) {
        // Baseline: copy the render buffer (positions + normals), same vertex count.
        std::vector<Vec3f> a(coupler.positions()), b(a.size()), c(coupler.normals()), d(c.size());
        const double copy = median_seconds(reps, [&] {
          std::memcpy(b.data(), a.data(), a.size() * sizeof(Vec3f));
          std::memcpy(d.data(), c.data(), c.size() * sizeof(Vec3f));
        });
        std::printf("%-26s %-12s %8d %10.2f %12.1f | (copy of the %zu-slot buffers)\n",
                    "baseline: memcpy", "-", 1, copy * 1e3,
                    static_cast<double>(vertices) / copy * 1e-6, a.size());
      }
    }
  }
  return 0;
}
