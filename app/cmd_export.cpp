// `tsf export`: a density volume or a saved simulation state -> glTF/GLB, OBJ, STL, PLY or FBX.
//
//   tsf export INPUT -o FILE.{glb,gltf,obj,stl,ply,fbx} [--format NAME] [--split-labels]
//              [--bodies] [--decimate N] [--max-error MM] [--manifold] [--lods N1,N2,...]
//              [--vertex-colours]
//              [--units mm|m] [--axes y-up|lps|ras] [--centre] [--frames all|last|rest|K|A:B]
//              [--time-scale X] [--iso 0.5] [--smooth N] [--stats]
//
// INPUT is a mesh sequence written by `tsf simulate` (.tsfmesh, recognised by its magic bytes)
// or a density volume (PREFIX-density.nrrd, read through tsf::import with its labels), which is
// surfaced with the IMT defaults of `tsf surface` first. What the options mean: export/ headers
// (mesh_export.h, export_format.h, output_frame.h) and docs/export.md.
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.h"
#include "scene/anatomy_placement.h"
#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/common/stopwatch.h"
#include "tsf/export/export_format.h"
#include "tsf/export/frame_selection.h"
#include "tsf/export/mesh_export.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/imt/mesh_smoothing.h"
#include "tsf/io/mesh_sequence.h"

#ifdef TSF_HAVE_IMPORT
#include "tsf/import/tissue_volume_io.h"
#endif

namespace tsf::app {

namespace {

namespace fs = std::filesystem;
using namespace tsf::exporter;

struct ExportArgs {
  std::string input, output, format, units, axes, frames = "last", lods;
  bool split_labels = false, centre = false, stats = false, vertex_colours = false, bodies = false;
  bool manifold = false;
  double time_scale = 1.0;
  std::size_t decimate = 0;
  double max_error_mm = 0.0;
  float iso = 0.5f;
  int smooth = 0;
  bool frames_given = false, iso_given = false, smooth_given = false;
};

std::string formats_help() {
  std::string s = "Formats (--format NAME; else from the extension):\n";
  for (const auto& f : export_formats()) {
    char line[200];
    std::snprintf(line, sizeof(line), "  %-10s %-6s %s\n", f.name, f.extension, f.description);
    s += line;
  }
  s += "Frames: the patient frame of the CT (LPS) mapped to the file's axes: y-up = x left, "
       "y superior, z anterior (glTF, FBX, default for OBJ); lps or ras as is (default for STL, "
       "PLY). Units: glTF metres; others mm unless --units m.\n"
       "Sequences (--frames with more than one state): numbered files STEM-KKKK.EXT, and for "
       "glTF/GLB FILE itself animated: morph targets while the topology stays, one node per "
       "topology switched by STEP scale keys where a cut re-meshed the surface.\n"
       "Every mesh is cleaned (no zero-area, no duplicate triangles; counts in the summary and "
       "--stats); --decimate/--max-error/--lods report each level's distance to the full surface "
       "in mm.";
  return s;
}

std::vector<std::size_t> parse_lods(const std::string& text) {
  std::vector<std::size_t> out;
  std::size_t at = 0;
  while (at <= text.size()) {
    const std::size_t comma = text.find(',', at);
    const std::string item =
        text.substr(at, comma == std::string::npos ? std::string::npos : comma - at);
    std::size_t used = 0;
    unsigned long long value = 0;
    try {
      value = std::stoull(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size() || item[0] == '-' || value == 0)
      throw Error("--lods '" + text +
                  "': expected triangle counts separated by commas, e.g. "
                  "100000,25000,5000 (got '" +
                  item + "')");
    out.push_back(static_cast<std::size_t>(value));
    if (comma == std::string::npos) break;
    at = comma + 1;
  }
  return out;
}

ExportReport run_volume(const ExportArgs& a, const ExportOptions& options, double& surface_s) {
#ifndef TSF_HAVE_IMPORT
  (void)options;
  (void)surface_s;
  throw Error("'" + a.input +
              "' is not a mesh sequence (.tsfmesh); reading volumes needs ITK: reconfigure with "
              "-DTSF_WITH_ITK=ON");
#else
  Stopwatch clock;
  Progress progress("export " + fs::path(a.output).filename().string(), 3);
  const VoxelVolume volume = import::read_tissue_volume(a.input);
  progress.advance();
  if (a.frames_given) {
    // A volume is one state (0); other selections name states it does not have.
    (void)FrameSelection::parse(a.frames).states(1);
  }
  if (a.bodies) {
    require(!a.smooth_given,
            "--smooth smooths the IMT surface; --bodies surfaces each tissue "
            "on its own: drop one of them");
    ExportReport report = export_bodies(volume, a.iso, a.output, options);
    progress.finish();
    return report;
  }
  imt::SurfaceOptions surface;
  surface.iso = a.iso;
  surface.validate();
  imt::SurfaceMesh mesh = imt::extract_surface(volume, surface);
  if (a.smooth > 0) {
    imt::TaubinOptions smoothing;
    smoothing.iterations = a.smooth;
    smoothing.validate();
    imt::smooth_taubin(mesh, smoothing);
  }
  surface_s = clock.seconds();
  progress.advance();
  ExportReport report = export_surface(mesh, volume.geometry(), a.output, options);
  progress.finish();
  return report;
#endif
}

void run_export(const ExportArgs& a) {
  ExportOptions options;
  options.format = a.format.empty() ? format_from_path(a.output) : format_from_name(a.format);
  if (!a.units.empty()) options.units = unit_from_name(a.units);
  if (!a.axes.empty()) options.axes = axes_from_name(a.axes);
  options.split_labels = a.split_labels;
  options.vertex_colours = a.vertex_colours;
  options.centre = a.centre;
  if (a.decimate > 0 || a.max_error_mm > 0.0) {
    DecimationOptions d;
    d.target_triangles = a.decimate;
    d.max_error_mm = a.max_error_mm;
    if (a.manifold) d.manifold_runs = 3;
    options.decimation = d;
  }
  if (!a.lods.empty()) options.lods = parse_lods(a.lods);
  require(!a.manifold || options.decimation || !options.lods.empty(),
          "--manifold applies to decimation: add --decimate, --max-error or --lods");
  require(
      !(a.bodies && a.split_labels),
      "--bodies already gives one mesh per tissue; --split-labels cuts the one surface instead: "
      "pick one");
  options.time_scale = a.time_scale;
  options.source = fs::path(a.input).filename().string();
  options.frame_warning = frame_warning_beside(a.input);
  options.validate();
  require_extension_matches(a.output, options.format);
  const FrameSelection selection = FrameSelection::parse(a.frames);

  Stopwatch clock;
  double surface_s = 0.0;
  ExportReport report;
  const bool sequence = io::is_mesh_sequence_file(a.input);
  if (sequence) {
    require(!a.iso_given && !a.smooth_given, "--iso and --smooth apply to density volumes; '" +
                                                 a.input +
                                                 "' is a mesh sequence (already surfaced)");
    require(!a.bodies, "--bodies surfaces each tissue from the label volume; '" + a.input +
                           "' is a mesh sequence (surfaces only): export its density volume");
    const io::MeshSequence states = io::read_mesh_sequence(a.input);
    report = export_sequence(states, selection, a.output, options);
  } else {
    report = run_volume(a, options, surface_s);
  }
  const double total_s = clock.seconds();

  if (a.stats) {
    nlohmann::json j = export_report_json(report);
    j["input"] = a.input;
    j["input_kind"] = sequence ? "mesh sequence" : "density volume";
    j["times_s"]["surface"] = surface_s;
    j["times_s"]["total"] = total_s;
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  for (const auto& f : report.files)
    std::printf("wrote %s (%.1f kB): %s\n", f.path.string().c_str(),
                static_cast<double>(f.bytes) / 1024.0, f.content.c_str());
  for (const std::string& line : export_summary_lines(report)) std::printf("%s\n", line.c_str());
  if (report.states.size() > 1 && !report.animated)
    std::printf("no animated %s: %s\n", fs::path(a.output).filename().string().c_str(),
                report.animation_note.c_str());
}

}  // namespace

void add_export_command(CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* sub = app.add_subcommand(
      "export",
      "Write the tissue surface of a density volume or a saved simulation state (.tsfmesh) as "
      "glTF/GLB, OBJ, STL, PLY or FBX: clean triangles, normals, one coloured PBR material per "
      "tissue, optional decimation, levels of detail and closed per-tissue bodies, placed in "
      "the patient frame; every file written atomically");
  sub->footer(formats_help());
  sub->add_option("input", args->input,
                  "Mesh sequence from `tsf simulate` (.tsfmesh) or density volume "
                  "(PREFIX-density.nrrd brings PREFIX-labels.nrrd along)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("-o,--output", args->output,
                  "Output file; its extension picks the format unless --format is given")
      ->required();
  sub->add_option("--format", args->format,
                  "glb, gltf, obj, stl, stl-ascii, ply, ply-ascii, fbx, fbx-ascii");
  sub->add_flag("--split-labels", args->split_labels,
                "One node per tissue: the one surface cut into patches by label (default: one "
                "node whose meshes are the tissues)");
  sub->add_flag("--bodies", args->bodies,
                "Each tissue of the label volume as its own closed body, sharing the interface "
                "where two tissues meet (volume inputs; STL/PLY: one file STEM-TISSUE.EXT each)");
  sub->add_option("--decimate", args->decimate,
                  "Decimate to at most N triangles (meshoptimizer; tissue borders kept); the "
                  "distance to the full surface is reported in mm")
      ->check(CLI::PositiveNumber);
  sub->add_option("--max-error", args->max_error_mm,
                  "Bound the decimated surface's distance to the full surface by MM millimetres "
                  "(measured; vertices farther away are kept and decimation runs again; with "
                  "--decimate: at most N triangles within the bound)")
      ->check(CLI::PositiveNumber);
  sub->add_flag("--manifold", args->manifold,
                "Decimation: where meshoptimizer left an edge of more than two triangles, lock "
                "the spot and decimate again (up to 3 runs; slower; --bodies always does)");
  sub->add_option("--lods", args->lods,
                  "Further levels of detail, triangle counts decreasing, e.g. 100000,25000,5000 "
                  "(glTF: MSFT_lod and a scene per level; OBJ/FBX: NAME_LODk nodes; STL/PLY: "
                  "STEM-lodK files)");
  sub->add_flag("--vertex-colours", args->vertex_colours,
                "Also store the tissue colour per vertex (glTF COLOR_0, with white materials; "
                "PLY always has them)");
  sub->add_option("--units", args->units, "mm or m (default: the format's; glTF is always metres)");
  sub->add_option("--axes", args->axes,
                  "y-up (x left, y superior, z anterior), lps or ras (default: the format's)");
  sub->add_flag("--centre", args->centre,
                "Move the centre of the first exported state's bounding box to the origin (the "
                "offset is recorded in the file's header or metadata)");
  sub->add_option("--frames", args->frames,
                  "States of a sequence: all, last, rest, K or A:B (0 = rest mesh, 1..N the saved "
                  "frames)")
      ->default_val("last");
  sub->add_option("--time-scale", args->time_scale,
                  "Animation seconds per simulated second (glTF animations)")
      ->default_val(1.0)
      ->check(CLI::PositiveNumber);
  sub->add_option("--iso", args->iso, "Density iso-level in (0, 1] (volume inputs)")
      ->default_val(0.5f)
      ->check(CLI::Range(0.0f, 1.0f));
  sub->add_option("--smooth", args->smooth, "Taubin smoothing iterations (volume inputs)")
      ->default_val(0)
      ->check(CLI::Range(0, 10000));
  sub->add_flag(
      "--stats", args->stats,
      "Print a JSON report (files, sizes, counts, time per stage) instead of the summary");
  sub->callback([args, sub] {
    args->frames_given = sub->count("--frames") > 0;
    args->iso_given = sub->count("--iso") > 0;
    args->smooth_given = sub->count("--smooth") > 0;
    run_export(*args);
  });
}

}  // namespace tsf::app
