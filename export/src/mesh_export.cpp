#include "tsf/export/mesh_export.h"

#include <assimp/version.h>
#include <assimp/Exporter.hpp>

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
#include "tsf/export/tissue_palette.h"
#include "tsf/io/mesh_validation.h"

namespace tsf::exporter {
namespace fs = std::filesystem;

namespace {

/// What the finished file says about itself, and what glTF finishing needs.
struct FileContext {
  const ExportFormatInfo* info = nullptr;
  const OutputFrame* frame = nullptr;
  std::string source;
  std::string frame_warning;
  std::string content;  ///< "state 3 (t = 0.03 s)" ...
  std::vector<std::size_t> states;
  std::vector<std::int32_t> material_labels;  ///< per material: tissue label, or -1 (whole mesh)
  std::vector<float> animation_times;         ///< keyframe times; empty: no animation
};

std::string assimp_version() {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%u.%u.%u", aiGetVersionMajor(), aiGetVersionMinor(),
                aiGetVersionPatch());
  return buf;
}

std::string one_line_description(const FileContext& c) {
  std::string s = "tsf export: " + c.content + "; " + c.frame->describe();
  if (!c.frame_warning.empty()) s += "; " + c.frame_warning;
  if (!c.source.empty()) s += "; source " + c.source;
  return s;
}

double centimetres_per_unit(LengthUnit units) {
  return units == LengthUnit::metre ? 100.0 : 0.1;
}

void finish_gltf(GltfDocument& doc, const FileContext& c) {
  drop_unused_extensions(doc);
  auto& asset = doc.json["asset"];
  asset["generator"] = "tsf export (Open Asset Import Library " + assimp_version() + ")";
  nlohmann::json tsf = {{"content", c.content},
                        {"units", "m"},
                        {"axes", axes_name(c.frame->axes)},
                        {"frame", c.frame->describe()},
                        {"tissue_mm_to_file_row_major", c.frame->matrix()},
                        {"states", c.states},
                        {"colours",
                         "COLOR_0 = tissue label colour (linear RGB); materials are white so that "
                         "COLOR_0 x baseColorFactor shows the tissue colour"}};
  if (!c.source.empty()) tsf["source"] = c.source;
  if (!c.frame_warning.empty()) tsf["frame_warning"] = c.frame_warning;
  asset["extras"] = {{"tsf", tsf}};

  auto& materials = doc.json["materials"];
  for (std::size_t m = 0; m < materials.size() && m < c.material_labels.size(); ++m) {
    auto& pbr = materials[m]["pbrMetallicRoughness"];
    pbr["baseColorFactor"] = {1.0, 1.0, 1.0, 1.0};
    pbr["metallicFactor"] = 0.0;
    pbr["roughnessFactor"] = 0.6;
    if (c.material_labels[m] >= 0) {
      const auto label = static_cast<std::uint8_t>(c.material_labels[m]);
      const auto srgb = tissue_colour_srgb(label);
      materials[m]["extras"] = {{"tsf_label", label},
                                {"tsf_colour_srgb8", {srgb[0], srgb[1], srgb[2]}}};
    }
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
  if (!c.animation_times.empty()) add_morph_animation(doc, c.animation_times, "tissue-motion");
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
      std::string text = header.substr(0, 80);
      text.resize(80, ' ');
      stl.replace(0, 80, text);
      files.emplace_back(target, std::move(stl));
      break;
    }
    case ExportFormat::stl_ascii:
      files.emplace_back(target, std::string(main));
      break;
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

/// `mesh` (tissue space) in the file frame with unit normals; validated, non-empty.
imt::SurfaceMesh prepare_state(const imt::SurfaceMesh& mesh, const OutputFrame& frame,
                               const std::string& what, ExportReport& report) {
  try {
    io::validate_mesh_quickly(mesh);
  } catch (const Error& e) {
    throw Error(what + ": " + e.what());
  }
  require(mesh.triangle_count() > 0, "nothing to export: " + what +
                                         " has no triangles (an empty surface: is the iso-level "
                                         "above every density?)");
  imt::SurfaceMesh out = to_output_frame(mesh, frame);
  report.repaired_normals += complete_normals(out);
  return out;
}

/// Writes one file (state or animation) into `set`.
void add_file(OutputFileSet& set, const imt::SurfaceMesh& base,
              const std::vector<const imt::SurfaceMesh*>& targets,
              const std::vector<std::string>& target_names, const ExportOptions& options,
              FileContext context, const fs::path& target, ExportReport& report) {
  Stopwatch clock;
  SceneInput input;
  input.base = &base;
  input.split_labels = options.split_labels;
  input.parts = options.split_labels ? partition_by_label(base)
                                     : std::vector<LabelPart>{whole_mesh_part(base, 0)};
  input.targets = targets;
  input.target_names = target_names;
  input.linear_colours =
      context.info->format == ExportFormat::glb || context.info->format == ExportFormat::gltf;
  input.root_name = options.name;
  for (const LabelPart& p : input.parts)
    context.material_labels.push_back(options.split_labels ? p.label : -1);
  report.meshes_per_file = std::max(report.meshes_per_file, input.parts.size());
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
                " holds one mesh: --split-labels needs glb, gltf, obj or fbx");
  require(std::isfinite(time_scale) && time_scale > 0.0,
          "time scale " + std::to_string(time_scale) + " must be finite and positive");
  require(!name.empty(), "export name must not be empty");
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

ExportReport export_surface(const imt::SurfaceMesh& mesh, const VolumeGeometry& geometry,
                            const fs::path& path, const ExportOptions& options) {
  ExportReport report = start_report(options);
  require_extension_matches(path, options.format);
  Stopwatch clock;
  OutputFrame frame = make_output_frame(geometry, report.axes, report.units);
  if (options.centre) frame = centred_on(frame, mesh);
  const imt::SurfaceMesh prepared = prepare_state(mesh, frame, "the surface", report);
  report.prepare_s += clock.seconds();
  report.vertices = prepared.vertex_count();
  report.triangles = prepared.triangle_count();
  report.states = {0};

  FileContext context;
  context.info = &format_info(options.format);
  context.frame = &frame;
  context.source = options.source;
  context.frame_warning = options.frame_warning;
  context.content = "surface";
  context.states = report.states;
  OutputFileSet set;
  add_file(set, prepared, {}, {}, options, context, path, report);
  clock.restart();
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

  Stopwatch clock;
  OutputFrame frame = make_output_frame(sequence.geometry, report.axes, report.units);
  const ExportFormatInfo& info = format_info(options.format);
  FileContext context;
  context.info = &info;
  context.frame = &frame;
  context.source = options.source;
  context.frame_warning = options.frame_warning;

  OutputFileSet set;
  if (states.size() == 1) {
    const imt::SurfaceMesh mesh = state_mesh(states[0]);
    if (options.centre) frame = centred_on(frame, mesh);
    const imt::SurfaceMesh prepared =
        prepare_state(mesh, frame, state_content(states[0], state_time(states[0])), report);
    report.prepare_s += clock.seconds();
    report.vertices = prepared.vertex_count();
    report.triangles = prepared.triangle_count();
    context.content = state_content(states[0], state_time(states[0]));
    context.states = states;
    add_file(set, prepared, {}, {}, options, context, path, report);
    report.animation_note = "one state selected";
  } else {
    bool animate = info.morph_animation;
    if (!info.morph_animation) report.animation_note = std::string(info.name) + " has no animation";
    for (std::size_t k : states)
      if (animate && topology[k] != topology[states[0]]) {
        animate = false;
        report.animation_note = "the topology changes at state " + std::to_string(topology[k]) +
                                " (a cut or ablation re-meshed the surface): numbered files only";
      }
    std::vector<imt::SurfaceMesh> kept;  // prepared states for the animation
    Progress progress("export", states.size() + (animate ? 1 : 0));
    for (std::size_t i = 0; i < states.size(); ++i) {
      const std::size_t k = states[i];
      clock.restart();
      const imt::SurfaceMesh mesh = state_mesh(k);
      if (i == 0 && options.centre) frame = centred_on(frame, mesh);
      imt::SurfaceMesh prepared =
          prepare_state(mesh, frame, state_content(k, state_time(k)), report);
      report.prepare_s += clock.seconds();
      if (i == 0) {
        report.vertices = prepared.vertex_count();
        report.triangles = prepared.triangle_count();
      }
      context.content = state_content(k, state_time(k));
      context.states = {k};
      add_file(set, prepared, {}, {}, options, context, numbered_path(path, k, state_count),
               report);
      if (animate) kept.push_back(std::move(prepared));
      progress.advance();
    }
    if (animate) {
      std::vector<const imt::SurfaceMesh*> targets;
      std::vector<std::string> names;
      std::vector<float> times;
      const double t0 = state_time(states[0]);
      for (std::size_t i = 0; i < states.size(); ++i) {
        times.push_back(static_cast<float>((state_time(states[i]) - t0) * options.time_scale));
        if (i == 0) continue;
        targets.push_back(&kept[i]);
        names.push_back(state_content(states[i], state_time(states[i])));
      }
      for (std::size_t i = 1; i < times.size(); ++i)
        require(times[i] > times[i - 1],
                "state times " + std::to_string(state_time(states[i - 1])) + " and " +
                    std::to_string(state_time(states[i])) +
                    " s are too close for a float animation clock; raise --time-scale");
      context.content = "animation of states " + std::to_string(states.front()) + ".." +
                        std::to_string(states.back()) + " (morph targets)";
      context.states = states;
      context.animation_times = times;
      add_file(set, kept[0], targets, names, options, context, path, report);
      report.animated = true;
      progress.advance();
    }
    progress.finish();
  }
  clock.restart();
  set.commit();
  report.write_s += clock.seconds();
  return report;
}

}  // namespace tsf::exporter
