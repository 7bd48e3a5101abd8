#include "tsf/export/mesh_export.h"

#include <assimp/version.h>
#include <assimp/Exporter.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>

#include "assimp_scene.h"
#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/common/stopwatch.h"
#include "tsf/export/export_normals.h"
#include "tsf/export/fbx_document.h"
#include "tsf/export/gltf_document.h"
#include "tsf/export/label_partition.h"
#include "tsf/export/output_file_set.h"
#include "tsf/export/output_frame.h"
#include "tsf/export/ply_document.h"
#include "tsf/export/tissue_bodies.h"
#include "tsf/export/tissue_palette.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/io/mesh_validation.h"

namespace tsf::exporter {
namespace fs = std::filesystem;

namespace {

using Tri = std::array<std::uint32_t, 3>;

/// What the finished file says about itself, and what glTF finishing needs.
struct FileContext {
  const ExportFormatInfo* info = nullptr;
  const OutputFrame* frame = nullptr;
  std::string source;
  std::string frame_warning;
  std::string content;  ///< "state 3 (t = 0.03 s)" ...
  std::vector<std::size_t> states;
  std::vector<std::uint8_t> material_labels;  ///< per material: its tissue label
  bool vertex_colours = false;
  std::vector<AnimatedGroup> animation;  ///< empty: no animation
  double time_scale = 1.0;               ///< animation seconds per simulated second
  std::vector<std::string> lod_nodes;    ///< glTF levels of detail (group node names)
  std::vector<float> lod_coverage;
};

/// The context every file of an export starts from: the format, frame, source and frame warning.
FileContext file_context(const ExportOptions& options, const OutputFrame& frame) {
  FileContext context;
  context.info = &format_info(options.format);
  context.frame = &frame;
  context.source = options.source;
  context.frame_warning = options.frame_warning;
  return context;
}

std::string assimp_version() {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%u.%u.%u", aiGetVersionMajor(), aiGetVersionMinor(),
                aiGetVersionPatch());
  return buf;
}

/// 3D Slicer's coordinate system token (SPACE=LPS or SPACE=RAS), empty for y-up axes.
std::string space_token(const OutputFrame& frame) {
  switch (frame.axes) {
    case AxisConvention::lps:
      return "SPACE=LPS";
    case AxisConvention::ras:
      return "SPACE=RAS";
    case AxisConvention::y_up:
      break;
  }
  return "";
}

std::string one_line_description(const FileContext& c) {
  std::string s = "tsf export: " + c.content + "; " + c.frame->describe();
  if (const std::string token = space_token(*c.frame); !token.empty()) s += "; " + token;
  if (!c.frame_warning.empty()) s += "; " + c.frame_warning;
  if (!c.source.empty()) s += "; source " + c.source;
  return s;
}

double centimetres_per_unit(LengthUnit units) {
  return units == LengthUnit::metre ? 100.0 : 0.1;
}

double mm_per_unit(LengthUnit units) {
  return units == LengthUnit::metre ? 1000.0 : 1.0;
}

void finish_gltf(GltfDocument& doc, const FileContext& c) {
  drop_unused_extensions(doc);
  auto& asset = doc.json["asset"];
  asset["generator"] = "tsf export (Open Asset Import Library " + assimp_version() + ")";
  nlohmann::json tsf = {
      {"content", c.content},
      {"units", "m"},
      {"axes", axes_name(c.frame->axes)},
      {"frame", c.frame->describe()},
      {"tissue_mm_to_file_row_major", c.frame->matrix()},
      {"states", c.states},
      {"colours", c.vertex_colours
                      ? "COLOR_0 = tissue colour (linear RGB); materials are white so that COLOR_0 "
                        "x baseColorFactor shows the tissue colour"
                      : "one material per tissue, baseColorFactor = the tissue colour (linear)"}};
  if (!c.source.empty()) tsf["source"] = c.source;
  if (!c.frame_warning.empty()) tsf["frame_warning"] = c.frame_warning;
  if (!c.animation.empty()) tsf["animation_seconds_per_simulated_second"] = c.time_scale;
  asset["extras"] = {{"tsf", tsf}};

  auto& materials = doc.json["materials"];
  require(materials.size() == c.material_labels.size(),
          "glTF finishing: assimp wrote " + std::to_string(materials.size()) + " materials for " +
              std::to_string(c.material_labels.size()) + " tissues");
  for (std::size_t m = 0; m < materials.size(); ++m) {
    const std::uint8_t label = c.material_labels[m];
    const auto linear = tissue_colour_linear(label);
    const auto srgb = tissue_colour_srgb(label);
    const TissueLook look = tissue_look(label);
    auto& material = materials[m];
    material["name"] = tissue_material_name(label);
    nlohmann::json pbr = {{"metallicFactor", look.metallic}, {"roughnessFactor", look.roughness}};
    pbr["baseColorFactor"] = c.vertex_colours
                                 ? std::vector<double>{1.0, 1.0, 1.0, 1.0}
                                 : std::vector<double>{linear[0], linear[1], linear[2], 1.0};
    material["pbrMetallicRoughness"] = pbr;
    material["extras"] = {{"tsf_label", label}, {"tsf_colour_srgb8", {srgb[0], srgb[1], srgb[2]}}};
  }
  // assimp leaves the target of morph-target buffer views unset (the validator hints at it):
  // they hold vertex attributes.
  for (const auto& mesh : doc.json.value("meshes", nlohmann::json::array()))
    for (const auto& primitive : mesh["primitives"])
      for (const auto& target : primitive.value("targets", nlohmann::json::array()))
        for (const auto& attribute : target) {
          auto& view = doc.json["bufferViews"]
                               [doc.json["accessors"][attribute.get<std::size_t>()]["bufferView"]
                                    .get<std::size_t>()];
          if (!view.contains("target")) view["target"] = 34962;  // ARRAY_BUFFER
        }
  if (!c.animation.empty()) add_state_animation(doc, c.animation, "tissue-motion");
  if (!c.lod_nodes.empty()) add_lods(doc, c.lod_nodes, c.lod_coverage);
}

std::string replace_first(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  require(at != std::string::npos, "assimp output lacks the expected '" + from + "'");
  return text.replace(at, from.size(), to);
}

/// Runs assimp's exporter on `scene` and finishes its output for `target`: the files to write.
std::vector<std::pair<fs::path, std::string>> encode_scene(const aiScene& scene,
                                                           const fs::path& target,
                                                           const FileContext& c,
                                                           ExportReport& report) {
  Stopwatch clock;
  Assimp::Exporter exporter;
  Assimp::ExportProperties properties;
  properties.SetPropertyBool("GLTF2_TARGETNAMES_EXP", true);
  const aiExportDataBlob* blob = exporter.ExportToBlob(&scene, c.info->assimp_id, 0u, &properties);
  if (!blob)
    throw Error("assimp could not write '" + target.string() + "' as " + c.info->name + ": " +
                exporter.GetErrorString());
  std::map<std::string, std::string_view> extra;  // companion blobs by extension ("bin", "mtl")
  for (const aiExportDataBlob* b = blob->next; b; b = b->next)
    extra[b->name.C_Str()] = std::string_view(static_cast<const char*>(b->data), b->size);
  const std::string_view main(static_cast<const char*>(blob->data), blob->size);
  report.assimp_s += clock.seconds();

  clock.restart();
  std::vector<std::pair<fs::path, std::string>> files;
  const std::string header = one_line_description(c);
  switch (c.info->format) {
    case ExportFormat::glb: {
      GltfDocument doc = parse_glb(main);
      finish_gltf(doc, c);
      files.emplace_back(target, write_glb(doc));
      break;
    }
    case ExportFormat::gltf: {
      require(extra.count("bin"), "assimp wrote no buffer for '" + target.string() + "'");
      GltfDocument doc = parse_gltf(main, extra["bin"]);
      finish_gltf(doc, c);
      files.emplace_back(target, write_embedded_gltf(doc));
      break;
    }
    case ExportFormat::obj: {
      require(extra.count("mtl"), "assimp wrote no material library for '" + target.string() + "'");
      fs::path mtl = target;
      mtl.replace_extension(".mtl");
      std::string obj = replace_first(std::string(main), "mtllib $blobfile.mtl",
                                      "mtllib " + mtl.filename().string());
      files.emplace_back(target, "# " + header + "\n" + obj);
      files.emplace_back(mtl, "# " + header + "\n" + std::string(extra["mtl"]));
      break;
    }
    case ExportFormat::stl: {
      std::string stl(main);
      require(stl.size() >= 84, "assimp wrote a truncated binary STL");
      // The 80-byte header is free text; it must not start with "solid" (ASCII STL's keyword).
      // Slicer's SPACE= token goes first so that it survives the cut to 80 bytes.
      std::string text = space_token(*c.frame);
      text = (text.empty() ? "" : text + " ") + header;
      text = text.substr(0, 80);
      text.resize(80, ' ');
      stl.replace(0, 80, text);
      files.emplace_back(target, std::move(stl));
      break;
    }
    case ExportFormat::stl_ascii: {
      // The "solid" line's name is the header Slicer searches for SPACE=.
      std::string stl(main);
      const std::string token = space_token(*c.frame);
      const std::size_t eol = stl.find('\n');
      require(stl.rfind("solid", 0) == 0 && eol != std::string::npos,
              "assimp wrote an ASCII STL without its 'solid' line");
      if (!token.empty()) stl.insert(eol, " " + token);
      files.emplace_back(target, std::move(stl));
      break;
    }
    case ExportFormat::ply:
      files.emplace_back(target, finalise_ply_binary(main, header));
      break;
    case ExportFormat::ply_ascii: {
      std::string ply(main);
      const std::size_t format_line = ply.find("\nformat ");
      require(format_line != std::string::npos, "assimp wrote a PLY without a format line");
      const std::size_t eol = ply.find('\n', format_line + 1);
      ply.insert(eol + 1, "comment " + header + "\n");
      files.emplace_back(target, std::move(ply));
      break;
    }
    case ExportFormat::fbx:
      files.emplace_back(target, finalise_fbx_binary(main, centimetres_per_unit(c.frame->units)));
      break;
    case ExportFormat::fbx_ascii:
      files.emplace_back(target,
                         finalise_fbx_ascii(main, centimetres_per_unit(c.frame->units), header));
      break;
  }
  report.finish_s += clock.seconds();
  return files;
}

// ---- topology: clean, decimate, levels ------------------------------------------------------

/// One level of one run of states: its topology as a map from the run's base state.
struct Level {
  std::vector<std::uint32_t> origin;  ///< output vertex -> vertex of the raw state
  std::vector<std::uint32_t> group;  ///< normal sharing (copies along tissue borders); may be empty
  std::vector<std::uint8_t> labels;
  std::vector<Tri> triangles;
  LevelReport report;
  TriangleDefects defects;  ///< in the base state (file frame)
};

/// measure_deviation in mm, for surfaces in the file's units (`mm` per unit).
SurfaceDeviation deviation_mm(const TriangleSet& full, const TriangleSet& level, double mm) {
  SurfaceDeviation d = measure_deviation(full, level);
  for (double* x :
       {&d.to_full_mean_mm, &d.to_full_max_mm, &d.from_full_mean_mm, &d.from_full_max_mm})
    *x *= mm;
  return d;
}

void fill_decimation_report(LevelReport& r, const DecimatedMesh& d) {
  r.decimated = true;
  r.decimate_s = d.seconds;
  r.decimate_idle_s = d.critical_path_cpu_s;
  r.meshopt_error_mm = d.meshopt_error_mm;
  r.slabs = d.slabs;
  r.rounds = d.rounds;
  r.locked_vertices = d.locked_vertices;
  r.nonmanifold_vertices = d.nonmanifold_vertices;
  r.repaired_triangles = d.fins_removed + d.caps_flipped + d.caps_removed;
}

std::vector<std::uint32_t> compose(const std::vector<std::uint32_t>& outer,
                                   const std::vector<std::uint32_t>& inner) {
  std::vector<std::uint32_t> out(inner.size());
  for (std::size_t i = 0; i < inner.size(); ++i) out[i] = outer[inner[i]];
  return out;
}

imt::SurfaceMesh level_mesh(const Level& level, const std::vector<Vec3f>& state_positions,
                            ExportReport& report) {
  imt::SurfaceMesh m;
  m.positions = gather(state_positions, level.origin);
  m.labels = level.labels;
  m.triangles = level.triangles;
  std::size_t without_area = 0;
  m.normals = area_weighted_normals(m.positions, m.triangles, level.group, &without_area);
  report.normals_without_area += without_area;
  return m;
}

/// Cleans (and decimates, levels of detail) one run of states whose base is `base` (raw, in the
/// file frame); `others`: the run's later states.
std::vector<Level> prepare_run(const imt::SurfaceMesh& base,
                               const std::vector<const std::vector<Vec3f>*>& others,
                               const ExportOptions& o, LengthUnit units, bool first,
                               ExportReport& report) {
  const double mm = mm_per_unit(units);
  Stopwatch clock;
  const CleanTopology clean = clean_topology(base, others, static_cast<float>(1e-3 / mm));
  report.clean_s += clock.seconds();
  if (first) {
    report.cleanup = clean.report;
    report.input_triangles = base.triangles.size();
  }
  require(!clean.triangles.empty(), "nothing to export: no triangle has area");
  imt::SurfaceMesh cleaned;
  cleaned.positions = gather(base.positions, clean.origin);
  cleaned.labels = clean.labels;
  cleaned.triangles = clean.triangles;

  std::vector<Level> levels;
  Level full;
  full.origin = clean.origin;
  full.labels = clean.labels;
  full.triangles = clean.triangles;
  full.defects = clean.report.after;
  DecimatedMesh previous;  // the level the next one is made from
  previous.origin.resize(cleaned.positions.size());
  for (std::uint32_t v = 0; v < previous.origin.size(); ++v) previous.origin[v] = v;
  previous.labels = cleaned.labels;
  previous.triangles = cleaned.triangles;

  const auto add_level = [&](const DecimatedMesh& d) {
    Level level;
    level.origin = compose(clean.origin, d.origin);
    level.group = d.origin;
    level.labels = d.labels;
    level.triangles = d.triangles;
    fill_decimation_report(level.report, d);
    report.decimate_s += d.seconds;
    const imt::SurfaceMesh surface = decimated_surface(cleaned, d);
    level.defects = count_triangle_defects(surface);
    if (o.measure_error && first) {
      clock.restart();
      level.report.deviation = deviation_mm({&cleaned.positions, &cleaned.triangles},
                                            {&surface.positions, &surface.triangles}, mm);
      report.measure_s += clock.seconds();
    }
    levels.push_back(std::move(level));
  };

  if (o.decimation) {
    DecimationOptions d = *o.decimation;
    d.mm_per_unit = mm;
    previous = decimate(cleaned, d);
    add_level(previous);
  } else {
    levels.push_back(std::move(full));
  }
  for (std::size_t target : o.lods) {
    DecimationOptions d = o.decimation ? *o.decimation : DecimationOptions{};
    d.target_triangles = target;
    d.mm_per_unit = mm;
    if (!o.decimation) d.max_error_mm = 0.0;
    previous = decimate_further(cleaned, previous, d);
    add_level(previous);
  }
  for (Level& level : levels) {
    level.report.triangles = level.triangles.size();
    level.report.vertices = level.origin.size();
  }
  return levels;
}

/// `mesh` validated, mapped into the file frame without normals (they are recomputed there).
imt::SurfaceMesh raw_in_frame(const imt::SurfaceMesh& mesh, const OutputFrame& frame,
                              const std::string& what) {
  try {
    io::validate_mesh_quickly(mesh);
  } catch (const Error& e) {
    throw Error(what + ": " + e.what());
  }
  require(mesh.triangle_count() > 0, "nothing to export: " + what +
                                         " has no triangles (an empty surface: is the iso-level "
                                         "above every density?)");
  imt::SurfaceMesh bare;
  bare.positions = mesh.positions;
  bare.labels = mesh.labels;
  bare.triangles = mesh.triangles;
  return to_output_frame(bare, frame);
}

// ---- files -----------------------------------------------------------------------------------

struct GroupInput {
  std::string name, mesh_suffix;
  const imt::SurfaceMesh* base = nullptr;
  std::vector<const imt::SurfaceMesh*> targets;
  std::vector<std::string> target_names;
};

/// Writes one file (groups of meshes: a surface, levels, bodies or runs of states) into `set`.
void add_file(OutputFileSet& set, const std::vector<GroupInput>& groups,
              const ExportOptions& options, FileContext context, const fs::path& target,
              ExportReport& report) {
  Stopwatch clock;
  SceneInput input;
  input.split_labels = options.split_labels;
  input.vertex_colours = options.vertex_colours || context.info->format == ExportFormat::ply ||
                         context.info->format == ExportFormat::ply_ascii;
  input.linear_colours =
      context.info->format == ExportFormat::glb || context.info->format == ExportFormat::gltf;
  input.root_name = options.name;
  std::size_t meshes = 0;
  for (const GroupInput& g : groups) {
    SceneGroup sg;
    sg.name = g.name;
    sg.mesh_suffix = g.mesh_suffix;
    sg.base = g.base;
    // Formats without materials keep the surface whole (no vertex copies on tissue borders).
    sg.parts = context.info->materials
                   ? partition_by_label(*g.base)
                   : std::vector<LabelPart>{whole_mesh_part(*g.base, g.base->labels.front())};
    sg.targets = g.targets;
    sg.target_names = g.target_names;
    meshes += sg.parts.size();
    input.groups.push_back(std::move(sg));
  }
  context.material_labels = scene_material_labels(input);
  context.vertex_colours = input.vertex_colours;
  report.tissues.clear();
  for (std::uint8_t l : context.material_labels) report.tissues.push_back(tissue_material_name(l));
  report.meshes_per_file = std::max(report.meshes_per_file, meshes);
  report.prepare_s += clock.seconds();

  clock.restart();
  const std::unique_ptr<aiScene> scene = build_assimp_scene(input);
  report.scene_s += clock.seconds();

  const auto files = encode_scene(*scene, target, context, report);
  clock.restart();
  for (const auto& [path, bytes] : files) {
    set.add(path, bytes);
    report.files.push_back({path, bytes.size(),
                            path.extension() == ".mtl"
                                ? "materials of " + target.filename().string()
                                : context.content});
  }
  report.write_s += clock.seconds();
}

std::string state_content(std::size_t state, double time_s) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "state %zu (t = %.6g s)", state, time_s);
  return buf;
}

ExportReport start_report(const ExportOptions& options) {
  options.validate();
  ExportReport report;
  report.format = options.format;
  report.units = options.resolved_units();
  report.axes = options.resolved_axes();
  return report;
}

/// STEM-lodK.EXT (K ≥ 1) beside `path`, for formats that hold one mesh per file.
fs::path level_path(const fs::path& path, std::size_t level) {
  if (level == 0) return path;
  return path.parent_path() /
         (path.stem().string() + "-lod" + std::to_string(level) + path.extension().string());
}

/// Screen coverage below which level k gives way to level k+1 (MSFT_screencoverage): halves
/// per level; the last level is shown down to nothing.
std::vector<float> lod_coverage(std::size_t levels) {
  std::vector<float> c;
  for (std::size_t k = 0; k < levels; ++k)
    c.push_back(k + 1 == levels ? 0.0f
                                : static_cast<float>(std::pow(0.5, static_cast<double>(k + 1))));
  return c;
}

/// Writes the levels of one state: one file with a group per level (a node per level, MSFT_lod
/// in glTF), or one file per level for formats that hold one mesh.
void write_levels(OutputFileSet& set, const std::vector<imt::SurfaceMesh>& meshes,
                  const ExportOptions& options, FileContext context, const fs::path& path,
                  ExportReport& report) {
  const bool several = meshes.size() > 1;
  if (!context.info->multiple_meshes) {
    for (std::size_t k = 0; k < meshes.size(); ++k) {
      FileContext c = context;
      if (several) c.content += ", level of detail " + std::to_string(k);
      add_file(set, {GroupInput{"surface", "", &meshes[k], {}, {}}}, options, c,
               level_path(path, k), report);
    }
    return;
  }
  std::vector<GroupInput> groups;
  for (std::size_t k = 0; k < meshes.size(); ++k) {
    const std::string suffix = several ? "_LOD" + std::to_string(k) : "";
    groups.push_back({several ? options.name + suffix : "surface", suffix, &meshes[k], {}, {}});
  }
  if (several &&
      (context.info->format == ExportFormat::glb || context.info->format == ExportFormat::gltf)) {
    for (const GroupInput& g : groups) context.lod_nodes.push_back(g.name);
    context.lod_coverage = lod_coverage(groups.size());
  }
  if (several) context.content += ", " + std::to_string(meshes.size()) + " levels of detail";
  add_file(set, groups, options, context, path, report);
}

}  // namespace

void ExportOptions::validate() const {
  const ExportFormatInfo& f = format_info(format);
  if (units && f.fixed_units && *units != f.default_units)
    throw Error(std::string("format ") + f.name + " stores metres by specification; --units " +
                unit_name(*units) + " applies to obj, stl, ply and fbx");
  if (axes && f.fixed_axes && *axes != f.default_axes)
    throw Error(std::string("format ") + f.name + " declares " + axes_name(f.default_axes) +
                " axes (" +
                (f.format == ExportFormat::fbx || f.format == ExportFormat::fbx_ascii
                     ? "in the FBX header assimp writes"
                     : "glTF: +Y up, the asset faces +Z") +
                "); --axes " + axes_name(*axes) + " applies to obj, stl and ply");
  if (split_labels && !f.multiple_meshes)
    throw Error(std::string("format ") + f.name +
                " holds one mesh: --split-labels needs glb, gltf, obj or fbx (for one file per "
                "tissue use --bodies)");
  require(std::isfinite(time_scale) && time_scale > 0.0,
          "time scale " + std::to_string(time_scale) + " must be finite and positive");
  require(!name.empty(), "export name must not be empty");
  if (decimation) decimation->validate();
  for (std::size_t k = 0; k < lods.size(); ++k) {
    require(lods[k] > 0, "--lods: a level of 0 triangles");
    require(k == 0 || lods[k] < lods[k - 1], "--lods: levels must decrease (" +
                                                 std::to_string(lods[k - 1]) + " then " +
                                                 std::to_string(lods[k]) + ")");
  }
  if (decimation && decimation->target_triangles > 0 && !lods.empty())
    require(lods[0] < decimation->target_triangles,
            "--lods: the first level (" + std::to_string(lods[0]) +
                " triangles) must be below --decimate (" +
                std::to_string(decimation->target_triangles) + ")");
}

LengthUnit ExportOptions::resolved_units() const {
  return units ? *units : format_info(format).default_units;
}

AxisConvention ExportOptions::resolved_axes() const {
  return axes ? *axes : format_info(format).default_axes;
}

fs::path numbered_path(const fs::path& path, std::size_t state, std::size_t state_count) {
  int digits = 4;
  for (std::size_t n = state_count > 0 ? state_count - 1 : 0; n >= 10000; n /= 10) ++digits;
  char number[32];
  std::snprintf(number, sizeof(number), "%0*zu", digits, state);
  return path.parent_path() / (path.stem().string() + "-" + number + path.extension().string());
}

namespace {

/// One state (a surface or one state of a sequence) with its levels into `set`.
void export_one_state(OutputFileSet& set, const imt::SurfaceMesh& mesh, const OutputFrame& frame,
                      const ExportOptions& options, FileContext context, const fs::path& path,
                      ExportReport& report) {
  Stopwatch clock;
  const imt::SurfaceMesh raw = raw_in_frame(mesh, frame, context.content);
  report.prepare_s += clock.seconds();
  const std::vector<Level> levels = prepare_run(raw, {}, options, frame.units, true, report);
  clock.restart();
  std::vector<imt::SurfaceMesh> meshes;
  for (const Level& level : levels) {
    meshes.push_back(level_mesh(level, raw.positions, report));
    report.levels.push_back(level.report);
    report.written.triangles += level.defects.triangles;
    report.written.zero_area += level.defects.zero_area;
    report.written.duplicates += level.defects.duplicates;
  }
  report.vertices = meshes[0].vertex_count();
  report.triangles = meshes[0].triangle_count();
  report.prepare_s += clock.seconds();
  write_levels(set, meshes, options, context, path, report);
}

}  // namespace

ExportReport export_surface(const imt::SurfaceMesh& mesh, const VolumeGeometry& geometry,
                            const fs::path& path, const ExportOptions& options) {
  ExportReport report = start_report(options);
  require_extension_matches(path, options.format);
  OutputFrame frame = make_output_frame(geometry, report.axes, report.units);
  if (options.centre) frame = centred_on(frame, mesh);
  report.states = {0};
  FileContext context = file_context(options, frame);
  context.content = "surface";
  context.states = report.states;
  OutputFileSet set;
  export_one_state(set, mesh, frame, options, context, path, report);
  Stopwatch clock;
  set.commit();
  report.write_s += clock.seconds();
  return report;
}

ExportReport export_sequence(const io::MeshSequence& sequence, const FrameSelection& selection,
                             const fs::path& path, const ExportOptions& options) {
  ExportReport report = start_report(options);
  require_extension_matches(path, options.format);
  const std::size_t state_count = sequence.frames.size() + 1;
  const std::vector<std::size_t> states = selection.states(state_count);
  report.states = states;

  // Topology in force at each state: the state that last re-meshed (0 = the rest mesh).
  std::vector<std::size_t> topology(state_count, 0);
  for (std::size_t k = 1; k < state_count; ++k)
    topology[k] = sequence.frames[k - 1].topology_changed ? k : topology[k - 1];
  const auto state_mesh = [&](std::size_t k) {
    return k == 0 ? sequence.rest : io::frame_mesh(sequence, k - 1);
  };
  const auto state_time = [&](std::size_t k) {
    return k == 0 ? sequence.rest_time_s : sequence.frames[k - 1].time_s;
  };

  OutputFrame frame = make_output_frame(sequence.geometry, report.axes, report.units);
  const ExportFormatInfo& info = format_info(options.format);
  FileContext context = file_context(options, frame);

  OutputFileSet set;
  if (states.size() == 1) {
    const imt::SurfaceMesh mesh = state_mesh(states[0]);
    if (options.centre) frame = centred_on(frame, mesh);
    context.content = state_content(states[0], state_time(states[0]));
    context.states = states;
    export_one_state(set, mesh, frame, options, context, path, report);
    report.animation_note = "one state selected";
  } else {
    require(options.lods.empty(),
            "--lods applies to one state; select one with --frames (e.g. --frames last)");
    const bool animate = info.morph_animation;
    if (!animate) report.animation_note = std::string(info.name) + " has no animation";
    // Runs of consecutive selected states that share one topology.
    std::vector<std::vector<std::size_t>> runs;
    for (std::size_t i = 0; i < states.size(); ++i) {
      if (runs.empty() || topology[states[i]] != topology[runs.back().front()]) runs.emplace_back();
      runs.back().push_back(states[i]);
    }
    report.topology_runs = runs.size();
    const double t0 = state_time(states.front());
    const auto anim_time = [&](std::size_t k) {
      return static_cast<float>((state_time(k) - t0) * options.time_scale);
    };
    for (std::size_t i = 1; i < states.size(); ++i)
      require(anim_time(states[i]) > anim_time(states[i - 1]),
              "state times " + std::to_string(state_time(states[i - 1])) + " and " +
                  std::to_string(state_time(states[i])) +
                  " s are too close for a float animation clock; raise --time-scale");

    Progress progress("export", states.size() + (animate ? 1 : 0));
    std::vector<std::vector<imt::SurfaceMesh>> kept(runs.size());  // per run, per state
    bool first_state = true;
    for (std::size_t r = 0; r < runs.size(); ++r) {
      Stopwatch clock;
      std::vector<imt::SurfaceMesh> raw;
      for (std::size_t k : runs[r]) {
        const imt::SurfaceMesh mesh = state_mesh(k);
        if (first_state && options.centre) frame = centred_on(frame, mesh);
        first_state = false;
        raw.push_back(raw_in_frame(mesh, frame, state_content(k, state_time(k))));
      }
      std::vector<const std::vector<Vec3f>*> others;
      for (std::size_t i = 1; i < raw.size(); ++i) others.push_back(&raw[i].positions);
      report.prepare_s += clock.seconds();
      const std::vector<Level> levels =
          prepare_run(raw[0], others, options, frame.units, r == 0, report);
      const Level& level = levels[0];
      if (r == 0) report.levels.push_back(level.report);
      for (std::size_t i = 0; i < runs[r].size(); ++i) {
        const std::size_t k = runs[r][i];
        clock.restart();
        imt::SurfaceMesh mesh = level_mesh(level, raw[i].positions, report);
        const TriangleDefects d = i == 0 ? level.defects : count_triangle_defects(mesh);
        report.written.triangles += d.triangles;
        report.written.zero_area += d.zero_area;
        report.written.duplicates += d.duplicates;
        if (r == 0 && i == 0) {
          report.vertices = mesh.vertex_count();
          report.triangles = mesh.triangle_count();
        }
        report.prepare_s += clock.seconds();
        context.content = state_content(k, state_time(k));
        context.states = {k};
        if (options.numbered_files || !animate)
          add_file(set, {GroupInput{"surface", "", &mesh, {}, {}}}, options, context,
                   numbered_path(path, k, state_count), report);
        if (animate) kept[r].push_back(std::move(mesh));
        progress.advance();
      }
    }
    if (animate) {
      std::vector<GroupInput> groups;
      std::vector<AnimatedGroup> animation;
      for (std::size_t r = 0; r < runs.size(); ++r) {
        GroupInput g;
        const std::size_t a = runs[r].front(), b = runs[r].back();
        g.name = runs.size() == 1
                     ? "surface"
                     : "states " + std::to_string(a) + (a == b ? "" : "-" + std::to_string(b));
        g.base = &kept[r][0];
        AnimatedGroup ag;
        // One run with a node per tissue hangs the tissue nodes from the root (assimp_scene.h).
        ag.node = options.split_labels && runs.size() == 1 ? options.name : g.name;
        for (std::size_t i = 0; i < runs[r].size(); ++i) {
          ag.times.push_back(anim_time(runs[r][i]));
          if (i == 0) continue;
          g.targets.push_back(&kept[r][i]);
          g.target_names.push_back(state_content(runs[r][i], state_time(runs[r][i])));
        }
        if (ag.times.size() == 1) ag.times.clear();  // a single state: no morph weights
        ag.visible_from = anim_time(a);
        ag.visible_until = r + 1 < runs.size() ? anim_time(runs[r + 1].front()) : -1.0f;
        groups.push_back(std::move(g));
        animation.push_back(std::move(ag));
      }
      context.content =
          "animation of states " + std::to_string(states.front()) + ".." +
          std::to_string(states.back()) +
          (runs.size() == 1 ? " (morph targets)"
                            : " (" + std::to_string(runs.size()) +
                                  " topologies switched by STEP scale keys, morph targets "
                                  "within each)");
      context.states = states;
      context.animation = animation;
      context.time_scale = options.time_scale;
      add_file(set, groups, options, context, path, report);
      report.animated = true;
      if (runs.size() > 1)
        report.animation_note = std::to_string(runs.size()) +
                                " runs of one topology (a cut or ablation re-meshed the surface)";
      progress.advance();
    }
    progress.finish();
  }
  Stopwatch clock;
  set.commit();
  report.write_s += clock.seconds();
  return report;
}

namespace {

/// The bodies of one level of the interface complex as one mesh: each body its own vertices
/// (copies of the complex's), labelled with its tissue, so partition_by_label gives the bodies.
imt::SurfaceMesh bodies_of_level(const InterfaceComplex& c,
                                 const std::vector<std::uint8_t>& tissues) {
  imt::SurfaceMesh m;
  for (std::uint8_t tissue : tissues) {
    const imt::SurfaceMesh body = body_mesh(c, tissue);
    const auto base = static_cast<std::uint32_t>(m.positions.size());
    m.positions.insert(m.positions.end(), body.positions.begin(), body.positions.end());
    m.labels.insert(m.labels.end(), body.labels.begin(), body.labels.end());
    for (const Tri& t : body.triangles)
      m.triangles.push_back({base + t[0], base + t[1], base + t[2]});
  }
  m.normals = area_weighted_normals(m.positions, m.triangles);
  return m;
}

}  // namespace

ExportReport export_bodies(const VoxelVolume& volume, float iso, const fs::path& path,
                           const ExportOptions& options) {
  ExportReport report = start_report(options);
  require_extension_matches(path, options.format);
  require(!options.split_labels,
          "--bodies already gives one mesh per tissue (--split-labels cuts "
          "the one surface instead)");
  Stopwatch clock;
  const InterfaceComplex complex = tissue_interfaces(volume, iso);
  const std::vector<std::uint8_t> tissues = complex.tissues();
  require(!tissues.empty(), "nothing to export: no voxel reaches the iso-level " +
                                std::to_string(iso) + " (is it above every density?)");
  imt::SurfaceMesh tissue_space;
  tissue_space.positions = complex.positions;
  tissue_space.triangles = complex.triangles;
  tissue_space.labels.assign(complex.positions.size(), 0);
  OutputFrame frame = make_output_frame(volume.geometry(), report.axes, report.units);
  if (options.centre) frame = centred_on(frame, tissue_space);
  const imt::SurfaceMesh full = to_output_frame(tissue_space, frame);  // the complex, file frame
  report.prepare_s += clock.seconds();
  report.states = {0};
  clock.restart();
  report.cleanup.before = report.cleanup.after = count_triangle_defects(full);
  report.input_triangles = full.triangles.size();
  report.clean_s += clock.seconds();

  // Levels: the complex as it is, or decimated with every interface its own part (triple lines
  // stay, so neighbouring bodies keep sharing their interface); each level from the full complex.
  struct BodyLevel {
    InterfaceComplex complex;
    LevelReport report;
  };
  const Vec3d& sp = volume.geometry().spacing;
  const double voxel_mm = std::min({sp.x, sp.y, sp.z});
  InterfaceComplex in_frame = complex;  // the complex in the file frame
  in_frame.positions = full.positions;
  in_frame.triangles = full.triangles;
  const double mm = mm_per_unit(report.units);
  std::vector<BodyLevel> levels;
  std::vector<std::size_t> targets;
  if (options.decimation) targets.push_back(options.decimation->target_triangles);
  targets.insert(targets.end(), options.lods.begin(), options.lods.end());
  if (!options.decimation) levels.push_back({in_frame, {}});
  for (std::size_t k = 0; k < targets.size(); ++k) {
    DecimationOptions o = options.decimation ? *options.decimation : DecimationOptions{};
    o.target_triangles = targets[k];
    if (k > 0 || !options.decimation) o.max_error_mm = 0.0;
    if (o.target_triangles == 0 && o.max_error_mm == 0.0) continue;
    // Triple lines never move, so a budget may be out of reach; without a bound meshoptimizer
    // would then collapse whole interfaces onto them. Bodies never move more than a voxel
    // unless --max-error says otherwise.
    if (o.max_error_mm == 0.0) o.max_error_mm = voxel_mm;
    o.mm_per_unit = mm;
    BodyLevel level;
    DecimatedMesh d;
    level.complex = decimate_interfaces(in_frame, o, &d);
    fill_decimation_report(level.report, d);
    report.decimate_s += d.seconds;
    if (options.measure_error) {
      Stopwatch measure;
      level.report.deviation = deviation_mm({&full.positions, &full.triangles},
                                            {&full.positions, &level.complex.triangles}, mm);
      report.measure_s += measure.seconds();
    }
    levels.push_back(std::move(level));
  }

  // Meshes: per level all bodies (each with its own vertices).
  clock.restart();
  std::vector<imt::SurfaceMesh> meshes;
  for (BodyLevel& level : levels) {
    meshes.push_back(bodies_of_level(level.complex, tissues));
    // Per body: neighbours share their interface, so the whole holds each such triangle twice.
    for (const LabelPart& part : partition_by_label(meshes.back())) {
      imt::SurfaceMesh body;
      body.positions = gather(meshes.back().positions, part.vertices);
      body.triangles = part.triangles;
      const TriangleDefects d = count_triangle_defects(body);
      report.written.triangles += d.triangles;
      report.written.zero_area += d.zero_area;
      report.written.duplicates += d.duplicates;
    }
    level.report.triangles = level.complex.triangles.size();
    level.report.vertices = meshes.back().vertex_count();
    report.levels.push_back(level.report);
  }
  for (const LabelPart& part : partition_by_label(meshes[0])) {
    imt::SurfaceMesh body;
    body.positions = gather(meshes[0].positions, part.vertices);
    body.triangles = part.triangles;
    body.labels.assign(body.positions.size(), part.label);
    ExportReport::Body b;
    b.tissue = tissue_material_name(part.label);
    b.vertices = body.positions.size();
    b.triangles = body.triangles.size();
    const imt::MeshTopology topo = imt::analyse_topology(body);
    b.closed_manifold = topo.closed_oriented_manifold();
    b.boundary_edges = topo.boundary_edges;
    b.nonmanifold_edges = topo.nonmanifold_edges;
    b.nonmanifold_vertices = topo.nonmanifold_vertices;
    b.components = topo.components;
    report.bodies.push_back(b);
  }
  report.vertices = meshes[0].vertex_count();
  report.triangles = meshes[0].triangle_count();
  report.prepare_s += clock.seconds();

  FileContext context = file_context(options, frame);
  context.content = "tissue bodies";
  context.states = report.states;
  OutputFileSet set;
  ExportOptions per_body = options;
  per_body.split_labels = true;
  if (context.info->multiple_meshes) {
    write_levels(set, meshes, per_body, context, path, report);
  } else {
    // One file per body (and level): STEM-TISSUE.EXT, STEM-TISSUE-lodK.EXT.
    for (std::size_t k = 0; k < meshes.size(); ++k)
      for (const LabelPart& part : partition_by_label(meshes[k])) {
        imt::SurfaceMesh body;
        body.positions = gather(meshes[k].positions, part.vertices);
        body.normals = gather(meshes[k].normals, part.vertices);
        body.triangles = part.triangles;
        body.labels.assign(body.positions.size(), part.label);
        const std::string tissue = tissue_material_name(part.label);
        const fs::path file = level_path(
            path.parent_path() / (path.stem().string() + "-" + tissue + path.extension().string()),
            k);
        FileContext c = context;
        c.content = "tissue body " + tissue +
                    (meshes.size() > 1 ? ", level of detail " + std::to_string(k) : "");
        add_file(set, {GroupInput{tissue, "", &body, {}, {}}}, options, c, file, report);
      }
  }
  clock.restart();
  set.commit();
  report.write_s += clock.seconds();
  return report;
}

}  // namespace tsf::exporter
