// What IMT's mesh optimisation and smoothing cost and buy: for each knob, triangles, time and the
// distance of the vertices to the analytic surface (voxels), plus triangle quality; then memory
// per voxel and per triangle.
//
//   bench_imt_optimise [--reps 5]
//
// Fields: a clamped signed-distance ramp (density linear over ±2 voxels of the surface) and a
// binary (hard-step) volume of the same shapes, so smoothing shows what it does to staircases.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "tsf/imt/extract_surface.h"
#include "tsf/imt/imt_surface.h"
#include "tsf/imt/mesh_quality.h"
#include "tsf/imt/mesh_smoothing.h"
#include "tsf/volume/analytic_volumes.h"

namespace {

using namespace tsf;
using Clock = std::chrono::steady_clock;

struct Config {
  const char* name;
  float eps;
  int smooth;
  bool unwelded;
};

}  // namespace

int main(int argc, char** argv) {
  int reps = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--reps" && i + 1 < argc) {
      reps = std::max(1, std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr, "usage: bench_imt_optimise [--reps R]\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  const Config configs[] = {
      {"unwelded (raw marching)", 0.0f, 0, true}, {"welded by edge key", 0.0f, 0, false},
      {"merge eps 0.1", 0.1f, 0, false},          {"merge eps 0.2", 0.2f, 0, false},
      {"merge 0.1 + Taubin 5", 0.1f, 5, false},   {"merge 0.1 + Taubin 20", 0.1f, 20, false}};

  struct Field {
    std::string name;
    int n;
    double ramp;
    std::function<double(const Vec3d&)> sdf;
  };
  std::vector<Field> fields;
  for (int n : {32, 128}) {
    const SphereField s{{0.5 * n - 0.5, 0.5 * n - 0.5, 0.5 * n - 0.5}, 0.375 * n};
    const TorusField t{{0.5 * n + 0.21, 0.5 * n - 0.33, 0.5 * n + 0.12}, 0.3 * n, 0.12 * n};
    for (double ramp : {2.0, 0.0}) {
      const std::string kind = ramp > 0 ? "ramp" : "binary";
      fields.push_back({"ball-" + std::to_string(n) + "-" + kind, n, ramp,
                        [s](const Vec3d& p) { return s.signed_distance(p); }});
      fields.push_back({"torus-" + std::to_string(n) + "-" + kind, n, ramp,
                        [t](const Vec3d& p) { return t.signed_distance(p); }});
    }
  }

  std::printf(
      "median of %d runs, %d thread(s); err = |signed distance| to the analytic surface in "
      "voxels; slivers = smallest angle < 10°\n\n",
      reps, omp_get_max_threads());
  std::printf("%-18s %-26s %9s %9s %9s %9s %9s %8s %8s %9s\n", "field", "optimisation", "triangles",
              "vertices", "vs welded", "ms", "errMean", "errMax", "slivers", "minAngle");
  for (const Field& f : fields) {
    const VoxelVolume v = make_sdf_volume(cube_geometry({f.n, f.n, f.n}), f.sdf, f.ramp);
    std::size_t welded_triangles = 0;
    for (const Config& c : configs) {
      imt::SurfaceOptions o;
      o.snap_epsilon = c.eps;
      std::vector<double> t;
      imt::SurfaceMesh m;
      for (int r = 0; r < reps; ++r) {
        const auto start = Clock::now();
        m = imt::extract_surface(v, o);
        if (c.smooth > 0) imt::smooth_taubin(m, {c.smooth, 0.5f, -0.53f});
        t.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
      }
      if (c.unwelded) m = imt::unweld(m);
      std::sort(t.begin(), t.end());
      double sum = 0, mx = 0;
      for (const Vec3f& p : m.positions) {
        const double e = std::fabs(f.sdf(to_double(p)));
        sum += e;
        mx = std::max(mx, e);
      }
      const imt::MeshQuality q = imt::measure_quality(m);
      if (!c.unwelded && c.eps == 0.0f && c.smooth == 0) welded_triangles = m.triangle_count();
      const double rel = welded_triangles
                             ? 100.0 * (double(m.triangle_count()) / double(welded_triangles) - 1.0)
                             : 0.0;
      std::printf("%-18s %-26s %9zu %9zu %8.1f%% %9.2f %9.4f %8.4f %8zu %9.2f\n", f.name.c_str(),
                  c.name, m.triangle_count(), m.vertex_count(), rel, t[t.size() / 2],
                  sum / double(std::max<std::size_t>(1, m.vertex_count())), mx, q.slivers,
                  q.min_angle_deg);
      std::fflush(stdout);
    }
  }

  // Memory: the voxel volume, and the incremental surface's buffers and records.
  std::printf("\nmemory\n");
  for (int n : {128, 256}) {
    const VoxelVolume v = make_blob_volume(cube_geometry({n, n, n}), 7);
    const double volume_bytes =
        double(v.voxel_count()) * (sizeof(float) + 1) +
        double(v.brick_count()) * (sizeof(VoxelVolume::BrickRange) + sizeof(std::uint64_t));
    imt::ImtSurface s;
    s.build(v);
    const double surface_bytes = double(s.memory_bytes());
    std::printf(
        "blobs-%d: volume %.2f bytes/voxel; ImtSurface %.1f MB for %zu triangles / %zu "
        "vertices = %.1f bytes/triangle (%.2f bytes/voxel), capacity %u triangles\n",
        n, volume_bytes / double(v.voxel_count()), surface_bytes / 1e6, s.live_triangle_count(),
        s.live_vertex_count(), surface_bytes / double(s.live_triangle_count()),
        surface_bytes / double(v.voxel_count()), s.triangle_capacity());
  }
  return 0;
}
