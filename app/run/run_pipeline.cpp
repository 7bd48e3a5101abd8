// `tsf run`: the pipeline of run_pipeline.h, as named stages that pass typed results:
//   prepare_run        read the scene, check its keys for `tsf run`, backend, the CT's series and
//                      geometry against the crops and tools (headers only), output folder
//   segment_stage      import → segment (when the scene has a pipeline section)
//   interaction_stage  the scene session: surface, lattice, coupler, the script (energy per frame,
//                      effect cost after it)
//   export_stage       GLB of each final surface, from the run's own meshes
//   assemble_report    the JSON report (the edge: JSON is made here only), then run-report.md
#include "run/run_pipeline.h"

#include <algorithm>
#include <cmath>
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
#include "scene/anatomy_placement.h"
#include "scene/interaction_run.h"
#include "scene/scene.h"
#include "scene/scene_session.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/version.h"
#ifdef TSF_HAVE_EXPORT
#include "tsf/export/mesh_export.h"
#endif
#ifdef TSF_HAVE_IMPORT
#include "tsf/import/ct_geometry.h"
#include "tsf/import/volume_file_reader.h"
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
  /// Said before and while the run worked: the CT check's ("scene: ...") and the import's
  /// ("import: ...", from segment's report). run-report.json `warnings`, run-report.md "Warnings".
  std::vector<std::string> warnings;
  json ct = nullptr;  ///< the CT's geometry as checked before segmenting (null without pipeline)
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

#ifdef TSF_HAVE_IMPORT
std::string point_text(const Vec3d& p) {
  return "(" + fixed(p.x, 1) + ", " + fixed(p.y, 1) + ", " + fixed(p.z, 1) + ")";
}

std::string box_text(const import::Box3& b) {
  return point_text(b.lo) + " to " + point_text(b.hi) + " mm";
}

/// How far a tool reaches from its pose's position (its bounding radius), mm.
double tool_reach_mm(const interaction::Tool& t) {
  switch (t.shape) {
    case collision::ToolShape::kSphere:
      return t.radius_mm;
    case collision::ToolShape::kCapsule:
      return t.radius_mm + t.half_length_mm;
    case collision::ToolShape::kMesh:
      return std::max(length(t.mesh->grid.lo()), length(t.mesh->grid.hi()));
    default:
      return length(t.half_extents_mm);
  }
}

/// Closest approach of the polyline through `points` to `box`, mm (0 when it enters the box).
double path_distance(const std::vector<Vec3d>& points, const import::Box3& box) {
  double best = 1e300;
  for (std::size_t k = 0; k < points.size(); ++k) {
    best = std::min(best, box.distance(points[k]));
    if (k == 0) continue;
    constexpr int kSamples = 64;
    for (int n = 1; n < kSamples; ++n)
      best = std::min(best, box.distance(points[k - 1] + (points[k] - points[k - 1]) *
                                                             (static_cast<double>(n) / kSamples)));
  }
  return best;
}

/// Reads the CT's geometry only (a volume file's header; the DICOM headers, no pixels), chooses
/// the series as the import will, and checks every instance's crop box against the volume and
/// every tool path against the tissue, before anything is segmented. Fails on a crop that misses
/// the volume (printing both); a tool path that never comes near the tissue is a warning.
void check_ct_before_segmenting(RunContext& ctx, const std::string& ct_key,
                                const std::string& series_key) {
  Stopwatch clock;
  const Scene& scene = ctx.scene;
  const RunSpec& spec = scene.pipeline;
  import::ImportOptions io;
  io.series_uid = spec.series;
  import::CtGeometry g;
  std::string modality = "CT";
  std::error_code ec;
  if (fs::is_regular_file(spec.ct, ec) && import::is_volume_file_path(spec.ct)) {
    if (!spec.series.empty())
      throw Error(series_key + ": a series UID (" + spec.series + ") was given but '" +
                  spec.ct.string() + "' is a volume file, not a DICOM folder");
    g = import::volume_file_geometry(spec.ct, io.max_voxels);
  } else {
    import::CatalogOptions copt;
    copt.show_progress = !ctx.options.quiet;
    const import::DicomCatalog catalog = import::catalog_dicom(spec.ct, copt);
    const auto usable = catalog.usable_series();
    if (spec.series.empty() && usable.size() > 1) {
      std::string list;
      for (const import::DicomSeries* u : usable) list += "\n  " + import::one_line_summary(*u);
      throw Error(ct_key + ": '" + spec.ct.string() + "' holds " + std::to_string(usable.size()) +
                  " usable DICOM series; choose one with `--series UID` on tsf run, or with "
                  "`pipeline.source.series: UID` in the scene (`tsf info " +
                  spec.ct.string() + "` describes each):" + list);
    }
    try {
      const import::DicomSeries& chosen = import::select_dicom_series(catalog, io);
      g = import::dicom_series_geometry(chosen);
      modality = chosen.modality;
    } catch (const Error& e) {
      throw Error((spec.series.empty() ? ct_key : series_key) + ": " + e.what());
    }
    if (modality != "CT")
      throw Error(ct_key + ": series " + g.series_instance_uid + " has modality " +
                  (modality.empty() ? std::string("(none)") : modality) +
                  ": tsf run segments CT (Hounsfield units); choose a CT series (`tsf info " +
                  spec.ct.string() + "`)");
  }
  const import::Box3 patient = import::patient_extent(g);
  const import::Box3 tissue = import::tissue_extent(g);
  const bool identity = import::identity_direction(g.direction);
  const std::string frames_note =
      identity ? std::string()
               : "; in tissue space (origin + index × spacing, the frame scenes' crops and tools "
                 "use for this volume, whose axes are not the patient axes) " +
                     box_text(tissue);

  // Every crop must hold part of the volume; the tissue the tools act on is each instance's crop
  // within the volume (the whole volume without a crop).
  std::vector<import::Box3> tissue_boxes;
  for (std::size_t i = 0; i < scene.instances.size(); ++i) {
    const SceneLattice& sl = scene.instances[i].lattice;
    if (!sl.cropped) {
      tissue_boxes.push_back(tissue);
      continue;
    }
    const import::Box3 crop{sl.crop_min_mm, sl.crop_max_mm};
    if (!crop.intersects(tissue))
      throw Error(scene.instance_prefix(i) + "lattice.crop: the box " + box_text(crop) +
                  " misses the CT '" + spec.ct.string() + "'" +
                  (g.series_instance_uid.empty() ? "" : " (series " + g.series_instance_uid + ")") +
                  ", whose voxel centres span " + box_text(patient) +
                  " in patient coordinates (LPS)" + frames_note +
                  ". Scenes place crops, anchors and tools in millimetres of the scan they were "
                  "written for: move lattice.crop (and the anchors and tool paths) onto this CT "
                  "(docs/patients.md). Nothing was segmented.");
    import::Box3 inside = crop;
    for (int a = 0; a < 3; ++a) {
      inside.lo[a] = std::max(crop.lo[a], tissue.lo[a]);
      inside.hi[a] = std::min(crop.hi[a], tissue.hi[a]);
    }
    tissue_boxes.push_back(inside);
  }

  // Tool paths: a trajectory or a stroke that never comes near the tissue touches nothing.
  constexpr double kNearMm = 5.0;  // beyond the tool's own reach
  constexpr double kFarMm = 50.0;  // keyframes this far outside the volume are suspicious
  auto check_path = [&](const std::string& what, const std::string& tool_name,
                        const std::vector<Vec3d>& points) {
    const SceneTool* tool = scene.find_tool(tool_name);
    const double reach = (tool ? tool_reach_mm(tool->tool) : 0.0) + kNearMm;
    double nearest = 1e300;
    for (const import::Box3& b : tissue_boxes)
      nearest = std::min(nearest, path_distance(points, b));
    if (nearest > reach) {
      ctx.warnings.push_back(
          "scene: " + what + " never comes near the tissue: its closest approach is " +
          fixed(nearest, 1) + " mm from the tissue box" + (tissue_boxes.size() > 1 ? "es" : "") +
          " (" + box_text(tissue_boxes.front()) + (tissue_boxes.size() > 1 ? ", ..." : "") +
          "), beyond the tool's reach of " + fixed(reach, 1) +
          " mm: it will touch nothing on this CT");
      return;
    }
    std::size_t far = 0;
    Vec3d first_far;
    for (const Vec3d& p : points)
      if (tissue.distance(p) > kFarMm && far++ == 0) first_far = p;
    if (far > 0)
      ctx.warnings.push_back(
          "scene: " + what + ": " + std::to_string(far) + " of " + std::to_string(points.size()) +
          " positions lie more than " + fixed(kFarMm, 0) + " mm outside the CT's volume (first " +
          point_text(first_far) + " mm; the volume spans " + box_text(tissue) + ")");
  };
  // Paths placed by the anatomy are known only after segmentation (anatomy_placement.h).
  for (const SceneTrajectory& t : scene.script.trajectories) {
    bool by_anatomy = false;
    for (const AnatomyPosition& p : t.anatomy) by_anatomy = by_anatomy || p.given();
    if (by_anatomy) continue;
    std::vector<Vec3d> points;
    for (const interaction::Keyframe& k : t.keyframes) points.push_back(k.pose.position);
    check_path("the trajectory of tool '" + t.tool + "'", t.tool, points);
  }
  for (const SceneEvent& e : scene.script.events)
    if (!e.from_anatomy.given() && !e.to_anatomy.given())
      check_path("the stroke of tool '" + e.tool + "' at " + fixed(e.time_s, 3) + " s", e.tool,
                 {e.from.position, e.to.position});

  auto v3 = [](const Vec3d& v) { return json::array({v.x, v.y, v.z}); };
  auto box_json = [&](const import::Box3& b) { return json{{"min", v3(b.lo)}, {"max", v3(b.hi)}}; };
  ctx.ct = {{"path", absolute_path(spec.ct).string()},
            {"kind", g.kind},
            {"series_instance_uid", g.series_instance_uid},
            {"dims", {g.dims.x, g.dims.y, g.dims.z}},
            {"spacing_mm", v3(g.spacing)},
            {"origin_mm", v3(g.origin)},
            {"direction", g.direction},
            {"orientation",
             g.orientation_recorded ? json(import::orientation_code(g.direction)) : json(nullptr)},
            {"orientation_recorded", g.orientation_recorded},
            {"extent_lps_mm", box_json(patient)},
            {"extent_tissue_mm", box_json(tissue)},
            {"check_seconds", clock.seconds()}};
  // Warnings go to stderr even with --quiet (which silences progress and the summary).
  for (const std::string& w : ctx.warnings)
    std::fprintf(stderr, "tsf run: warning: %s\n", w.c_str());
  ctx.stages.push_back({"check the CT against the scene (headers only)", clock.seconds(),
                        std::to_string(g.dims.x) + "×" + std::to_string(g.dims.y) + "×" +
                            std::to_string(g.dims.z) + " voxels, extent " + box_text(patient) +
                            " (LPS)"});
}
#endif

RunContext prepare_run(const RunOptions& options) {
  Stopwatch clock;
  RunContext ctx{options, read_scene(options.scene), {}, {}, {}, nullptr};
  Scene& scene = ctx.scene;
  check_scene_for_command(scene, SceneCommand::kRun);
  override_backend(scene, options.backend);
  // CUDA asked for where it cannot run is known now, before minutes of segmentation.
  bool explicit_instance = false;
  for (const SceneInstance& inst : scene.instances)
    explicit_instance |= inst.integration.integrator != crms::Integrator::kImplicitEuler;
  if (scene.solver.backend == crms::Backend::kCuda && explicit_instance && !cuda_status().available)
    throw Error(scene.file.string() + ": " +
                (options.backend.empty() ? "solver.backend" : "--backend") +
                ": cuda was asked for, but CUDA is not usable here (" + cuda_status().reason +
                "); use cpu or auto. Nothing was segmented");
  // --ct / --series: another patient's CT for this run, through the same scene.
  std::string ct_key = scene.file.string() + ": pipeline.source.ct";
  std::string series_key = scene.file.string() + ": pipeline.source.series";
  if (!options.ct.empty() || !options.series.empty()) {
    if (!scene.pipeline.present)
      throw Error(scene.file.string() + ": " + (options.ct.empty() ? "--series" : "--ct") +
                  " replaces pipeline.source, but the scene has no pipeline section (it builds "
                  "its tissue from lattice.volume; docs/scenes.md)");
    if (!options.ct.empty()) {
      scene.pipeline.ct = options.ct;
      scene.pipeline.series.clear();  // the scene's series belongs to the scene's CT
      ct_key = "--ct";
    }
    if (!options.series.empty()) {
      scene.pipeline.series = options.series;
      series_key = "--series";
    }
  }
  if (scene.pipeline.present) {
    for (std::size_t i = 0; i < scene.instances.size(); ++i)
      if (scene.instances[i].lattice.source != SceneLattice::Source::kVolume)
        throw Error(scene.instance_prefix(i) +
                    "lattice.source: a scene with a pipeline section builds its lattice from the "
                    "segmented CT: expected source: volume");
    if (!fs::exists(scene.pipeline.ct))
      throw Error(ct_key + ": '" + scene.pipeline.ct.string() + "' does not exist");
#ifdef TSF_HAVE_IMPORT
    ctx.stages.push_back(
        {"read and check the scene", clock.seconds(), absolute_path(scene.file).string()});
    check_ct_before_segmenting(ctx, ct_key, series_key);
    clock.restart();
#endif
  }
  // Output folder: command line, then the scene (inside the working folder), then
  // out/<scene name> here.
  if (options.output_folder.empty() && !scene.pipeline.folder.empty())
    check_scene_output_folder(scene.pipeline.folder, "pipeline.outputs.folder", scene.file);
  const fs::path folder = !options.output_folder.empty()   ? options.output_folder
                          : !scene.pipeline.folder.empty() ? scene.pipeline.folder
                                                           : fs::path("out") / scene.name;
  ctx.folder = OutputFolder::prepare(folder, options.force,
                                     options.output_folder.empty() ? "output folder" : "--output");
  if (ctx.stages.empty())
    ctx.stages.push_back(
        {"read and check the scene", clock.seconds(), absolute_path(scene.file).string()});
  else
    ctx.stages.push_back(
        {"prepare the output folder", clock.seconds(), ctx.folder.path().string()});
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
  job.series_uid = spec.series;
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
  for (const json& w : seg.report.value("warnings", json::array())) {
    ctx.warnings.push_back("import: " + w.get<std::string>());
    std::fprintf(stderr, "tsf run: warning: import: %s\n", w.get<std::string>().c_str());
  }
  const double read_s = seg.report["input"].value("read_seconds", 0.0);
  const double write_s = seg.report["outputs"].value("write_seconds", 0.0);
  ctx.stages.push_back({"import (read CT)", read_s,
                        absolute_path(spec.ct).string() +
                            (spec.series.empty() ? "" : " (series " + spec.series + ")")});
  ctx.stages.push_back({"segment (preset " + job.preset.name + ")",
                        std::max(0.0, wall - read_s - write_s),
                        fixed(seg.report["grid"].value("voxel_mm", 0.0), 2) + " mm voxels"});
  ctx.stages.push_back({"write segmented volumes", write_s,
                        seg.volume_paths.density.filename().string() + ", labels, weights"});
  for (SceneInstance& inst : ctx.scene.instances) inst.lattice.volume = seg.volume_paths.density;
  if (!ctx.scene.anatomy_key.empty()) {
    // Crops, anchors and tool positions given relative to the anatomy the segmentation found.
    clock.restart();
    for (const std::string& w : place_scene_by_anatomy(ctx.scene, seg.report)) {
      ctx.warnings.push_back(w);
      std::fprintf(stderr, "tsf run: warning: %s\n", w.c_str());
    }
    std::string crops;
    for (const SceneInstance& inst : ctx.scene.instances)
      if (inst.lattice.crop_by_anatomy())
        crops += (crops.empty() ? "crop " : ", ") +
                 box_text({inst.lattice.crop_min_mm, inst.lattice.crop_max_mm}) + " (" +
                 (inst.lattice.crop_region.empty() ? "around " + inst.lattice.crop_center.landmark
                                                   : inst.lattice.crop_region) +
                 ")";
    ctx.stages.push_back({"place the scene by anatomy", clock.seconds(),
                          crops.empty() ? std::string("anchors and tool positions") : crops});
  }
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
  if (ctx.options.states_every) {
    if (o.states.empty()) o.states = ctx.folder.file("states.tsfmesh");
    o.states_every = *ctx.options.states_every;
  }
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

// ---- export: GLB of each final surface (and of the saved states) in the patient frame -------

std::vector<fs::path> export_stage(RunContext& ctx, const InteractionResult& result) {
  std::vector<fs::path> files;
#ifdef TSF_HAVE_EXPORT
  Stopwatch clock;
  for (const InstanceResult& r : result.instances) {
    exporter::ExportOptions eo;
    eo.format = exporter::ExportFormat::glb;
    eo.name = ctx.scene.multi_instance ? ctx.scene.name + "-" + r.name : ctx.scene.name;
    eo.source = "tsf run " + absolute_path(ctx.scene.file).string();
    if (!ctx.ct.is_null() && !ctx.ct.value("orientation_recorded", true))
      eo.frame_warning = kLeftRightUnknown;
    if (!r.outputs.mesh.empty()) {
      const fs::path glb = r.outputs.mesh.parent_path() / (r.outputs.mesh.stem().string() + ".glb");
      const exporter::ExportReport er =
          exporter::export_surface(r.final_mesh, r.patient_frame, glb, eo);
      for (const auto& f : er.files) files.push_back(absolute_path(f.path));
    }
    // Saved states: one animated GLB that plays them, cuts included (no numbered files).
    if (!r.outputs.states.empty() && fs::exists(r.outputs.states)) {
      const io::MeshSequence states = io::read_mesh_sequence(r.outputs.states);
      if (!states.frames.empty()) {
        const fs::path glb =
            r.outputs.states.parent_path() / (r.outputs.states.stem().string() + ".glb");
        // Slow motion: the whole run plays in 10 s of animation (the scale is in the file).
        exporter::ExportOptions ao = eo;
        ao.numbered_files = false;
        const double span = states.frames.back().time_s - states.rest_time_s;
        ao.time_scale = span > 0.0 ? std::max(1.0, 10.0 / span) : 1.0;
        const exporter::ExportReport er =
            exporter::export_sequence(states, exporter::FrameSelection::parse("all"), glb, ao);
        for (const auto& f : er.files) files.push_back(absolute_path(f.path));
      }
    }
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
          {"poisson_ratio", m.poisson_ratio},
          {"poisson_ratio_source", m.poisson_ratio_source},
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
  const InstanceResult* worst = r.least_stable();
  if (worst && worst->stability.verdict == crms::StabilityVerdict::kUnstable)
    return {"unstable", (r.instances.size() > 1 ? worst->name + ": " : std::string()) +
                            worst->stability.headline()};
  return {"completed", "every frame of the script was played"};
}

/// An unstable verdict the scene allows (stability.allow_unstable) is reported but not a failure;
/// a halted solver (NaN guard) always is.
bool failed(const InteractionResult& r, const std::string& verdict_word) {
  if (verdict_word == "completed") return false;
  const InstanceResult* worst = r.least_stable();
  return verdict_word != "unstable" || r.instability || !worst || !worst->stability.allowed;
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
    instances.push_back(
        {{"name", r.name},
         {"material", material_json(scene, scene.instances[r.index])},
         {"poisson_ratio", ir["session"].value("poisson_ratio", json(nullptr))},
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
         {"removal", ir["session"]["removal"]},
         {"lattice_pieces", {{"start", r.components_start}, {"end", r.components_end}}},
         {"exposures", ir["exposures"]},
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
      {"stability", interaction.value("stability", json(nullptr))},
      {"warnings", ctx.warnings},
      {"ct", ctx.ct},
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
       failed(result, verdict_word) ? json(verdict_word + ": " + verdict_reason) : json(nullptr)},
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
    write_text_atomically(
        ctx.folder.file("run-report.json"),
        json{
            {"tsf_version", TSF_VERSION_STRING},
            {"scene", {{"name", ctx.scene.name}, {"file", absolute_path(ctx.scene.file).string()}}},
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
