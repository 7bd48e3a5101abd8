// Edit → render buffer latency on the cranium tissue: a ball of radius 2, 4 and 8 voxels ablates
// at a random point of the deformed surface, and apply_tool returns when every layer is current
// (tool pose mapped to rest space, voxels edited, IMT re-meshed, lattice nodes deleted and springs
// broken, vertices re-bound and coupled into the render buffer). Reported per radius, p50/p99 µs
// of each stage and of the whole, and how much changed per edit. The IMT re-mesh column is the
// baseline the other stages add to (bench_imt_incremental measures it alone).
//
//   bench_cut_latency [--edits 200] [--k 2] [--backend cpu|cuda|auto] [--radii 2,4,8] [--seed 7]
//
// The lattice is bent first (a smooth displacement field of up to ~2 mm), so the pose mapping and
// the coupling work on a deformed tissue. The edit path runs on one thread (as interactive edits
// do; OpenMP is pinned to one thread).
#include <omp.h>
#include <time.h>

#include <chrono>
#include <random>
#include <sstream>

#include "bench_cut_scenes.h"

namespace {

using namespace tsf;
using Clock = std::chrono::steady_clock;

/// CPU time of the calling thread, µs: what an edit costs when the machine is not shared (wall
/// time on a busy machine adds whole scheduler slices of other processes).
double thread_cpu_us() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e6 + static_cast<double>(t.tv_nsec) * 1e-3;
}

void bend(interaction::TissueModel& model) {
  const crms::Lattice& l = model.solver().lattice();
  const crms::LatticeGeometry& g = l.geometry();
  const Vec3d lo = g.origin;
  const Vec3d size{g.spacing.x * (g.dims.x - 1), g.spacing.y * (g.dims.y - 1),
                   g.spacing.z * (g.dims.z - 1)};
  std::vector<Vec3f> u(static_cast<std::size_t>(l.node_count())), v(u.size());
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    const Vec3d p = g.rest_position(n);
    const double sx = (p.x - lo.x) / size.x - 0.5, sy = (p.y - lo.y) / size.y - 0.5;
    const double sz = (p.z - lo.z) / size.z;
    // Sag towards the top (0 at the anchored bottom), a little twist: ~2 mm at most.
    u[static_cast<std::size_t>(n)] =
        to_float(Vec3d{0.8 * sz * sy, -0.8 * sz * sx, -2.0 * sz * sz * (1.0 - 4.0 * sx * sx)});
  }
  model.solver().set_state(u, v);
  model.couple();
}

}  // namespace

int main(int argc, char** argv) {
  int edits = 200, k = 2;
  unsigned seed = 7;
  std::string backend_text = "cpu";
  std::vector<double> radii = {2, 4, 8};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--edits" && i + 1 < argc) {
      edits = std::atoi(argv[++i]);
    } else if (a == "--k" && i + 1 < argc) {
      k = std::atoi(argv[++i]);
    } else if (a == "--seed" && i + 1 < argc) {
      seed = static_cast<unsigned>(std::atoi(argv[++i]));
    } else if (a == "--backend" && i + 1 < argc) {
      backend_text = argv[++i];
    } else if (a == "--radii" && i + 1 < argc) {
      radii.clear();
      std::stringstream s(argv[++i]);
      for (std::string r; std::getline(s, r, ',');) radii.push_back(std::atof(r.c_str()));
    } else if (bench::ignorable_argument(a)) {
      continue;
    } else {
      std::fprintf(stderr,
                   "usage: bench_cut_latency [--edits N] [--k K] [--backend cpu|cuda|auto] "
                   "[--radii 2,4,8] [--seed S]\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (edits < 1 || k < 1 || radii.empty()) {
    std::fprintf(stderr, "--edits and --k must be >= 1, --radii non-empty\n");
    return 2;
  }
  const crms::Backend backend = bench::parse_backend(backend_text);
  if (backend == crms::Backend::kCuda && !cuda_status().available) {
    std::fprintf(stderr, "--backend cuda: %s\n", cuda_status().reason.c_str());
    return 2;
  }
  bench::BenchTissue tissue = bench::cranium_or_blobs();
  const double voxel =
      std::min(tissue.volume.geometry().spacing.x,
               std::min(tissue.volume.geometry().spacing.y, tissue.volume.geometry().spacing.z));
  std::printf("tissue: %s; lattice k = %d; %d edits per radius; ball ablation, strength 1\n",
              tissue.name.c_str(), k, edits);

  bool header = false;
  for (double radius_voxels : radii) {
    interaction::TissueModel model(VoxelVolume(tissue.volume), bench::soft_tissue(k, backend));
    if (!header) {
      std::printf("backend: %s; %lld alive nodes; %zu surface vertices; voxel %.3f mm\n\n",
                  model.solver().backend_name().c_str(),
                  static_cast<long long>(model.alive_nodes()), model.surface().live_vertex_count(),
                  voxel);
      std::printf("%7s | %11s %11s %11s %11s %11s %11s | %11s %11s %11s | %8s %8s %8s %7s %6s\n",
                  "radius", "map", "voxel edit", "IMT remesh", "topology", "rebind", "couple",
                  "total", "wall", "thread CPU", "rebound", "(nodes)", "tris", "nodes", "springs");
      std::printf("%7s | %11s %11s %11s %11s %11s %11s | %11s %11s %11s | %8s %8s %8s %7s %6s\n",
                  "voxels", "p50/p99 µs", "p50/p99", "p50/p99", "p50/p99", "p50/p99", "p50/p99",
                  "p50/p99", "p50/p99", "p50/p99", "/edit", "/edit", "/edit", "deleted", "broken");
      header = true;
    }
    bend(model);
    omp_set_num_threads(1);
    interaction::Tool ball;
    ball.radius_mm = radius_voxels * voxel;
    std::mt19937 rng(seed + static_cast<unsigned>(radius_voxels * 10));
    std::uniform_real_distribution<double> u01(0, 1);
    std::vector<double> map, edit, remesh, topo, rebind, couple, total, wall, cpu;
    double rebound = 0, rebound_topology = 0, tris = 0, nodes = 0, springs = 0;
    int done = 0;
    while (done < edits) {
      const auto& s = model.surface();
      std::uint32_t slot = 1 + static_cast<std::uint32_t>(u01(rng) * (s.vertex_slot_count() - 2));
      while (!s.vertex_live(slot)) slot = 1 + slot % (s.vertex_slot_count() - 1);
      // Centre the ball half a radius inside the deformed surface.
      const Vec3d at = to_double(model.coupler().positions()[slot]) -
                       to_double(model.coupler().normals()[slot]) * (0.5 * ball.radius_mm);
      model.release_tool();
      const double c0 = thread_cpu_us();
      const auto t0 = Clock::now();
      const interaction::EditReport r =
          model.apply_tool(ball, {at, {}}, interaction::ToolMode::kAblate);
      const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
      const double cpu_us = thread_cpu_us() - c0;
      if (!r.edited) continue;
      cpu.push_back(cpu_us);
      ++done;
      map.push_back(r.map_us);
      edit.push_back(r.edit_us);
      remesh.push_back(r.remesh_us);
      topo.push_back(r.topology_us);
      rebind.push_back(r.rebind_us);
      couple.push_back(r.couple_us);
      total.push_back(r.total_us);
      wall.push_back(us);
      rebound += static_cast<double>(r.vertices_rebound);
      rebound_topology += static_cast<double>(r.vertices_rebound_for_topology);
      tris += static_cast<double>(r.triangles_changed);
      nodes += static_cast<double>(r.nodes_deleted);
      springs += static_cast<double>(r.springs_broken);
    }
    omp_set_num_threads(omp_get_num_procs());
    auto pp = [](const std::vector<double>& v) {
      char b[32];
      std::snprintf(b, sizeof b, "%.0f/%.0f", bench::percentile(v, 0.5),
                    bench::percentile(v, 0.99));
      return std::string(b);
    };
    std::printf(
        "%7.0f | %11s %11s %11s %11s %11s %11s | %11s %11s %11s | %8.0f %8.0f %8.0f %7.2f %6.2f\n",
        radius_voxels, pp(map).c_str(), pp(edit).c_str(), pp(remesh).c_str(), pp(topo).c_str(),
        pp(rebind).c_str(), pp(couple).c_str(), pp(total).c_str(), pp(wall).c_str(),
        pp(cpu).c_str(), rebound / edits, rebound_topology / edits, tris / edits, nodes / edits,
        springs / edits);
  }
  std::printf(
      "\nmap = tool pose to rest space (gather nodes near the tool, Newton per cube); voxel edit = "
      "the ablation with the stroke memory; IMT remesh = update + change list; topology = "
      "lattice deletions and broken springs; rebind / couple = the coupler on the changed "
      "vertices (rebound (nodes) = of them, only because a node of their cube was deleted or a "
      "spring broken); total = apply_tool end to end (wall = the same measured outside; thread CPU "
      "= the CPU time of the edit's thread, which leaves out the time slices other processes take "
      "on a shared machine).\n");
  return 0;
}
