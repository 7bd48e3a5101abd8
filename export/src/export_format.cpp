#include "tsf/export/export_format.h"

#include <algorithm>
#include <cctype>

#include "tsf/common/error.h"

namespace tsf::exporter {

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string format_names() {
  std::string names;
  for (const auto& f : export_formats()) names += std::string(names.empty() ? "" : ", ") + f.name;
  return names;
}

std::string extensions() {
  std::string out;
  for (const auto& f : export_formats())
    if (out.find(f.extension) == std::string::npos)
      out += std::string(out.empty() ? "" : ", ") + f.extension;
  return out;
}

}  // namespace

const std::vector<ExportFormatInfo>& export_formats() {
  using F = ExportFormat;
  using U = LengthUnit;
  using A = AxisConvention;
  // clang-format off
  static const std::vector<ExportFormatInfo> formats = {
    {F::glb, "glb", ".glb", "glb2", "binary glTF 2.0 (metres, +Y up); sequences as morph-target animation",
     true, true, true, true, true, true, true, U::metre, A::y_up},
    {F::gltf, "gltf", ".gltf", "gltf2", "glTF 2.0 JSON with the buffer embedded (metres, +Y up)",
     true, true, true, true, true, true, true, U::metre, A::y_up},
    {F::obj, "obj", ".obj", "obj", "Wavefront OBJ with vertex colours and a .mtl beside it",
     true, true, true, true, false, false, false, U::millimetre, A::y_up},
    {F::stl, "stl", ".stl", "stlb", "binary STL (triangles and face normals only)",
     false, false, false, false, false, false, false, U::millimetre, A::lps},
    {F::stl_ascii, "stl-ascii", ".stl", "stl", "ASCII STL",
     false, false, false, false, false, false, false, U::millimetre, A::lps},
    {F::ply, "ply", ".ply", "plyb", "binary PLY with normals and vertex colours",
     true, true, false, false, false, false, false, U::millimetre, A::lps},
    {F::ply_ascii, "ply-ascii", ".ply", "ply", "ASCII PLY",
     true, true, false, false, false, false, false, U::millimetre, A::lps},
    {F::fbx, "fbx", ".fbx", "fbx", "binary FBX 7.5 (+Y up; unit scale recorded)",
     true, true, true, true, false, false, true, U::millimetre, A::y_up},
    {F::fbx_ascii, "fbx-ascii", ".fbx", "fbxa", "ASCII FBX 7.5 (not read by Blender)",
     true, true, true, true, false, false, true, U::millimetre, A::y_up},
  };
  // clang-format on
  return formats;
}

const ExportFormatInfo& format_info(ExportFormat format) {
  for (const auto& f : export_formats())
    if (f.format == format) return f;
  throw Error("unknown export format value " + std::to_string(static_cast<int>(format)));
}

ExportFormat format_from_name(const std::string& name) {
  const std::string n = lower(name);
  for (const auto& f : export_formats())
    if (n == f.name) return f.format;
  throw Error("unknown export format '" + name + "' (expected one of: " + format_names() + ")");
}

ExportFormat format_from_path(const std::filesystem::path& path) {
  const std::string ext = lower(path.extension().string());
  for (const auto& f : export_formats())
    if (ext == f.extension) return f.format;
  throw Error("output '" + path.string() + "': unknown extension '" + ext +
              "' (supported: " + extensions() + "; or name one with --format)");
}

void require_extension_matches(const std::filesystem::path& path, ExportFormat format) {
  const ExportFormatInfo& f = format_info(format);
  const std::string ext = lower(path.extension().string());
  require(ext == f.extension, "output '" + path.string() + "' has extension '" + ext +
                                  "' but format '" + f.name + "' writes '" + f.extension +
                                  "' files");
}

const char* unit_name(LengthUnit unit) {
  return unit == LengthUnit::metre ? "m" : "mm";
}

LengthUnit unit_from_name(const std::string& name) {
  const std::string n = lower(name);
  if (n == "mm") return LengthUnit::millimetre;
  if (n == "m") return LengthUnit::metre;
  throw Error("unknown length unit '" + name + "' (expected mm or m)");
}

const char* axes_name(AxisConvention axes) {
  switch (axes) {
    case AxisConvention::y_up:
      return "y-up";
    case AxisConvention::lps:
      return "lps";
    case AxisConvention::ras:
      return "ras";
  }
  return "?";
}

AxisConvention axes_from_name(const std::string& name) {
  const std::string n = lower(name);
  if (n == "y-up" || n == "yup") return AxisConvention::y_up;
  if (n == "lps") return AxisConvention::lps;
  if (n == "ras") return AxisConvention::ras;
  throw Error("unknown axis convention '" + name + "' (expected y-up, lps or ras)");
}

}  // namespace tsf::exporter
