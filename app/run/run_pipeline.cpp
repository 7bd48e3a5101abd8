// `tsf run`: the pipeline of run_pipeline.h.
#include "run/run_pipeline.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <set>
#include <vector>

#include "run/effect_cost.h"
#include "run/material_library.h"
#include "run/repo_paths.h"
#include "run/run_report.h"
#include "run/run_spec.h"
#include "scene/interaction_run.h"
#include "scene/scene.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/version.h"
#ifdef TSF_HAVE_EXPORT
#include "tsf/export/mesh_export.h"
#include "tsf/import/tissue_volume_io.h"
#include "tsf/imt/surface_ply.h"
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

json stages_json(const std::vector<Stage>& stages) {
  json a = json::array();
  for (const Stage& s : stages)
    a.push_back({{"stage", s.name}, {"seconds", s.seconds}, {"detail", s.detail}});
  return a;
}

}  // namespace

json run_pipeline(const RunOptions& options) {
  Stopwatch total_clock;
  std::vector<Stage> stages;
  Stopwatch clock;
  Scene scene = read_scene(options.scene);
  const RunSpec spec = read_run_spec(options.scene);
  if (!scene.tissue.present)
    throw Error(options.scene.string() +
                ": tsf run needs an interaction scene (tissue, tools and a script); this one only "
                "steps a lattice: run it with `tsf simulate`");

  // Output folder: command line, then the scene, then out/<scene name> here.
  const fs::path folder = !options.output_folder.empty() ? options.output_folder
                          : !spec.folder.empty()         ? spec.folder
                                                         : fs::path("out") / scene.name;
  fs::create_directories(folder);

  // Materials from the library: pipeline.material (single form) or each instance's id.
  const fs::path lib_path =
      spec.material_library.empty() ? default_material_library_path() : spec.material_library;
  std::optional<MaterialLibrary> library;
  auto library_material = [&](const std::string& id, const std::string& key) {
    if (!library) library = read_material_library(lib_path);
    const LibraryMaterial* m = library->find(id);
    if (!m) {
      std::string known;
      for (const auto& k : library->materials) known += (known.empty() ? "" : ", ") + k.id;
      throw Error(options.scene.string() + ": " + key + ": no material '" + id + "' in " +
                  lib_path.string() + " (known: " + known + ")");
    }
    return *m;
  };
  if (!spec.material.empty()) {
    const LibraryMaterial m = library_material(spec.material, "pipeline.material");
    scene.solver.materials.at(0) = m.crms_material();
    scene.instances.at(0).material = m.crms_material();
    scene.instances.at(0).material_id = m.id;
  }
  json materials = json::array();
  for (const SceneInstance& inst : scene.instances) {
    if (inst.material_id.empty()) {
      materials.push_back({{"instance", inst.name},
                           {"id", nullptr},
                           {"name", "inline (scene file)"},
                           {"youngs_modulus_pa", inst.material.youngs_modulus_pa},
                           {"density_g_per_mm3", inst.material.density_g_per_mm3}});
      continue;
    }
    const LibraryMaterial m = library_material(inst.material_id, "material");
    json sources = json::array();
    for (const auto& src : m.sources) sources.push_back(src.citation);
    materials.push_back({{"instance", inst.name},
                         {"id", m.id},
                         {"name", m.name},
                         {"library", lib_path.string()},
                         {"youngs_modulus_pa", m.youngs_modulus_pa},
                         {"damping_time_s", m.damping_time_s},
                         {"density_g_per_mm3", m.density_g_per_mm3},
                         {"sources", sources}});
  }
  if (!options.backend.empty()) {
    if (options.backend == "cpu")
      scene.solver.backend = crms::Backend::kCpu;
    else if (options.backend == "cuda")
      scene.solver.backend = crms::Backend::kCuda;
    else if (options.backend == "auto")
      scene.solver.backend = crms::Backend::kAuto;
    else
      throw Error("--backend: expected cpu, cuda or auto, got '" + options.backend + "'");
  }
  for (std::size_t i = 0; i < scene.instances.size(); ++i)
    crms::validate_solver_config(scene_for_instance(scene, i).solver);
  stages.push_back({"read scene", clock.seconds(), scene.file.string()});

  // import → segment (one job: tsf import's reader, then the preset's stages).
  json segmentation = nullptr;
  if (spec.present) {
    for (const SceneInstance& inst : scene.instances)
      if (inst.lattice.source != SceneLattice::Source::kVolume)
        throw Error(options.scene.string() + ": " +
                    (scene.multi_instance ? "tissues[" + inst.name + "]." : std::string()) +
                    "lattice.source: a scene with a pipeline section builds its lattice from the "
                    "segmented CT: expected source: volume");
#ifdef TSF_HAVE_SEGMENT
    if (!fs::exists(spec.ct))
      throw Error(options.scene.string() + ": pipeline.source.ct: '" + spec.ct.string() +
                  "' does not exist");
    clock.restart();
    segment::SegmentJob job;
    job.input = spec.ct;
    job.preset = segment::load_segment_preset(spec.preset);
    const double voxel = options.voxel_mm ? *options.voxel_mm : spec.voxel_mm;
    if (voxel > 0) {
      job.preset.resample.voxel_mm = voxel;
      job.overrides.push_back("resample.voxel_mm=" + std::to_string(voxel));
    }
    if (spec.smoothing_mm >= 0) {
      job.preset.smoothing.sigma_mm = spec.smoothing_mm;
      job.overrides.push_back("smoothing.sigma_mm=" + std::to_string(spec.smoothing_mm));
    }
    job.preset.validate();
    job.output_prefix = folder / scene.name;
    job.show_progress = !options.quiet;
    const segment::SegmentJobResult seg = segment::run_segment_job(job);
    const double segment_wall = clock.seconds();
    segmentation = seg.report;
    const double read_s = seg.report["input"].value("read_seconds", 0.0);
    const double write_s = seg.report["outputs"].value("write_seconds", 0.0);
    stages.push_back({"import (read CT)", read_s, spec.ct.filename().string()});
    stages.push_back(
        {"segment (preset " + job.preset.name + ")", std::max(0.0, segment_wall - read_s - write_s),
         std::to_string(seg.report["grid"].value("voxel_mm", 0.0)).substr(0, 5) + " mm voxels"});
    stages.push_back({"write segmented volumes", write_s,
                      seg.volume_paths.density.filename().string() + ", labels, weights"});
    scene.lattice.volume = seg.volume_paths.density;
    for (SceneInstance& inst : scene.instances) inst.lattice.volume = seg.volume_paths.density;
#else
    throw Error(options.scene.string() +
                ": pipeline: import and segmentation need a build with ITK "
                "(reconfigure with -DTSF_WITH_ITK=ON)");
#endif
  }

  // surface → lattice → scripted interaction (the interaction runner), energy every N frames.
  InteractionRunOptions run;
  run.duration_s = options.duration_s;
  run.quiet = options.quiet;
  run.report = folder / "interaction.json";
  if (spec.meshes || !spec.present) {
    run.mesh = folder / (scene.name + "-final.ply");
    scene.outputs.rest_mesh = folder / (scene.name + "-rest.ply");
  } else {
    scene.outputs.rest_mesh.clear();
  }
  scene.outputs.report.clear();
  const std::size_t instance_count = scene.instances.size();
  std::vector<json> energy(instance_count, json::array());
  std::vector<std::int64_t> frames_seen(instance_count, 0), alive_nodes(instance_count, 0);
  run.on_frame = [&](double time_s, std::size_t i, const interaction::TissueModel& model) {
    if (frames_seen[i]++ == 0) alive_nodes[i] = model.alive_nodes();
    if ((frames_seen[i] - 1) % spec.energy_every != 0) return;
    const crms::EnergyReport e = model.solver().energy();
    energy[i].push_back({{"time_s", time_s},
                         {"kinetic_nj", e.kinetic_nj},
                         {"elastic_nj", e.elastic_nj},
                         {"gravitational_nj", e.gravitational_nj},
                         {"total_nj", e.total_nj()}});
  };
  // After the script: what the effects cost on each instance's final lattice (effect_cost.h).
  double cost_s = 0;
  run.extra_key = "effect_cost";
  run.after_script = [&](std::size_t i, interaction::TissueModel& model) {
    Stopwatch cost_clock;
    if (!options.quiet)
      std::printf("tsf run: measuring the effects' step cost on %s's lattice\n",
                  scene.instances[i].name.c_str());
    json cost = measure_effect_cost(model.solver(), model.dt(), EffectCostOptions{});
    cost_s += cost_clock.seconds();
    return cost;
  };
  clock.restart();
  json interaction;
  std::string failure;
  try {
    interaction = run_interaction_scene(scene, run);
  } catch (const Error& e) {
    failure = e.what();  // unstable: the report still says what happened up to there
    if (fs::exists(run.report)) {
      std::ifstream in(run.report);
      interaction = json::parse(in, nullptr, false);
    }
    if (interaction.is_discarded() || interaction.is_null()) throw;
  }
  const double interaction_wall = clock.seconds();
  const json& timings = interaction["timings_s"];
  // One report per instance (a single-instance scene's report is the instance's).
  const json instance_reports =
      interaction.contains("instances") ? interaction["instances"] : json::array({interaction});
  double setup_total = 0;
  for (std::size_t i = 0; i < instance_reports.size(); ++i) {
    const json& ir = instance_reports[i];
    const double setup_s = ir["timings_s"].value("setup", 0.0);
    setup_total += setup_s;
    stages.push_back(
        {"surface + lattice + coupler" +
             (scene.multi_instance ? " (" + ir.value("instance", "") + ")" : std::string()),
         setup_s,
         std::to_string(ir["lattice"].value("alive_nodes_start", 0)) + " nodes at " +
             std::to_string(ir["lattice"]["spacing_mm"][0].get<double>()).substr(0, 4) + " mm, " +
             std::to_string(ir["surface"].value("triangles_start", 0)) + " triangles"});
  }
  stages.push_back(
      {"scripted interaction", timings.value("script", 0.0),
       std::to_string(interaction.value("frames", 0)) + " frames, " +
           std::to_string(interaction.value("steps", 0)) + " steps" +
           (scene.multi_instance ? " over " + std::to_string(instance_count) + " instances"
                                 : std::string())});
  stages.push_back({"effect cost measurement", cost_s,
                    "step time with the scene's effects vs all off, interleaved"});
  stages.push_back(
      {"write meshes",
       std::max(0.0, interaction_wall - setup_total - timings.value("script", 0.0) - cost_s),
       run.mesh.empty() ? "none" : run.mesh.filename().string()});

  // Export formats (glTF binary) of the final surface when the export module is built.
  json exported = json::array();
#ifdef TSF_HAVE_EXPORT
  clock.restart();
  for (std::size_t i = 0; i < instance_reports.size(); ++i) {
    const fs::path mesh = instance_output_path(run.mesh, scene, i);
    if (mesh.empty() || !fs::exists(mesh)) continue;
    // The surface is in the tissue space of the (uncropped) volume: its geometry maps it to the
    // patient frame. Box scenes have an axis-aligned volume at the origin.
    VolumeGeometry geometry;
    if (scene.instances[i].lattice.source == SceneLattice::Source::kVolume) {
      geometry = import::read_tissue_volume(scene.instances[i].lattice.volume).geometry();
    } else {
      const json& v = instance_reports[i]["volume"];
      for (int a = 0; a < 3; ++a) {
        geometry.dims[a] = v["dims"][a].get<int>();
        geometry.spacing[a] = v["spacing_mm"][a].get<double>();
        geometry.origin[a] = v["origin_mm"][a].get<double>();
      }
    }
    exporter::ExportOptions eo;
    eo.format = exporter::ExportFormat::glb;
    eo.name = scene.multi_instance ? scene.name + "-" + scene.instances[i].name : scene.name;
    eo.source = "tsf run " + scene.file.string();
    const fs::path glb = mesh.parent_path() / (mesh.stem().string() + ".glb");
    const exporter::ExportReport er =
        exporter::export_surface(imt::read_surface_ply(mesh), geometry, glb, eo);
    for (const auto& f : er.files) exported.push_back(f.path.filename().string());
  }
  if (!exported.empty()) stages.push_back({"export (glTF)", clock.seconds(), exported.dump()});
#endif
  // Per instance: material, effects, nodes, rates, energy, effect cost. Scene-wide energy is the
  // sum over instances frame by frame (every instance advances every frame).
  json instances = json::array();
  std::set<std::string> effects_union;
  double node_steps = 0;
  for (std::size_t i = 0; i < instance_reports.size(); ++i) {
    const json& ir = instance_reports[i];
    const double st = ir["timings_s"].value("stepping", 0.0);
    const double n_steps = ir.value("steps", 0.0);
    node_steps += n_steps * double(alive_nodes[i]);
    for (const auto& e : ir.value("effects_active", json::array()))
      effects_union.insert(e.get<std::string>());
    instances.push_back({{"name", scene.instances[i].name},
                         {"material", materials[i]},
                         {"effects_active", ir.value("effects_active", json::array())},
                         {"kernel_features", ir.value("kernel_features", json::array())},
                         {"bytes_per_node", ir.value("bytes_per_node", 0.0)},
                         {"labels", ir["lattice"].value("labels", json::array())},
                         {"lattice_spacing_mm", ir["lattice"]["spacing_mm"]},
                         {"alive_nodes_start", ir["lattice"].value("alive_nodes_start", 0)},
                         {"alive_nodes_end", ir["lattice"].value("alive_nodes_end", 0)},
                         {"fixed_nodes", ir["lattice"].value("fixed_nodes", 0)},
                         {"integrator", ir.value("integrator", "")},
                         {"dt_s", ir.value("dt_s", 0.0)},
                         {"steps", n_steps},
                         {"timings_s", ir["timings_s"]},
                         {"steps_per_s", st > 0 ? n_steps / st : 0.0},
                         {"node_steps_per_s", st > 0 ? n_steps * double(alive_nodes[i]) / st : 0.0},
                         {"surface", ir["surface"]},
                         {"totals", ir["totals"]},
                         {"outputs", ir["outputs"]},
                         {"effect_cost", ir.value("effect_cost", json(nullptr))},
                         {"energy", energy[i]}});
  }
  json energy_total = energy[0];
  for (std::size_t i = 1; i < energy.size(); ++i)
    for (std::size_t k = 0; k < energy_total.size() && k < energy[i].size(); ++k)
      for (const char* key : {"kinetic_nj", "elastic_nj", "gravitational_nj", "total_nj"})
        energy_total[k][key] = energy_total[k][key].get<double>() + energy[i][k][key].get<double>();
  const double stepping = timings.value("stepping", 0.0);
  const double steps = interaction.value("steps", 0.0);
  const double simulated = interaction.value("simulated_s", 0.0);
  json report = {
      {"tsf_version", TSF_VERSION_STRING},
      {"scene", {{"name", scene.name}, {"file", scene.file.string()}}},
      {"output_folder", folder.string()},
      {"material", materials[0]},
      {"backend", interaction.value("backend", "")},
      {"effects_active", json(effects_union)},
      {"effects_note",
       "effects the solver ran (crms::Solver::active_effects(), the scene's effects: section); "
       "an effect that is off launches no pass and allocates no array. effect_cost per instance: "
       "step time on the final lattice with the scene's effects vs all off, interleaved"},
      {"instances", instances},
      {"stages", stages_json(stages)},
      {"rates",
       {{"steps", steps},
        {"dt_s", interaction.value("dt_s", 0.0)},
        {"simulated_s", simulated},
        {"stepping_s", stepping},
        {"steps_per_s", stepping > 0 ? steps / stepping : 0.0},
        {"node_steps_per_s", stepping > 0 ? node_steps / stepping : 0.0},
        {"real_time_factor",
         timings.value("script", 0.0) > 0 ? simulated / timings.value("script", 0.0) : 0.0}}},
      {"segmentation", segmentation},
      {"interaction", interaction},
      {"energy", energy_total},
      {"exported", exported},
      {"failure", failure.empty() ? json(nullptr) : json(failure)},
  };
  report["total_seconds"] = total_clock.seconds();
  write_text_atomically(folder / "run-report.json", report.dump(2) + "\n");
  if (spec.report || !spec.present) {
    const fs::path md = write_run_report(report, folder, spec.plots);
    if (!options.quiet) std::printf("tsf run: report %s\n", md.string().c_str());
  }
  if (!failure.empty()) throw Error(failure);
  return report;
}

}  // namespace tsf::app
