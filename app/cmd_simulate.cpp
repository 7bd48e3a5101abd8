// `tsf simulate SCENE --steps N --report OUT.json`: runs a scene's CRMS lattice headless and
// reports energy over time, step rate, the stable-dt estimate, any instability and the backend.
// A scene with tissue, tools or a script runs interactively instead (scene/interaction_run.h):
// the tissue model is built from voxels, the script's tools press, ablate and cut it frame by
// frame, and the final deformed, cut mesh and a JSON report of the edits are written.
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "commands.h"
#include "output/interrupt.h"
#include "output/output_folder.h"
#include "scene/interaction_run.h"
#include "scene/scene.h"
#include "scene/scene_session.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/common/stopwatch.h"
#include "tsf/crms/solver.h"
#include "tsf/version.h"

namespace tsf::app {
namespace {

using nlohmann::json;

json to_json(const Vec3d& v) {
  return json::array({v.x, v.y, v.z});
}

json stable_json(const crms::StableTimeStep& s) {
  return {{"symplectic_euler_s", s.symplectic_euler_s},
          {"explicit_euler_s", s.explicit_euler_s},
          {"omega_max_rad_s", s.omega_max},
          {"zeta_at_omega_max", s.zeta_at_omega_max},
          {"damping_time_s", s.damping_time_s},
          {"critical_node", s.critical_node}};
}

struct SimulateArguments {
  std::string scene;
  std::string report;
  std::string backend;
  std::string out;
  std::string mesh;
  std::string states;
  std::int64_t steps = -1;
  std::int64_t states_every = 0;  ///< 0: the scene's outputs.states_every
  double duration_s = -1.0;
  bool force = false;
  bool quiet = false;
};

/// An interactive scene: the script plays on every instance (interaction_run.h). The scene's
/// `outputs:` are written in the output folder; --mesh, --report and --states name files directly.
void run_interactive(const Scene& scene, const SimulateArguments& args) {
  if (args.steps >= 0)
    throw Error("--steps: this scene runs a script (tissue/tools/script); use --duration");
  InteractionRunOptions run;
  if (args.duration_s >= 0) run.duration_s = args.duration_s;
  run.quiet = args.quiet;
  InteractionOutputs& out = run.outputs;
  out.states_every = args.states_every > 0 ? args.states_every : scene.outputs.states_every;
  // --states-every without a states file anywhere saves them as states.tsfmesh in the folder.
  const std::filesystem::path states_name = !scene.outputs.states.empty() ? scene.outputs.states
                                            : args.states_every > 0
                                                ? std::filesystem::path("states.tsfmesh")
                                                : std::filesystem::path();
  const bool writes_folder = !scene.outputs.rest_mesh.empty() ||
                             (!scene.outputs.mesh.empty() && args.mesh.empty()) ||
                             (!scene.outputs.report.empty() && args.report.empty()) ||
                             (!states_name.empty() && args.states.empty());
  OutputFolder folder;
  if (writes_folder || !args.out.empty())
    folder = OutputFolder::prepare(args.out.empty() ? std::filesystem::path("out") / scene.name
                                                    : std::filesystem::path(args.out),
                                   args.force, "--out");
  out.mesh = args.mesh.empty() ? folder.file(scene.outputs.mesh) : absolute_path(args.mesh);
  out.rest_mesh = folder.file(scene.outputs.rest_mesh);
  out.report = args.report.empty() ? folder.file(scene.outputs.report) : absolute_path(args.report);
  out.states = args.states.empty() ? folder.file(states_name) : absolute_path(args.states);
  InterruptScope interrupts;
  const InteractionResult result = run_interaction_scene(scene, run);
  if (result.interrupted)
    throw Error("interrupted (signal " + std::to_string(interrupt_signal()) + ") after " +
                std::to_string(result.frames) + " of " + std::to_string(result.frames_planned) +
                " frames; the outputs hold what was reached");
  if (result.instability) throw Error("unstable: " + *result.instability);
  if (const InstanceResult* worst = result.least_stable())
    require_stable_enough(worst->stability,
                          scene.multi_instance ? scene.name + "/" + worst->name : scene.name);
}

/// What a lattice-only run measured (typed; the report is made from it at the edge).
struct LatticeRunResult {
  std::int64_t steps_requested = 0;
  double stepping_s = 0;
  std::vector<std::pair<std::int64_t, crms::EnergyReport>> energy;  ///< (step, energy)
  double max_displacement_mm = 0;
  bool interrupted = false;
  crms::StabilitySummary stability;
};

/// Steps the lattice in chunks of solver.report_every, sampling energy after each, until the
/// steps are done, an instability halts it or a signal arrives.
LatticeRunResult step_lattice(const Scene& scene, LatticeRun& built, std::int64_t steps) {
  crms::Solver& solver = *built.solver;
  LatticeRunResult r;
  r.steps_requested = steps;
  r.energy.emplace_back(solver.steps_done(), solver.energy());
  Progress progress("simulate " + scene.name, static_cast<std::uint64_t>(steps));
  std::int64_t done = 0;
  InterruptScope interrupts;
  crms::StabilityMonitor monitor;
  while (done < steps && !solver.instability() && !interrupted()) {
    const auto chunk = static_cast<int>(std::min<std::int64_t>(scene.report_every, steps - done));
    Stopwatch clock;
    monitor.step(solver, chunk, built.dt_s);
    r.stepping_s += clock.seconds();
    done += chunk;
    progress.set(static_cast<std::uint64_t>(done));
    r.energy.emplace_back(solver.steps_done(), solver.energy());
  }
  progress.finish();
  r.interrupted = interrupted();
  r.stability = monitor.summary(solver);
  for (const Vec3f& u : solver.displacements())
    r.max_displacement_mm =
        std::max(r.max_displacement_mm, std::sqrt(static_cast<double>(dot(u, u))));
  return r;
}

json lattice_report_json(const Scene& scene, const LatticeRun& built, const LatticeRunResult& r) {
  const crms::Solver& solver = *built.solver;
  const crms::Lattice& l = solver.lattice();
  const crms::SolverConfig& config = solver.config();
  const double stable = solver.stable_dt();
  const std::int64_t run = solver.steps_done();
  const double rate = r.stepping_s > 0 ? static_cast<double>(run) / r.stepping_s : 0.0;
  json instability = nullptr;
  if (const auto& inst = solver.instability())
    instability = {{"step", inst->step},
                   {"node", inst->node},
                   {"coordinates",
                    json::array({inst->coordinates.x, inst->coordinates.y, inst->coordinates.z})},
                   {"rest_position_mm", to_json(inst->rest_position_mm)},
                   {"position_mm", to_json(inst->position_mm)},
                   {"message", inst->describe()}};
  json energy = json::array();
  for (const auto& [step, e] : r.energy)
    energy.push_back({{"step", step},
                      {"time_s", static_cast<double>(step) * built.dt_s},
                      {"kinetic_nj", e.kinetic_nj},
                      {"elastic_nj", e.elastic_nj},
                      {"gravitational_nj", e.gravitational_nj},
                      {"total_nj", e.total_nj()}});
  const crms::SpringConstants& k = solver.palette().entry[0];
  return {
      {"tsf_version", TSF_VERSION_STRING},
      {"scene", {{"name", scene.name}, {"file", absolute_path(scene.file).string()}}},
      {"frame", "patient (LPS), mm"},
      {"stability", stability_json(r.stability)},
      {"time_step", time_step_json(built.dt_choice)},
      {"interrupted", r.interrupted},
      {"backend", solver.backend_name()},
      {"integrator", crms::to_string(config.integrator)},
      {"angular_form", crms::to_string(config.angular_form)},
      {"angular_reactions", crms::to_string(config.angular_reactions)},
      {"effects", solver.active_effects()},
      {"volume_term_folded", solver.volume_term_folded()},
      {"poisson_ratio", poisson_json(scene, 0, solver)},
      {"triggers_fired", solver.fired_triggers()},
      {"lattice",
       {{"dims", json::array({l.geometry().dims.x, l.geometry().dims.y, l.geometry().dims.z})},
        {"spacing_mm", to_json(l.geometry().spacing)},
        {"origin_mm", to_json(l.geometry().origin)},
        {"alive_nodes", l.alive_count()},
        {"fixed_nodes", built.fixed_nodes},
        {"total_mass_g", l.total_mass()},
        {"bytes_per_node", solver.bytes_per_node()}}},
      {"springs",
       {{"ks_linear_un", json::array({k.ks_linear[0], k.ks_linear[1], k.ks_linear[2]})},
        {"kd_linear_un_s", json::array({k.kd_linear[0], k.kd_linear[1], k.kd_linear[2]})},
        {"k_angular_un_mm", json::array({k.k_angular[0], k.k_angular[1], k.k_angular[2]})},
        {"c_angular_un_mm_s", json::array({k.c_angular[0], k.c_angular[1], k.c_angular[2]})}}},
      {"stable_dt", stable_json(solver.stable_time_step())},
      {"dt_s", built.dt_s},
      {"dt_over_stable", stable > 0 ? built.dt_s / stable : static_cast<double>(INFINITY)},
      {"steps_requested", r.steps_requested},
      {"steps_run", run},
      {"setup_s", built.setup_s},
      {"stepping_s", r.stepping_s},
      {"steps_per_s", rate},
      {"node_steps_per_s", rate * static_cast<double>(l.node_count())},
      {"max_displacement_mm", r.max_displacement_mm},
      {"instability", instability},
      {"energy", energy},
  };
}

void print_lattice_summary(const Scene& scene, const LatticeRun& built, const LatticeRunResult& r) {
  const crms::Solver& solver = *built.solver;
  const crms::Lattice& l = solver.lattice();
  const double stable = solver.stable_dt();
  const std::int64_t run = solver.steps_done();
  const double rate = r.stepping_s > 0 ? static_cast<double>(run) / r.stepping_s : 0.0;
  std::printf("%s\n", r.stability.headline().c_str());
  std::printf("time step: %s\n", built.dt_choice.how.c_str());
  std::printf(
      "%s: %lld nodes (%lld alive, %lld fixed) on %s, %s, dt %.3g s (%.2f× the stable "
      "%.3g s)\n",
      scene.name.c_str(), static_cast<long long>(l.node_count()),
      static_cast<long long>(l.alive_count()), static_cast<long long>(built.fixed_nodes),
      solver.backend_name().c_str(), crms::to_string(solver.config().integrator), built.dt_s,
      stable > 0 ? built.dt_s / stable : 0.0, stable);
  std::string effects;
  for (const std::string& e : solver.active_effects()) effects += (effects.empty() ? "" : ", ") + e;
  std::printf("effects: %s%s\n", effects.empty() ? "none" : effects.c_str(),
              solver.volume_term_folded() ? " (the volumetric term inside the step launch)" : "");
  std::printf("%s\n", poisson_line(poisson_json(scene, 0, solver)).c_str());
  std::printf(
      "%lld steps in %.3f s: %.4g steps/s, %.4g node-steps/s; energy %.6g -> %.6g nJ; max "
      "displacement %.4g mm\n",
      static_cast<long long>(run), r.stepping_s, rate, rate * static_cast<double>(l.node_count()),
      r.energy.front().second.total_nj(), r.energy.back().second.total_nj(), r.max_displacement_mm);
}

/// A lattice-only scene: build, step, report, summary.
void run_lattice_only(const Scene& scene, const SimulateArguments& args) {
  if (args.duration_s >= 0 || !args.mesh.empty() || !args.states.empty() || args.states_every > 0)
    throw Error(
        "--duration, --mesh, --states and --states-every need a scene with a script (tissue, "
        "tools, script)");
  // The report: --report, else report.json in --out when an output folder is given.
  std::filesystem::path report_path = absolute_path(args.report);
  if (report_path.empty() && !args.out.empty())
    report_path = OutputFolder::prepare(args.out, args.force, "--out").file("report.json");
  LatticeRun built = build_lattice_run(scene);
  const LatticeRunResult r = step_lattice(scene, built, args.steps >= 0 ? args.steps : scene.steps);
  if (!report_path.empty())
    write_text_atomically(report_path, lattice_report_json(scene, built, r).dump(2) + "\n");
  if (r.interrupted)
    throw Error("interrupted (signal " + std::to_string(interrupt_signal()) + ") after " +
                std::to_string(built.solver->steps_done()) + " of " +
                std::to_string(r.steps_requested) + " steps");
  if (!args.quiet) print_lattice_summary(scene, built, r);
  if (const auto& inst = built.solver->instability()) throw Error("unstable: " + inst->describe());
  require_stable_enough(r.stability, scene.name);
}

void run_simulate(const SimulateArguments& args) {
  Scene scene = read_scene(args.scene);
  check_scene_for_command(scene, SceneCommand::kSimulate);
  override_backend(scene, args.backend);
  if (scene.interactive)
    run_interactive(scene, args);
  else
    run_lattice_only(scene, args);
}

}  // namespace

void add_simulate_command(CLI::App& app) {
  CLI::App* sub = app.add_subcommand(
      "simulate",
      "Run a scene headless: its mass-spring (CRMS) lattice (energy, step rate, stable time step, "
      "instability), or, when the scene has tissue, tools or a script, the tools pressing, "
      "ablating and cutting the tissue frame by frame (final deformed, cut mesh and a report)");
  auto args = std::make_shared<SimulateArguments>();
  sub->add_option("scene", args->scene,
                  "Scene file (YAML), e.g. scenes/beam.yaml, scenes/cut-block.yaml")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--steps,-n", args->steps, "Steps to run (default: the scene's solver.steps)")
      ->check(CLI::Range(std::int64_t{0}, std::int64_t{1'000'000'000'000}));
  sub->add_option("--duration", args->duration_s,
                  "Scripted scenes: seconds of script to play (default: the scene's "
                  "script.duration)")
      ->check(CLI::Range(0.0, 1e5));
  sub->add_option("--report,-r", args->report,
                  "Write a JSON report here (written atomically; overrides outputs.report)");
  sub->add_option("--out,-o", args->out,
                  "Scripted scenes: output folder for the scene's outputs (default out/<scene "
                  "name>; must be new or empty, see --force)");
  sub->add_flag("--force", args->force,
                "Replace the files of an earlier tsf run in the --out folder");
  sub->add_option("--mesh", args->mesh,
                  "Scripted scenes: write the final deformed, cut mesh here (binary .ply; "
                  "overrides outputs.mesh)");
  sub->add_option("--states", args->states,
                  "Scripted scenes: save the rest and deformed, cut states here (.tsfmesh mesh "
                  "sequence for `tsf export`; every outputs.states_every frames and the last; "
                  "overrides outputs.states)");
  sub->add_option("--states-every", args->states_every,
                  "Scripted scenes: save a state every N frames (overrides outputs.states_every; "
                  "without --states or outputs.states they go to states.tsfmesh in --out); "
                  "`tsf export STATES --frames all -o anim.glb` plays them, cuts included")
      ->check(CLI::Range(std::int64_t{1}, std::int64_t{1'000'000'000}));
  sub->add_option("--backend", args->backend, "Override the scene's backend: cpu, cuda or auto");
  sub->add_flag("--quiet,-q", args->quiet, "No summary or progress on the terminal");
  sub->callback([args] {
    if (!args->mesh.empty() && std::filesystem::path(args->mesh).extension() != ".ply")
      throw Error("--mesh: expected a .ply file name, got '" + args->mesh + "'");
    if (!args->states.empty() && std::filesystem::path(args->states).extension() != ".tsfmesh")
      throw Error("--states: expected a .tsfmesh file name, got '" + args->states + "'");
    run_simulate(*args);
  });
}

}  // namespace tsf::app
