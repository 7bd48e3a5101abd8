// The cost of the optional CRMS effects (docs/effects.md): time per step and bytes per node for the
// baseline, every effect alone (palette blends, plasticity, anisotropy, fluid, tearing, node
// masking, rest-shape animation, the volumetric term of a material with ν > 0) and all together,
// on cubic lattices, CPU and CUDA. "Disabled"
// is a scene whose effects carry parameters but are switched off: it must cost what the
// baseline costs, within the run-to-run noise measured here (the spread of the baseline's own
// repetitions, printed as the noise band).
//
//   build/bench/bench_effects                          64³ and 128³, every available backend
//   build/bench/bench_effects --sizes 32,64 --backends cpu --reps 5
//
// Configurations are timed round-robin (repetition r of every configuration before repetition
// r + 1 of any), so slow drifts of a shared machine hit them alike. Time per step = median over
// the repetitions; lattice 1 mm spacing, symmetric reactions, E = 10 kPa, gravity, one face
// clamped, a mild initial compression so that every effect has work to do.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "tsf/common/cuda_support.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/solver.h"

namespace {

using namespace tsf;
using namespace tsf::crms;

struct Variant {
  std::string name;
  EffectsConfig effects;
  /// Heterogeneous tissue (features::kHeterogeneous), 3 materials: kLayers = three layers along y,
  /// pure nodes with one blended node layer at each interface (what CT gives: blends only where
  /// classes meet); kAllBlended = every node a 2-entry blend (the worst case).
  enum class Palette { kNone, kLayers, kAllBlended };
  Palette palette = Palette::kNone;
  /// The materials' Poisson ratio: > 0 runs the volumetric term (volume_term.h); the palette's
  /// stiff entry gets 0.4.
  double poisson_ratio = 0.0;
};

/// Animation: two rest keyframes (a 5% swelling along z over 1 s); filled per lattice.
AnimationConfig swelling(const Lattice& l) {
  AnimationConfig a;
  a.enabled = true;
  RestKeyframe start, end;
  end.time_s = 1.0;
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    const Vec3d p = l.geometry().rest_position(n);
    start.rest_displacement_mm.push_back({0.0f, 0.0f, 0.0f});
    end.rest_displacement_mm.push_back({0.0f, 0.0f, static_cast<float>(0.05 * p.z)});
  }
  a.rest_keyframes = {start, end};
  return a;
}

std::vector<Variant> variants() {
  EffectsConfig plastic, aniso, fluid, tear, mask, animation, all, disabled;
  plastic.plasticity.enabled = true;
  plastic.plasticity.yield_strain = 0.02;
  plastic.plasticity.recovery_rate = 5;
  aniso.anisotropy.enabled = true;
  aniso.anisotropy.axis = {1, 1, 0};
  aniso.anisotropy.stiffness_factor = 3;
  fluid.fluid.enabled = true;
  fluid.fluid.bulk_modulus_pa = 10e3;
  fluid.fluid.diffusion_rate = 100;
  tear.tearing.enabled = true;
  tear.tearing.strain_threshold = 0.5;
  mask.tearing = tear.tearing;
  mask.tearing.node_force_threshold_un = 1e5;
  animation.animation.enabled = true;  // keyframes filled in make_solver
  all.plasticity = plastic.plasticity;
  all.anisotropy = aniso.anisotropy;
  all.fluid = fluid.fluid;
  all.tearing = mask.tearing;
  all.animation = animation.animation;
  disabled = all;
  disabled.plasticity.enabled = disabled.anisotropy.enabled = disabled.fluid.enabled =
      disabled.tearing.enabled = disabled.animation.enabled = false;
  return {{"baseline", {}},
          {"all configured, disabled", disabled},
          {"palette, 3 layers (blends at interfaces)", {}, Variant::Palette::kLayers},
          {"palette, every node a 2-entry blend", {}, Variant::Palette::kAllBlended},
          {"plasticity", plastic},
          {"anisotropy", aniso},
          {"fluid", fluid},
          {"tearing (springs)", tear},
          {"tearing + node masking", mask},
          {"animation (rest keyframes)", animation},
          {"volumetric term (ν = 0.45)", {}, Variant::Palette::kNone, 0.45},
          {"volumetric term, layered palette (ν = 0.45, 0.4, 0.45)",
           {},
           Variant::Palette::kLayers,
           0.45},
          {"all, with layered palette", all, Variant::Palette::kLayers}};
}

std::unique_ptr<Solver> make_solver(int edge, Backend backend, const Variant& variant) {
  BoxLatticeOptions o;
  o.size_mm = {double(edge), double(edge), double(edge)};
  o.spacing_mm = 1.0;
  Lattice l = build_box_lattice(o);
  fix_nodes_behind_plane(l, {0.6, 0, 0}, {1, 0, 0});
  SolverConfig c;
  c.backend = backend;
  Material m;
  m.youngs_modulus_pa = 10e3;
  m.viscosity_pa_s = 2.0;
  m.poisson_ratio = variant.poisson_ratio;
  c.materials = {m};
  if (variant.palette != Variant::Palette::kNone) {  // soft, stiff, fibrous
    Material stiff = m, fibre = m;
    stiff.youngs_modulus_pa = 30e3;
    stiff.viscosity_pa_s = 6.0;
    if (variant.poisson_ratio > 0) stiff.poisson_ratio = 0.4;
    fibre.anisotropy_axis = {0, 0, 1};
    fibre.anisotropy_factor = 2;
    c.materials = {m, stiff, fibre};
    for (std::int64_t n = 0; n < l.node_count(); ++n) {
      const double y = l.geometry().rest_position(n).y / edge;
      if (variant.palette == Variant::Palette::kAllBlended) {
        l.set_material(n, make_material_blend({0, n % 2 ? 1 : 2, 0, 0}, {1.0 - y, y, 0, 0}));
      } else {
        const int layer = std::min(2, static_cast<int>(3.0 * y));
        const double to_interface = std::min(std::abs(3.0 * y - 1.0), std::abs(3.0 * y - 2.0));
        l.set_material(n, to_interface * edge / 3.0 < 0.5
                              ? make_material_blend({layer, layer == 0 ? 1 : layer - 1, 0, 0},
                                                    {0.5, 0.5, 0, 0})
                              : MaterialBlend::single(layer));
      }
    }
  }
  c.gravity = {0, 0, -9810};
  c.effects = variant.effects;
  if (c.effects.animation.enabled) c.effects.animation = swelling(l);
  auto s = std::make_unique<Solver>(std::move(l), c);
  // 3% compression along x: springs, cubes and plastic offsets all see strain.
  const auto count = static_cast<std::size_t>(s->lattice().node_count());
  std::vector<Vec3f> u(count), v(count);
  for (std::size_t n = 0; n < count; ++n) {
    const Vec3d p = s->lattice().geometry().rest_position(static_cast<std::int64_t>(n));
    u[n] = {static_cast<float>(-0.03 * (p.x - 0.5)), 0.0f, 0.0f};
  }
  s->set_state(u, v);
  return s;
}

double seconds_per_step(Solver& s, int steps, double dt) {
  const auto t0 = std::chrono::steady_clock::now();
  s.step(steps, dt);  // waits for the device
  const auto t1 = std::chrono::steady_clock::now();
  return std::chrono::duration<double>(t1 - t0).count() / steps;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

std::vector<int> parse_ints(const char* text) {
  std::vector<int> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(std::atoi(item.c_str()));
  return out;
}

void usage() {
  std::printf(
      "bench_effects [--sizes 64,128] [--backends cpu,cuda] [--reps 5] [--cpu-steps N] "
      "[--cuda-steps N]\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<int> sizes{64, 128};
  std::vector<Backend> backends{Backend::kCpu};
  if (cuda_status().available) backends.push_back(Backend::kCuda);
  int reps = 5, cpu_steps = 0, cuda_steps = 0;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    const char* value = a + 1 < argc ? argv[a + 1] : nullptr;
    if (arg.rfind("--benchmark_", 0) == 0) continue;  // Google Benchmark options (gpu-check.sh)
    if (arg == "--help" || arg == "-h") {
      usage();
      return 0;
    }
    if (!value) {
      std::fprintf(stderr, "bench_effects: %s needs a value\n", arg.c_str());
      return 2;
    }
    ++a;
    if (arg == "--sizes") {
      sizes = parse_ints(value);
    } else if (arg == "--reps") {
      reps = std::max(3, std::atoi(value));
    } else if (arg == "--cpu-steps") {
      cpu_steps = std::atoi(value);
    } else if (arg == "--cuda-steps") {
      cuda_steps = std::atoi(value);
    } else if (arg == "--backends") {
      backends.clear();
      if (std::strstr(value, "cpu")) backends.push_back(Backend::kCpu);
      if (std::strstr(value, "cuda")) {
        if (!cuda_status().available) {
          std::fprintf(stderr, "bench_effects: no CUDA: %s\n", cuda_status().reason.c_str());
          return 2;
        }
        backends.push_back(Backend::kCuda);
      }
    } else {
      std::fprintf(stderr, "bench_effects: unknown option %s\n", arg.c_str());
      usage();
      return 2;
    }
  }

  const std::vector<Variant> all = variants();
  for (Backend backend : backends)
    for (int edge : sizes) {
      const bool cuda = backend == Backend::kCuda;
      int steps = cuda ? cuda_steps : cpu_steps;
      if (steps <= 0) {
        const double nodes = double(edge) * edge * edge;
        steps = std::max(2, static_cast<int>((cuda ? 2e9 : 2e7) * 0.2 / nodes / 4) * 2);
      }
      std::vector<std::unique_ptr<Solver>> solvers;
      for (const Variant& v : all) solvers.push_back(make_solver(edge, backend, v));
      double dt = solvers.front()->stable_dt();  // the same dt for every variant: the smallest
      for (auto& s : solvers) dt = std::min(dt, s->stable_dt());  // half stable step of any
      dt *= 0.5;
      for (auto& s : solvers) s->step(steps, dt);  // warm-up: graphs, caches, pages
      std::vector<std::vector<double>> times(all.size());
      for (int r = 0; r < reps; ++r)
        for (std::size_t i = 0; i < all.size(); ++i)
          times[i].push_back(seconds_per_step(*solvers[i], steps, dt));
      const double base = median(times[0]);
      const auto [lo, hi] = std::minmax_element(times[0].begin(), times[0].end());
      const double band = (*hi - *lo) / base;
      std::printf("\n%s, %d³ (%s), %d steps × %d repetitions, dt = %.3g s\n",
                  solvers.front()->backend_name().c_str(), edge,
                  to_string(solvers.front()->config().angular_reactions), steps, reps, dt);
      std::printf("baseline noise band (max − min)/median over its repetitions: ±%.1f%%\n",
                  50.0 * band);
      std::printf("| variant | ms/step | vs baseline | bytes/node | finite |\n");
      std::printf("| --- | --- | --- | --- | --- |\n");
      for (std::size_t i = 0; i < all.size(); ++i) {
        const double t = median(times[i]);
        const bool finite = !solvers[i]->instability();
        std::printf("| %s | %.3f | %.2f× | %.0f | %s |\n", all[i].name.c_str(), 1e3 * t, t / base,
                    solvers[i]->bytes_per_node(), finite ? "yes" : "NO");
      }
      std::fflush(stdout);
    }
  return 0;
}
