// Collision cost against the number of nodes near the tool: balls of 1–16 mm pressed 1 mm into
// the deformed cranium tissue at random surface points. Per radius: the nodes the broad phase
// gathers and the exact tests find inside, the coupled vertices of the narrow phase, and the time
// of one contact pass (gather + release test + node projection + vertex narrow phase +
// constraints + reaction forces), p50 µs. Also the broad phase's refit after the lattice moved
// (once per step batch), and, as the baseline in the same run, a brute-force scan of every alive
// node against the same ball (what the block boxes save). Then several tools at once and a
// tool made from a mesh, against one ball in the same run: the contact pass with two balls in
// two hands (one pass over both), with a 4 mm ball given as a closed mesh (2048 triangles,
// its distance grid at 0.2 mm; and the grid's build time), per press p50.
//
//   bench_collision [--presses 100] [--k 2] [--backend cpu|cuda|auto] [--seed 7]
#include <omp.h>

#include <chrono>
#include <random>

#include <map>
#include <memory>

#include "bench_cut_scenes.h"
#include "tsf/collision/node_gatherer.h"
#include "tsf/coupler/coupler.h"

namespace {

using namespace tsf;
using Clock = std::chrono::steady_clock;

double us_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  int presses = 100, k = 2;
  unsigned seed = 7;
  std::string backend_text = "cpu";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--presses" && i + 1 < argc)
      presses = std::atoi(argv[++i]);
    else if (a == "--k" && i + 1 < argc)
      k = std::atoi(argv[++i]);
    else if (a == "--seed" && i + 1 < argc)
      seed = static_cast<unsigned>(std::atoi(argv[++i]));
    else if (a == "--backend" && i + 1 < argc)
      backend_text = argv[++i];
    else if (bench::ignorable_argument(a))
      continue;
    else {
      std::fprintf(stderr,
                   "usage: bench_collision [--presses N] [--k K] [--backend cpu|cuda|auto] "
                   "[--seed S]\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  if (presses < 1 || k < 1) {
    std::fprintf(stderr, "--presses and --k must be >= 1\n");
    return 2;
  }
  const crms::Backend backend = bench::parse_backend(backend_text);
  if (backend == crms::Backend::kCuda && !cuda_status().available) {
    std::fprintf(stderr, "--backend cuda: %s\n", cuda_status().reason.c_str());
    return 2;
  }
  bench::BenchTissue tissue = bench::cranium_or_blobs();
  interaction::TissueModel model(std::move(tissue.volume), bench::soft_tissue(k, backend));
  model.advance(model.dt() * 4);  // a little sag so the lattice is deformed
  const crms::Solver& solver = model.solver();
  std::printf("tissue: %s; lattice k = %d; %s; %lld alive nodes; %zu surface vertices\n",
              tissue.name.c_str(), k, solver.backend_name().c_str(),
              static_cast<long long>(model.alive_nodes()), model.surface().live_vertex_count());

  // Broad phase refit after the lattice moved, and a brute-force scan as the baseline.
  collision::NodeGatherer gatherer(solver.lattice().geometry());
  std::vector<double> refit, brute;
  const coupler::DeformedLatticeView view = coupler::deformed_lattice_view(solver);
  for (int r = 0; r < 20; ++r) {
    gatherer.state_changed();
    collision::NodeNeighbourhood nb;
    auto t0 = Clock::now();
    gatherer.gather(solver, {0, 0, 0}, {0, 0, 0}, std::nullopt, nb);  // refit + empty query
    refit.push_back(us_since(t0));
  }
  std::printf("broad phase refit (all nodes, after a step batch): p50 %.0f µs\n\n",
              bench::percentile(refit, 0.5));

  omp_set_num_threads(1);
  std::printf("%8s | %10s %10s %10s %10s | %12s %12s %14s\n", "radius", "gathered", "inside",
              "held", "vertices", "contact p50", "query p50", "brute force p50");
  std::printf("%8s | %10s %10s %10s %10s | %12s %12s %14s\n", "mm", "nodes", "nodes", "nodes",
              "tested", "µs", "µs", "µs (baseline)");
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  struct PhaseRow {
    double radius, gather, release, narrow, hold, feedback, iterations;
  };
  std::vector<PhaseRow> phase_rows;
  for (double radius : {1.0, 2.0, 4.0, 8.0, 16.0}) {
    interaction::Tool ball;
    ball.radius_mm = radius;
    std::vector<double> contact_us, query_us, brute_us;
    std::vector<double> ph[5];
    double gathered = 0, inside = 0, held = 0, tested = 0, iterations = 0;
    for (int p = 0; p < presses; ++p) {
      const auto& s = model.surface();
      std::uint32_t slot = 1 + static_cast<std::uint32_t>(u01(rng) * (s.vertex_slot_count() - 2));
      while (!s.vertex_live(slot)) slot = 1 + slot % (s.vertex_slot_count() - 1);
      // The ball's surface 1 mm inside the deformed surface, along the vertex normal.
      const Vec3d n = to_double(model.coupler().normals()[slot]);
      const Vec3d centre = to_double(model.coupler().positions()[slot]) + n * (radius - 1.0);
      auto t0 = Clock::now();
      const interaction::EditReport r =
          model.apply_tool(ball, {centre, {}}, interaction::ToolMode::kPress);
      contact_us.push_back(us_since(t0));
      gathered += static_cast<double>(r.contact.nodes_gathered);
      held += static_cast<double>(r.contact.nodes_held);
      tested += static_cast<double>(r.contact.vertices_tested);
      iterations += r.contact.narrow_iterations;
      const auto& cp = r.contact.phases_us;
      ph[0].push_back(cp.gather);
      ph[1].push_back(cp.release);
      ph[2].push_back(cp.narrow);
      ph[3].push_back(cp.hold);
      ph[4].push_back(cp.feedback);
      model.release_tool();
      // The gather alone, with a refit first (what a contact pass after stepping pays).
      const collision::WorldTool placed = interaction::place_tool(ball, {centre, {}});
      collision::NodeNeighbourhood nb;
      t0 = Clock::now();
      gatherer.gather_around_tool(solver, placed, 2.5 * solver.lattice().geometry().min_spacing(),
                                  nb);
      query_us.push_back(us_since(t0));  // the boxes are current: the query alone
      std::size_t in = 0;
      for (std::uint8_t b : nb.inside) in += b;
      inside += static_cast<double>(in);
      // Baseline: every alive node against the ball.
      t0 = Clock::now();
      std::size_t found = 0;
      if (!solver.on_cuda()) {
        const auto& g = solver.lattice().geometry();
        for (std::int64_t node = 0; node < g.node_count(); ++node) {
          if (!view.alive(node)) continue;
          const Int3 c = g.coordinates(node);
          Vec3f target, normal;
          found += collision::node_in_tool(
                       placed, view.rest(c.x, c.y, c.z) + view.displacement(node), target, normal)
                       ? 1
                       : 0;
        }
      }
      brute_us.push_back(us_since(t0));
      if (found > 1u << 30) std::printf(" ");  // keep the scan from being optimised away
    }
    std::printf("%8.0f | %10.0f %10.1f %10.1f %10.0f | %12.0f %12.0f %14.0f\n", radius,
                gathered / presses, inside / presses, held / presses, tested / presses,
                bench::percentile(contact_us, 0.5), bench::percentile(query_us, 0.5),
                solver.on_cuda() ? 0.0 : bench::percentile(brute_us, 0.5));
    phase_rows.push_back({radius, bench::percentile(ph[0], 0.5), bench::percentile(ph[1], 0.5),
                          bench::percentile(ph[2], 0.5), bench::percentile(ph[3], 0.5),
                          bench::percentile(ph[4], 0.5), iterations / presses});
  }
  std::printf(
      "\nthe contact pass's phases, p50 µs (ToolContact's steps; narrow: nodes to the tool "
      "surface and the vertices' iterations)\n%8s | %9s %9s %9s %9s %9s | %10s\n",
      "radius", "gather", "release", "narrow", "hold", "feedback", "iterations");
  for (const PhaseRow& r : phase_rows)
    std::printf("%8.0f | %9.0f %9.0f %9.0f %9.0f %9.0f | %10.1f\n", r.radius, r.gather, r.release,
                r.narrow, r.hold, r.feedback, r.iterations);
  // The narrow phase's incremental iterations against testing every cube every iteration (the
  // reference they equal): two fresh twins of the model, one built with
  // ContactOptions::retest_every_cube, given the same presses (4 mm balls 1 mm deep, random
  // places) alternately.
  {
    auto twin = [&](bool every_cube) {
      interaction::TissueModelOptions o = bench::soft_tissue(k, backend);
      o.contact.retest_every_cube = every_cube;
      auto m = std::make_unique<interaction::TissueModel>(bench::cranium_or_blobs().volume, o);
      m->advance(m->dt() * 4);
      return m;
    };
    const std::unique_ptr<interaction::TissueModel> incremental = twin(false), every = twin(true);
    interaction::Tool ball;
    ball.radius_mm = 4.0;
    std::vector<double> inc_us, every_us;
    double inc_tests = 0, every_tests = 0, iterations = 0;
    bool same = true;
    for (int p = 0; p < presses; ++p) {
      const auto& s = incremental->surface();
      std::uint32_t slot = 1 + static_cast<std::uint32_t>(u01(rng) * (s.vertex_slot_count() - 2));
      while (!s.vertex_live(slot)) slot = 1 + slot % (s.vertex_slot_count() - 1);
      const Vec3d n = to_double(incremental->coupler().normals()[slot]);
      const Vec3d centre = to_double(incremental->coupler().positions()[slot]) + n * 3.0;
      const interaction::EditReport a =
          incremental->apply_tool(ball, {centre, {}}, interaction::ToolMode::kPress);
      const interaction::EditReport b =
          every->apply_tool(ball, {centre, {}}, interaction::ToolMode::kPress);
      incremental->release_tool();
      every->release_tool();
      inc_us.push_back(a.contact.phases_us.narrow);
      every_us.push_back(b.contact.phases_us.narrow);
      inc_tests += static_cast<double>(a.contact.narrow_cube_tests);
      every_tests += static_cast<double>(b.contact.narrow_cube_tests);
      iterations += a.contact.narrow_iterations;
      same = same && a.contact.force_un.x == b.contact.force_un.x &&
             a.contact.force_un.y == b.contact.force_un.y &&
             a.contact.force_un.z == b.contact.force_un.z &&
             a.contact.nodes_held == b.contact.nodes_held &&
             a.contact.vertices_pushed == b.contact.vertices_pushed;
    }
    const double inc = bench::percentile(inc_us, 0.5), all = bench::percentile(every_us, 0.5);
    std::printf(
        "\nnarrow phase, 4 mm, 1 mm deep, p50: incremental iterations %.0f µs, every cube every "
        "iteration %.0f µs (%.2f×; %.1f iterations, %.0f against %.0f cube tests a pass); the "
        "same outcome: %s\n",
        inc, all, all / inc, iterations / presses, inc_tests / presses, every_tests / presses,
        same ? "yes" : "NO");
  }
  // Several tools at once and a mesh tool, against one ball (4 mm, 1 mm deep, random places).
  {
    // A 4 mm sphere as an octahedron subdivided 4 times (2048 triangles).
    std::vector<Vec3d> v = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    std::vector<std::array<std::uint32_t, 3>> t = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                                   {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    for (int level = 0; level < 4; ++level) {
      std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
      auto middle = [&](std::uint32_t a, std::uint32_t b) {
        const auto key = std::make_pair(std::min(a, b), std::max(a, b));
        if (const auto it = mid.find(key); it != mid.end()) return it->second;
        v.push_back(normalized_or_zero(v[a] + v[b]));
        return mid[key] = static_cast<std::uint32_t>(v.size() - 1);
      };
      std::vector<std::array<std::uint32_t, 3>> next;
      for (const auto& f : t) {
        const std::uint32_t ab = middle(f[0], f[1]), bc = middle(f[1], f[2]),
                            ca = middle(f[2], f[0]);
        next.insert(next.end(), {{f[0], ab, ca}, {ab, f[1], bc}, {ca, bc, f[2]}, {ab, bc, ca}});
      }
      t.swap(next);
    }
    std::vector<Vec3f> verts;
    for (const Vec3d& p : v) verts.push_back(to_float(p * 4.0));
    auto t0 = Clock::now();
    interaction::Tool mesh_ball;
    mesh_ball.shape = collision::ToolShape::kMesh;
    mesh_ball.mesh = interaction::ToolMesh::from_closed_mesh("sphere", verts, t, 0.2);
    const double build_ms = us_since(t0) * 1e-3;
    interaction::Tool ball;
    ball.radius_mm = 4.0;
    std::vector<double> one_us, two_us, mesh_us;
    auto random_centre = [&]() {
      const auto& s = model.surface();
      std::uint32_t slot = 1 + static_cast<std::uint32_t>(u01(rng) * (s.vertex_slot_count() - 2));
      while (!s.vertex_live(slot)) slot = 1 + slot % (s.vertex_slot_count() - 1);
      const Vec3d n = to_double(model.coupler().normals()[slot]);
      return to_double(model.coupler().positions()[slot]) + n * 3.0;
    };
    for (int p = 0; p < presses; ++p) {
      const Vec3d a = random_centre(), b = random_centre();
      t0 = Clock::now();
      model.apply_tool(0, ball, {a, {}}, interaction::ToolMode::kPress);
      one_us.push_back(us_since(t0));
      t0 = Clock::now();
      model.apply_tool(1, ball, {b, {}}, interaction::ToolMode::kPress);  // both hands: one pass
      two_us.push_back(us_since(t0));
      model.release_tool();
      t0 = Clock::now();
      model.apply_tool(0, mesh_ball, {a, {}}, interaction::ToolMode::kPress);
      mesh_us.push_back(us_since(t0));
      model.release_tool();
    }
    const double one = bench::percentile(one_us, 0.5);
    std::printf(
        "\nseveral tools, 4 mm, 1 mm deep, p50 per contact pass: one ball %.0f µs; two balls in "
        "two hands %.0f µs (%.2f×); the ball as a mesh tool %.0f µs (%.2f×; its 0.2 mm distance "
        "grid: %d × %d × %d samples, %.1f MB, built in %.0f ms)\n",
        one, bench::percentile(two_us, 0.5), bench::percentile(two_us, 0.5) / one,
        bench::percentile(mesh_us, 0.5), bench::percentile(mesh_us, 0.5) / one,
        mesh_ball.mesh->grid.dims().x, mesh_ball.mesh->grid.dims().y, mesh_ball.mesh->grid.dims().z,
        mesh_ball.mesh->grid.bytes() / 1e6, build_ms);
  }
  std::printf(
      "\ncontact = one apply_tool(press): gather + node tests + narrow phase on coupled vertices "
      "+ constraints + reaction forces; query = the broad phase and exact node tests alone (block "
      "boxes current); brute force = the exact test on every alive node (no broad phase). After "
      "the solver steps, the first query also refits the boxes (above).\n");
  return 0;
}
