// Incremental IMT latency: sphere ablations of radius 2, 4, 8, 16 voxels on a 256³ organ-like
// volume. Each edit is centred on a random vertex of the current surface (so it always cuts
// surface), strength 1; reported per radius: the voxel edit and the re-mesh time, p50/p99 µs, and
// how many vertex slots and triangle slots changed per edit. Single-threaded, like an interactive
// edit.
//
//   bench_imt_incremental [--size 256] [--edits 200] [--eps 0.1] [--seed 7]
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "tsf/imt/imt_surface.h"
#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/volume_edits.h"

namespace {

using namespace tsf;
using Clock = std::chrono::steady_clock;

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t i = std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5));
  return v[i];
}

}  // namespace

int main(int argc, char** argv) {
  int size = 256, edits = 200;
  unsigned seed = 7;
  float eps = 0.1f;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--size" && i + 1 < argc)
      size = std::atoi(argv[++i]);
    else if (a == "--edits" && i + 1 < argc)
      edits = std::atoi(argv[++i]);
    else if (a == "--eps" && i + 1 < argc)
      eps = static_cast<float>(std::atof(argv[++i]));
    else if (a == "--seed" && i + 1 < argc)
      seed = static_cast<unsigned>(std::atoi(argv[++i]));
    else {
      std::fprintf(stderr,
                   "usage: bench_imt_incremental [--size N] [--edits N] [--eps E] [--seed S]\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (size < 32 || edits < 1) {
    std::fprintf(stderr, "--size must be >= 32 and --edits >= 1\n");
    return 2;
  }
  std::printf(
      "volume: %d³ organ-like blobs (seed %u), merge eps %.2f; %d edits per radius; the "
      "re-mesh runs on one thread\n\n",
      size, seed, static_cast<double>(eps), edits);
  std::printf("%8s %10s %10s %10s %10s %10s %10s %12s %12s %10s\n", "radius", "edit p50",
              "edit p99", "mesh p50", "mesh p99", "total p50", "total p99", "verts/edit",
              "tris/edit", "cubes");
  std::printf("%8s %10s %10s %10s %10s %10s %10s %12s %12s %10s\n", "voxels", "µs", "µs", "µs",
              "µs", "µs", "µs", "changed", "changed", "remeshed");
  for (double radius : {2.0, 4.0, 8.0, 16.0}) {
    VoxelVolume volume = make_blob_volume(cube_geometry({size, size, size}), seed);
    imt::SurfaceOptions options;
    options.snap_epsilon = eps;
    imt::ImtSurface surface(options);
    surface.build(volume);
    surface.take_changes();
    omp_set_num_threads(1);  // the edit loop below is single-threaded on purpose
    std::mt19937 rng(seed + static_cast<unsigned>(radius));
    std::vector<double> t_edit, t_mesh, t_total;
    double verts = 0, tris = 0, cubes = 0;
    for (int e = 0; e < edits; ++e) {
      // A random live vertex as the tool centre.
      std::uniform_int_distribution<std::uint32_t> pick(1, surface.vertex_slot_count() - 1);
      std::uint32_t v = pick(rng);
      while (!surface.vertex_live(v)) v = pick(rng);
      const Vec3f p = surface.positions()[v];
      const auto t0 = Clock::now();
      const VoxelBox changed = ablate_sphere(volume, {to_double(p), radius});
      const auto t1 = Clock::now();
      const auto stats = surface.update(volume, changed);
      const imt::SurfaceChanges c = surface.take_changes();
      const auto t2 = Clock::now();
      t_edit.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      t_mesh.push_back(std::chrono::duration<double, std::micro>(t2 - t1).count());
      t_total.push_back(std::chrono::duration<double, std::micro>(t2 - t0).count());
      verts += static_cast<double>(c.vertices_added.size() + c.vertices_modified.size() +
                                   c.vertices_freed.size());
      tris += static_cast<double>(c.triangles_added.size() + c.triangles_freed.size());
      cubes += static_cast<double>(stats.cubes_remeshed);
    }
    omp_set_num_threads(omp_get_num_procs());
    std::printf("%8.0f %10.1f %10.1f %10.1f %10.1f %10.1f %10.1f %12.0f %12.0f %10.0f\n", radius,
                percentile(t_edit, 0.5), percentile(t_edit, 0.99), percentile(t_mesh, 0.5),
                percentile(t_mesh, 0.99), percentile(t_total, 0.5), percentile(t_total, 0.99),
                verts / edits, tris / edits, cubes / edits);
    std::fflush(stdout);
  }
  return 0;
}
