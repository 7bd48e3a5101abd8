// `tsf run`: the pipeline of run_pipeline.h.
#include "run/run_pipeline.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <vector>

#include "run/material_library.h"
#include "run/repo_paths.h"
#include "run/run_report.h"
#include "run/run_spec.h"
#include "scene/interaction_run.h"
#include "scene/scene.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/crms/effects.h"
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

json feature_list(unsigned features) {
  namespace ft = crms::features;
  json list = json::array();
  if (features & ft::kSymmetricReactions) list.push_back("symmetric angular reactions");
  if (features & ft::kCosineAngular) list.push_back("cosine angular form");
  if (features & ft::kExternalForces) list.push_back("external forces");
  if (features & ft::kHeterogeneous) list.push_back("per-node materials");
  return list;
}

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

  // Material from the library.
  json material_json = nullptr;
  if (!spec.material.empty()) {
    const fs::path lib_path =
        spec.material_library.empty() ? default_material_library_path() : spec.material_library;
    const MaterialLibrary lib = read_material_library(lib_path);
    const LibraryMaterial* m = lib.find(spec.material);
    if (!m) {
      std::string known;
      for (const auto& k : lib.materials) known += (known.empty() ? "" : ", ") + k.id;
      throw Error(options.scene.string() + ": pipeline.material: no material '" + spec.material +
                  "' in " + lib_path.string() + " (known: " + known + ")");
    }
    scene.solver.materials.at(0) = m->crms_material();
    json sources = json::array();
    for (const auto& s : m->sources) sources.push_back(s.citation);
    material_json = {{"id", m->id},
                     {"name", m->name},
                     {"library", lib_path.string()},
                     {"youngs_modulus_pa", m->youngs_modulus_pa},
                     {"damping_time_s", m->damping_time_s},
                     {"density_g_per_mm3", m->density_g_per_mm3},
                     {"sources", sources}};
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
  crms::validate_solver_config(scene.solver);
  stages.push_back({"read scene", clock.seconds(), scene.file.string()});

  // import → segment (one job: tsf import's reader, then the preset's stages).
  json segmentation = nullptr;
  if (spec.present) {
    if (scene.lattice.source != SceneLattice::Source::kVolume)
      throw Error(options.scene.string() +
                  ": lattice.source: a scene with a pipeline section builds its lattice from the "
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
  json energy = json::array();
  std::int64_t frame = 0;
  unsigned features = 0;
  std::int64_t alive_nodes = 0;
  run.on_frame = [&](double time_s, const interaction::TissueModel& model) {
    if (frame++ == 0) {
      features = model.solver().features();
      alive_nodes = model.alive_nodes();
    }
    if ((frame - 1) % spec.energy_every != 0) return;
    const crms::EnergyReport e = model.solver().energy();
    energy.push_back({{"time_s", time_s},
                      {"kinetic_nj", e.kinetic_nj},
                      {"elastic_nj", e.elastic_nj},
                      {"gravitational_nj", e.gravitational_nj},
                      {"total_nj", e.total_nj()}});
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
  const double setup_s = timings.value("setup", 0.0);
  stages.push_back(
      {"surface + lattice + coupler", setup_s,
       std::to_string(interaction["lattice"].value("alive_nodes_start", 0)) + " nodes, " +
           std::to_string(interaction["surface"].value("triangles_start", 0)) + " triangles"});
  stages.push_back({"scripted interaction", timings.value("script", 0.0),
                    std::to_string(interaction.value("frames", 0)) + " frames, " +
                        std::to_string(interaction.value("steps", 0)) + " steps"});
  stages.push_back({"write meshes",
                    std::max(0.0, interaction_wall - setup_s - timings.value("script", 0.0)),
                    run.mesh.empty() ? "none" : run.mesh.filename().string()});

  // Export formats (glTF binary) of the final surface when the export module is built.
  json exported = json::array();
#ifdef TSF_HAVE_EXPORT
  if (!run.mesh.empty() && fs::exists(run.mesh)) {
    clock.restart();
    // The surface is in the tissue space of the (uncropped) volume: its geometry maps it to the
    // patient frame. Box scenes have an axis-aligned volume at the origin.
    VolumeGeometry geometry;
    if (scene.lattice.source == SceneLattice::Source::kVolume) {
      geometry = import::read_tissue_volume(scene.lattice.volume).geometry();
    } else {
      const json& v = interaction["volume"];
      for (int a = 0; a < 3; ++a) {
        geometry.dims[a] = v["dims"][a].get<int>();
        geometry.spacing[a] = v["spacing_mm"][a].get<double>();
        geometry.origin[a] = v["origin_mm"][a].get<double>();
      }
    }
    exporter::ExportOptions eo;
    eo.format = exporter::ExportFormat::glb;
    eo.name = scene.name;
    eo.source = "tsf run " + scene.file.string();
    const fs::path glb = folder / (scene.name + "-final.glb");
    const exporter::ExportReport er =
        exporter::export_surface(imt::read_surface_ply(run.mesh), geometry, glb, eo);
    for (const auto& f : er.files) exported.push_back(f.path.filename().string());
    stages.push_back({"export (glTF)", clock.seconds(), glb.filename().string()});
  }
#endif
  const double stepping = timings.value("stepping", 0.0);
  const double steps = interaction.value("steps", 0.0);
  const double simulated = interaction.value("simulated_s", 0.0);
  json report = {
      {"tsf_version", TSF_VERSION_STRING},
      {"scene", {{"name", scene.name}, {"file", scene.file.string()}}},
      {"output_folder", folder.string()},
      {"material", material_json},
      {"backend", interaction.value("backend", "")},
      {"effects_active", feature_list(features)},
      {"effects_note",
       "kernel features compiled into this run's step (crms/effects.h); a feature that is off is "
       "not in the kernel and costs nothing"},
      {"stages", stages_json(stages)},
      {"rates",
       {{"steps", steps},
        {"dt_s", interaction.value("dt_s", 0.0)},
        {"simulated_s", simulated},
        {"stepping_s", stepping},
        {"steps_per_s", stepping > 0 ? steps / stepping : 0.0},
        {"node_steps_per_s", stepping > 0 ? steps * double(alive_nodes) / stepping : 0.0},
        {"real_time_factor",
         timings.value("script", 0.0) > 0 ? simulated / timings.value("script", 0.0) : 0.0}}},
      {"segmentation", segmentation},
      {"interaction", interaction},
      {"energy", energy},
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
