// `tsf run`: the pipeline of run_pipeline.h, as named stages that pass typed results:
//   prepare_run        read the scene, check its keys for `tsf run`, backend, output folder
//   segment_stage      import → segment (when the scene has a pipeline section)
//   interaction_stage  the scene session: surface, lattice, coupler, the script (energy per frame,
//                      effect cost after it)
//   export_stage       GLB of each final surface, from the run's own meshes
//   assemble_report    the JSON report (the edge: JSON is made here only), then run-report.md
#include "run/run_pipeline.h"

#include <algorithm>
#include <cstdio>
#include <set>
#include <vector>

#include "output/interrupt.h"
#include "output/output_folder.h"
#include "run/effect_cost.h"
#include "run/material_library.h"
#include "run/repo_paths.h"
#include "run/run_report.h"
#include "run/run_spec.h"
#include "scene/interaction_run.h"
#include "scene/scene.h"
#include "scene/scene_session.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/version.h"
#ifdef TSF_HAVE_EXPORT
#include "tsf/export/mesh_export.h"
#endif
#ifdef TSF_HAVE_SEGMENT
#include "tsf/segment/segment_job.h"
#include "tsf/segment/segment_preset.h"
#endif

namespace tsf::app {
namespace fs = std::filesystem;
using nlohmann::json;

fs::path default_scene_path() {
  return find_bundled_path("scenes/sinus.yaml");
}

namespace {

struct Stage {
  std::string name;
  double seconds = 0;
  std::string detail;
};

/// What every stage reads and adds to.
struct RunContext {
  const RunOptions& options;
  Scene scene;
  OutputFolder folder;
  std::vector<Stage> stages;
};

struct SegmentOutcome {
  json report = nullptr;  ///< segment's own report (null without a pipeline section)
};

struct EnergySample {
  double time_s = 0;
  crms::EnergyReport energy;
};

struct InteractionOutcome {
  InteractionResult result;
  std::vector<std::vector<EnergySample>> energy;  ///< per instance
  std::vector<std::int64_t> alive_nodes;          ///< per instance, at the first frame
  double effect_cost_s = 0;
  fs::path report_path;  ///< the interaction's own JSON report
};

std::string fixed(double v, int decimals) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", decimals, v);
  return b;
}

json vec(const Vec3d& v) {
  return json::array({v.x, v.y, v.z});
}

// ---- prepare: everything checkable before the long stages ------------------------------------

RunContext prepare_run(const RunOptions& options) {
  Stopwatch clock;
  RunContext ctx{options, read_scene(options.scene), {}, {}};
  Scene& scene = ctx.scene;
  check_scene_for_command(scene, SceneCommand::kRun);
  override_backend(scene, options.backend);
  if (scene.pipeline.present) {
    for (std::size_t i = 0; i < scene.instances.size(); ++i)
      if (scene.instances[i].lattice.source != SceneLattice::Source::kVolume)
        throw Error(scene.instance_prefix(i) +
                    "lattice.source: a scene with a pipeline section builds its lattice from the "
                    "segmented CT: expected source: volume");
    if (!fs::exists(scene.pipeline.ct))
      throw Error(scene.file.string() + ": pipeline.source.ct: '" + scene.pipeline.ct.string() +
                  "' does not exist");
  }
  // Output folder: command line, then the scene, then out/<scene name> here.
  const fs::path folder = !options.output_folder.empty()   ? options.output_folder
                          : !scene.pipeline.folder.empty() ? scene.pipeline.folder
                                                           : fs::path("out") / scene.name;
  ctx.folder = OutputFolder::prepare(folder, options.force,
                                     options.output_folder.empty() ? "output folder" : "--output");
  ctx.stages.push_back(
      {"read and check the scene", clock.seconds(), absolute_path(scene.file).string()});
  return ctx;
}

// ---- segment: import → segment, the volumes every instance is built from -------------------

SegmentOutcome segment_stage(RunContext& ctx) {
  SegmentOutcome out;
  const RunSpec& spec = ctx.scene.pipeline;
  if (!spec.present) return out;
#ifdef TSF_HAVE_SEGMENT
  Stopwatch clock;
  segment::SegmentJob job;
  job.input = spec.ct;
  job.preset = segment::load_segment_preset(spec.preset);
  const double voxel = ctx.options.voxel_mm ? *ctx.options.voxel_mm : spec.voxel_mm;
  if (voxel > 0) {
    job.preset.resample.voxel_mm = voxel;
    job.overrides.push_back("resample.voxel_mm=" + std::to_string(voxel));
  }
  if (spec.smoothing_mm >= 0) {
    job.preset.smoothing.sigma_mm = spec.smoothing_mm;
    job.overrides.push_back("smoothing.sigma_mm=" + std::to_string(spec.smoothing_mm));
  }
  job.preset.validate();
  job.output_prefix = ctx.folder.file(ctx.scene.name);
  job.show_progress = !ctx.options.quiet;
  const segment::SegmentJobResult seg = segment::run_segment_job(job);
  const double wall = clock.seconds();
  out.report = seg.report;
  const double read_s = seg.report["input"].value("read_seconds", 0.0);
  const double write_s = seg.report["outputs"].value("write_seconds", 0.0);
  ctx.stages.push_back({"import (read CT)", read_s, absolute_path(spec.ct).string()});
  ctx.stages.push_back({"segment (preset " + job.preset.name + ")",
                        std::max(0.0, wall - read_s - write_s),
                        fixed(seg.report["grid"].value("voxel_mm", 0.0), 2) + " mm voxels"});
  ctx.stages.push_back({"write segmented volumes", write_s,
                        seg.volume_paths.density.filename().string() + ", labels, weights"});
  for (SceneInstance& inst : ctx.scene.instances) inst.lattice.volume = seg.volume_paths.density;
#else
  throw Error(ctx.scene.file.string() +
              ": pipeline: import and segmentation need a build with ITK "
              "(reconfigure with -DTSF_WITH_ITK=ON)");
#endif
  return out;
}

// ---- interaction: the scene session and its script ------------------------------------------

InteractionOutcome interaction_stage(RunContext& ctx) {
  const Scene& scene = ctx.scene;
  const RunSpec& spec = scene.pipeline;
  InteractionOutcome out;
  const std::size_t n = scene.instances.size();
  out.energy.resize(n);
  out.alive_nodes.assign(n, 0);
  std::vector<std::int64_t> frames_seen(n, 0);
  const int energy_every = spec.present ? spec.energy_every : 1;

  InteractionRunOptions run;
  run.duration_s = ctx.options.duration_s;
  run.quiet = ctx.options.quiet;
  // The run's own files, then the scene's `outputs:` names, all inside the folder.
  InteractionOutputs& o = run.outputs;
  o.report =
      ctx.folder.file(scene.outputs.report.empty() ? std::filesystem::path("interaction.json")
                                                   : scene.outputs.report);
  const bool meshes = spec.meshes || !spec.present;
  o.mesh = meshes ? ctx.folder.file(scene.name + "-final.ply") : fs::path();
  o.rest_mesh = meshes ? ctx.folder.file(scene.name + "-rest.ply") : fs::path();
  if (!scene.outputs.mesh.empty()) o.mesh = ctx.folder.file(scene.outputs.mesh);
  if (!scene.outputs.rest_mesh.empty()) o.rest_mesh = ctx.folder.file(scene.outputs.rest_mesh);
  o.states = ctx.folder.file(scene.outputs.states);
  o.states_every = scene.outputs.states_every;
  run.on_frame = [&](double time_s, std::size_t i, const interaction::TissueModel& model) {
    if (frames_seen[i]++ == 0) out.alive_nodes[i] = model.alive_nodes();
    if ((frames_seen[i] - 1) % energy_every == 0)
      out.energy[i].push_back({time_s, model.solver().energy()});
  };
  // After the script: what the effects cost on each instance's final lattice (effect_cost.h). With
  // no effect on it still measures "off" twice: the noise band a paired run compares against
  // (the report's Markdown shows the table only when effects are on).
  run.extra_key = "effect_cost";
  run.after_script = [&](std::size_t i, interaction::TissueModel& model) -> json {
    Stopwatch clock;
    if (!ctx.options.quiet)
      std::printf("tsf run: measuring the effects' step cost on %s's lattice\n",
                  scene.instances[i].name.c_str());
    json cost = measure_effect_cost(model.solver(), model.dt(), EffectCostOptions{});
    out.effect_cost_s += clock.seconds();
    return cost;
  };
  out.report_path = o.report;
  Stopwatch clock;
  out.result = run_interaction_scene(scene, run);
  const double wall = clock.seconds();

  double setup_total = 0;
  for (const InstanceResult& r : out.result.instances) {
    setup_total += r.setup_s;
    ctx.stages.push_back(
        {"surface + lattice + coupler" + (scene.multi_instance ? " (" + r.name + ")" : ""),
         r.setup_s,
         std::to_string(r.alive_start) + " nodes at " + fixed(r.lattice_spacing_mm.x, 2) + " mm, " +
             std::to_string(r.topology_start.triangles) + " triangles"});
  }
  std::int64_t steps = 0;
  for (const InstanceResult& r : out.result.instances) steps += r.steps;
  ctx.stages.push_back({"scripted interaction", out.result.script_s,
                        std::to_string(out.result.frames) + " frames, " + std::to_string(steps) +
                            " steps" + (n > 1 ? " over " + std::to_string(n) + " instances" : "")});
  if (out.effect_cost_s > 0)
    ctx.stages.push_back({"effect cost measurement", out.effect_cost_s,
                          "step time with the scene's effects vs all off, interleaved"});
  ctx.stages.push_back({"write meshes and states",
                        std::max(0.0, wall - setup_total - out.result.script_s - out.effect_cost_s),
                        o.mesh.empty() ? "none" : o.mesh.filename().string()});
  return out;
}

// ---- export: GLB of each final surface in the patient frame ---------------------------------

std::vector<fs::path> export_stage(RunContext& ctx, const InteractionResult& result) {
  std::vector<fs::path> files;
#ifdef TSF_HAVE_EXPORT
  Stopwatch clock;
  for (const InstanceResult& r : result.instances) {
    if (r.outputs.mesh.empty()) continue;
    exporter::ExportOptions eo;
    eo.format = exporter::ExportFormat::glb;
    eo.name = ctx.scene.multi_instance ? ctx.scene.name + "-" + r.name : ctx.scene.name;
    eo.source = "tsf run " + absolute_path(ctx.scene.file).string();
    const fs::path glb = r.outputs.mesh.parent_path() / (r.outputs.mesh.stem().string() + ".glb");
    const exporter::ExportReport er =
        exporter::export_surface(r.final_mesh, r.patient_frame, glb, eo);
    for (const auto& f : er.files) files.push_back(absolute_path(f.path));
  }
  if (!files.empty()) {
    std::string names;
    for (const fs::path& f : files) names += (names.empty() ? "" : ", ") + f.filename().string();
    ctx.stages.push_back({"export (glTF binary)", clock.seconds(), names});
  }
#else
  (void)ctx;
  (void)result;
#endif
  return files;
}

// ---- the report ------------------------------------------------------------------------------

json material_json(const Scene& scene, const SceneInstance& inst) {
  if (inst.material_id.empty())
    return {{"instance", inst.name},
            {"id", nullptr},
            {"name", "inline (scene file)"},
            {"youngs_modulus_pa", inst.material.youngs_modulus_pa},
            {"density_g_per_mm3", inst.material.density_g_per_mm3}};
  const fs::path lib_path = scene.pipeline.material_library.empty()
                                ? default_material_library_path()
                                : scene.pipeline.material_library;
  const MaterialLibrary library = read_material_library(lib_path);
  const LibraryMaterial& m = library.get(inst.material_id);
  json sources = json::array();
  for (const auto& src : m.sources) sources.push_back(src.citation);
  return {{"instance", inst.name},
          {"id", m.id},
          {"name", m.name},
          {"library", absolute_path(lib_path).string()},
          {"youngs_modulus_pa", m.youngs_modulus_pa},
          {"damping_time_s", m.damping_time_s},
          {"density_g_per_mm3", m.density_g_per_mm3},
          {"sources", sources}};
}

json energy_json(const std::vector<EnergySample>& samples) {
  json a = json::array();
  for (const EnergySample& s : samples)
    a.push_back({{"time_s", s.time_s},
                 {"kinetic_nj", s.energy.kinetic_nj},
                 {"elastic_nj", s.energy.elastic_nj},
                 {"gravitational_nj", s.energy.gravitational_nj},
                 {"total_nj", s.energy.total_nj()}});
  return a;
}

/// "completed", "unstable" or "interrupted", and why.
std::pair<std::string, std::string> verdict(const InteractionResult& r) {
  if (r.interrupted)
    return {"interrupted", "stopped by a signal after " + std::to_string(r.frames) + " of " +
                               std::to_string(r.frames_planned) + " frames"};
  if (r.instability) return {"unstable", *r.instability};
  return {"completed", "every frame of the script was played"};
}

json assemble_report(const RunContext& ctx, const SegmentOutcome& seg, const InteractionOutcome& io,
                     const std::vector<fs::path>& exported, double total_s) {
  const Scene& scene = ctx.scene;
  const InteractionResult& result = io.result;
  json instances = json::array();
  std::set<std::string> effects_union;
  double node_steps = 0, stepping = 0, steps = 0;
  for (const InstanceResult& r : result.instances) {
    const json ir = instance_report_json(scene, result, r);
    const double st = r.stepping_s;
    const double n_steps = static_cast<double>(r.steps);
    const double alive = static_cast<double>(io.alive_nodes[r.index]);
    node_steps += n_steps * alive;
    stepping += st;
    steps += n_steps;
    effects_union.insert(r.effects_active.begin(), r.effects_active.end());
    instances.push_back({{"name", r.name},
                         {"material", material_json(scene, scene.instances[r.index])},
                         {"effects_active", r.effects_active},
                         {"kernel_features", r.kernel_features},
                         {"bytes_per_node", r.bytes_per_node},
                         {"labels", scene.instances[r.index].lattice.labels},
                         {"lattice_spacing_mm", vec(r.lattice_spacing_mm)},
                         {"alive_nodes_start", r.alive_start},
                         {"alive_nodes_end", r.alive_end},
                         {"fixed_nodes", r.fixed_nodes},
                         {"integrator", r.integrator},
                         {"dt_s", r.dt_s},
                         {"steps", n_steps},
                         {"timings_s", ir["timings_s"]},
                         {"steps_per_s", st > 0 ? n_steps / st : 0.0},
                         {"node_steps_per_s", st > 0 ? n_steps * alive / st : 0.0},
                         {"surface", ir["surface"]},
                         {"totals", ir["totals"]},
                         {"outputs", ir["outputs"]},
                         {"effect_cost", r.extra.is_null() ? json(nullptr) : r.extra},
                         {"energy", energy_json(io.energy[r.index])}});
  }
  // Scene-wide energy: the sum over instances frame by frame (every instance advances every
  // frame).
  std::vector<EnergySample> total = io.energy.empty() ? std::vector<EnergySample>{} : io.energy[0];
  for (std::size_t i = 1; i < io.energy.size(); ++i)
    for (std::size_t k = 0; k < total.size() && k < io.energy[i].size(); ++k) {
      total[k].energy.kinetic_nj += io.energy[i][k].energy.kinetic_nj;
      total[k].energy.elastic_nj += io.energy[i][k].energy.elastic_nj;
      total[k].energy.gravitational_nj += io.energy[i][k].energy.gravitational_nj;
    }
  // The time step: one instance's, or each instance's when they differ.
  const double dt = result.instances.size() == 1 ? result.instances[0].dt_s : 0.0;
  const double simulated =
      result.frame_rate_hz > 0 ? static_cast<double>(result.frames) / result.frame_rate_hz : 0.0;
  const auto [verdict_word, verdict_reason] = verdict(result);
  json exported_json = json::array();
  for (const fs::path& f : exported) exported_json.push_back(f.string());
  json stages = json::array();
  for (const Stage& s : ctx.stages)
    stages.push_back({{"stage", s.name}, {"seconds", s.seconds}, {"detail", s.detail}});
  const json interaction = interaction_report_json(scene, result);
  return {
      {"tsf_version", TSF_VERSION_STRING},
      {"scene", {{"name", scene.name}, {"file", absolute_path(scene.file).string()}}},
      {"frame", "patient (LPS), mm"},
      {"verdict", verdict_word},
      {"verdict_reason", verdict_reason},
      {"output_folder", ctx.folder.path().string()},
      {"interaction_report", io.report_path.string()},
      {"material", instances.empty() ? json(nullptr) : instances[0]["material"]},
      {"backend", result.instances.empty() ? "" : result.instances[0].backend},
      {"effects_active", json(effects_union)},
      {"effects_note",
       "effects the solver ran (the scene's effects: section); an effect that is off launches no "
       "pass and allocates no array. effect_cost per instance with effects on: step time on the "
       "final lattice with the scene's effects vs all off, interleaved"},
      {"instances", instances},
      {"stages", stages},
      {"rates",
       {{"steps", steps},
        {"dt_s", dt},
        {"simulated_s", simulated},
        {"stepping_s", stepping},
        {"steps_per_s", stepping > 0 ? steps / stepping : 0.0},
        {"node_steps_per_s", stepping > 0 ? node_steps / stepping : 0.0},
        {"real_time_factor", result.script_s > 0 ? simulated / result.script_s : 0.0}}},
      {"segmentation", seg.report},
      {"interaction", interaction},
      {"energy", energy_json(total)},
      {"exported", exported_json},
      {"failure",
       verdict_word == "completed" ? json(nullptr) : json(verdict_word + ": " + verdict_reason)},
      {"total_seconds", total_s},
  };
}

}  // namespace

json run_pipeline(const RunOptions& options) {
  Stopwatch total_clock;
  RunContext ctx = prepare_run(options);
  InterruptScope interrupts;
  const SegmentOutcome seg = segment_stage(ctx);
  if (interrupted()) {
    // Stopped before the simulation: the report says so, with what was done.
    json stages = json::array();
    for (const Stage& s : ctx.stages)
      stages.push_back({{"stage", s.name}, {"seconds", s.seconds}, {"detail", s.detail}});
    const std::string why = "interrupted (signal " + std::to_string(interrupt_signal()) +
                            ") after segmentation; nothing was simulated";
    write_text_atomically(ctx.folder.file("run-report.json"),
                          json{{"tsf_version", TSF_VERSION_STRING},
                               {"scene", {{"name", ctx.scene.name},
                                          {"file", absolute_path(ctx.scene.file).string()}}},
                               {"verdict", "interrupted"},
                               {"verdict_reason", why},
                               {"stages", stages},
                               {"segmentation", seg.report},
                               {"failure", why}}
                                  .dump(2) +
                              "\n");
    throw Error(why + " (" + ctx.folder.path().string() + ")");
  }
  const InteractionOutcome io = interaction_stage(ctx);
  const std::vector<fs::path> exported = export_stage(ctx, io.result);
  const json report = assemble_report(ctx, seg, io, exported, total_clock.seconds());
  write_text_atomically(ctx.folder.file("run-report.json"), report.dump(2) + "\n");
  const RunSpec& spec = ctx.scene.pipeline;
  if (spec.report || !spec.present) {
    const fs::path md = write_run_report(report, ctx.folder.path(), spec.plots || !spec.present);
    if (!options.quiet) std::printf("tsf run: report %s\n", md.string().c_str());
  }
  if (!report["failure"].is_null()) throw Error(report["failure"].get<std::string>());
  return report;
}

}  // namespace tsf::app
