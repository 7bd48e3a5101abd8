// The file formats `tsf export` writes (through assimp), and what each can carry.
//
//   name       extension  assimp exporter  vertex colours  normals      materials  morph animation
//   glb        .glb       glb2             COLOR_0 (linear) yes         yes        yes
//   gltf       .gltf      gltf2            COLOR_0 (linear) yes         yes        yes (buffer
//   embedded) obj        .obj       obj (+ .mtl)     "v x y z r g b"  yes         .mtl       no stl
//   .stl       stlb (binary)    no               face only   no         no stl-ascii  .stl stl no
//   face only   no         no ply        .ply       plyb (binary)    uchar rgba       yes no no
//   ply-ascii  .ply       ply              uchar rgba       yes         no         no
//   fbx        .fbx       fbx (binary, repaired: fbx_binary.h)  yes    yes        yes        no
//   fbx-ascii  .fbx       fbxa             yes              yes         yes        no
// An extension picks the first format listed for it; --format picks any.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace tsf::exporter {

enum class ExportFormat { glb, gltf, obj, stl, stl_ascii, ply, ply_ascii, fbx, fbx_ascii };

/// Lengths in the written file.
enum class LengthUnit { millimetre, metre };

/// How the patient frame (LPS) maps onto the file's x, y, z (output_frame.h).
enum class AxisConvention {
  y_up,  ///< x = patient left, y = superior, z = anterior (glTF and FBX convention: +Y up,
         ///< the patient faces +Z, right-handed)
  lps,   ///< x = left, y = posterior, z = superior (DICOM / ITK patient frame, as is)
  ras,   ///< x = right, y = anterior, z = superior (3D Slicer, FreeSurfer, NIfTI scanner frame)
};

struct ExportFormatInfo {
  ExportFormat format;
  const char* name;         ///< --format value
  const char* extension;    ///< with the dot, lower case
  const char* assimp_id;    ///< assimp exporter id
  const char* description;  ///< one line for --help
  bool vertex_colours;      ///< the file stores a colour per vertex
  bool vertex_normals;      ///< the file stores a normal per vertex (STL: per face only)
  bool materials;           ///< named materials
  bool multiple_meshes;     ///< can hold one mesh per tissue (--split-labels)
  bool morph_animation;     ///< a sequence can be one animated file (glTF morph targets)
  bool fixed_units;         ///< units fixed by the format's specification (glTF: metres)
  bool fixed_axes;          ///< axes fixed by the format (glTF spec, FBX header assimp writes)
  LengthUnit default_units;
  AxisConvention default_axes;
};

/// Every format, in the order of the table above.
const std::vector<ExportFormatInfo>& export_formats();
const ExportFormatInfo& format_info(ExportFormat format);

/// The format named `name` (--format value, case-insensitive). Throws tsf::Error listing the names.
ExportFormat format_from_name(const std::string& name);
/// The default format for `path`'s extension (case-insensitive). Throws tsf::Error naming the
/// extension and listing the supported ones.
ExportFormat format_from_path(const std::filesystem::path& path);
/// Throws tsf::Error when `path`'s extension is not `format`'s (e.g. out.glb with --format obj).
void require_extension_matches(const std::filesystem::path& path, ExportFormat format);

const char* unit_name(LengthUnit unit);              ///< "mm", "m"
LengthUnit unit_from_name(const std::string& name);  ///< "mm" | "m"; throws tsf::Error otherwise
const char* axes_name(AxisConvention axes);          ///< "y-up", "lps", "ras"
AxisConvention axes_from_name(const std::string& name);  ///< throws tsf::Error otherwise

}  // namespace tsf::exporter
