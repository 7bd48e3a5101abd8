// Effect cost on a scene's lattice (effect_cost.h).
#include "run/effect_cost.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"

namespace tsf::app {
namespace {

using nlohmann::json;

struct Configuration {
  std::string name;
  crms::EffectsConfig effects;
  bool volumetric = false;  ///< the materials keep their ν (else ν = 0: no volumetric term)
  std::unique_ptr<crms::Solver> solver;
  std::vector<double> us_per_step;
  bool unstable = false;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n == 0 ? 0.0 : n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// `all` with only effect `name` left on.
crms::EffectsConfig only(const crms::EffectsConfig& all, const std::string& name) {
  crms::EffectsConfig e = all;
  e.plasticity.enabled = name == "plasticity" && all.plasticity.enabled;
  e.anisotropy.enabled = name == "anisotropy" && all.anisotropy.enabled;
  e.fluid.enabled = name == "fluid" && all.fluid.enabled;
  e.tearing.enabled = name == "tearing" && all.tearing.enabled;
  return e;
}

}  // namespace

json measure_effect_cost(const crms::Solver& solver, double dt, const EffectCostOptions& options) {
  require(options.repetitions >= 3, "effect cost: repetitions must be at least 3");
  require(options.seconds_per_repetition > 0, "effect cost: seconds_per_repetition must be > 0");
  require(dt > 0, "effect cost: the time step must be > 0");
  const crms::SolverConfig base = solver.config();
  // The scene's effects and, for materials with ν > 0, the volumetric term ("volumetric").
  const std::vector<std::string> active = solver.active_effects();
  std::vector<Configuration> configs;
  configs.push_back({"off", crms::EffectsConfig{}, false, nullptr, {}, false});
  configs.push_back(
      {"off again (noise reference)", crms::EffectsConfig{}, false, nullptr, {}, false});
  if (!active.empty()) {
    std::string all;
    for (const std::string& a : active) all += (all.empty() ? "" : " + ") + a;
    configs.push_back({all, base.effects, true, nullptr, {}, false});
    if (active.size() > 1)
      for (const std::string& a : active)
        configs.push_back(
            {a + " alone", only(base.effects, a), a == "volumetric", nullptr, {}, false});
  }
  // Copies of the final lattice and state: the measurement never touches the run's solver.
  const std::vector<Vec3f> u = solver.displacements(), v = solver.velocities();
  for (Configuration& c : configs) {
    crms::SolverConfig cfg = base;
    cfg.effects = c.effects;
    if (!c.volumetric)
      for (crms::Material& m : cfg.materials) m.poisson_ratio = 0.0;
    c.solver = std::make_unique<crms::Solver>(crms::Lattice(solver.lattice()), cfg);
    c.solver->set_state(u, v);
  }
  const std::int64_t alive = solver.lattice().alive_count();
  // Warm-up (caches, threads, CUDA graphs), timed on the slowest configuration to size the
  // repetitions (the second round: the first pays for first touches and thread start-up).
  double warm_us = 0;
  constexpr int kWarmSteps = 4;
  for (int round = 0; round < 2; ++round)
    for (Configuration& c : configs) {
      Stopwatch clock;
      c.solver->step(kWarmSteps, dt);
      if (round == 1) warm_us = std::max(warm_us, clock.seconds() * 1e6 / kWarmSteps);
    }
  const int steps = static_cast<int>(std::clamp(
      std::lround(options.seconds_per_repetition * 1e6 / std::max(warm_us, 1e-3)), 2L, 200L));
  for (int r = 0; r < options.repetitions; ++r)
    for (Configuration& c : configs) {
      Stopwatch clock;
      const crms::StepReport report = c.solver->step(steps, dt);
      const double s = clock.seconds();
      if (report.instability) {
        c.unstable = true;
        c.solver->clear_instability();
      }
      c.us_per_step.push_back(s * 1e6 / std::max<std::int64_t>(1, report.steps_run));
    }

  const double off = median(configs[0].us_per_step);
  const double off_min =
      *std::min_element(configs[0].us_per_step.begin(), configs[0].us_per_step.end());
  json rows = json::array();
  double spread = 0;
  for (const Configuration& c : configs) {
    const auto [lo, hi] = std::minmax_element(c.us_per_step.begin(), c.us_per_step.end());
    const double m = median(c.us_per_step);
    spread = std::max(spread, (*hi - *lo) / std::max(m, 1e-12));
    rows.push_back({{"name", c.name},
                    {"effects", c.solver->active_effects()},
                    {"median_us_per_step", m},
                    {"min_us_per_step", *lo},
                    {"max_us_per_step", *hi},
                    {"ratio_to_off", off > 0 ? m / off : 0.0},
                    // Minima: the least disturbed repetition of each (a loaded machine only adds).
                    {"ratio_to_off_min", off_min > 0 ? *lo / off_min : 0.0},
                    {"bytes_per_node", c.solver->bytes_per_node()},
                    {"unstable", c.unstable}});
  }
  const double again = median(configs[1].us_per_step);
  return {{"backend", solver.backend_name()},
          {"alive_nodes", alive},
          {"steps_per_repetition", steps},
          {"repetitions", options.repetitions},
          {"dt_s", dt},
          {"configurations", rows},
          // Two identical configurations differ by this much: smaller ratios are noise.
          {"noise_off_vs_off_again", off > 0 ? std::fabs(again / off - 1.0) : 0.0},
          {"noise_largest_spread", spread}};
}

}  // namespace tsf::app
