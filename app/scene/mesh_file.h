// Triangle meshes from files, for tools made from a mesh (`tools: [{shape: mesh, file: …}]`): the
// tissue core reads no files, so the app reads them here and hands the core vertices and
// triangles (interaction::ToolMesh turns them into a signed-distance grid).
//
//   OBJ   `v x y z` and `f a b c …` lines (polygons are fanned into triangles; `a/b/c` index forms
//         and negative indices are read; everything else is ignored)
//   STL   binary or ASCII (each facet's corners; corners at the same position are welded)
//   PLY   ASCII, binary little or big endian; `vertex` x, y, z of any numeric type and a `face`
//         list of indices (polygons fanned); other elements and properties are skipped
// Bounds (checked before anything is sized from the file): at most 4 M vertices and 4 M
// triangles; every coordinate finite and within ±10⁵ mm. Errors name the file, the line or the
// element and what was expected.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

#include "tsf/common/vec3.h"

namespace tsf::app {

struct MeshFile {
  std::vector<Vec3f> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

/// Reads an OBJ, STL or PLY file (by extension, case-insensitive), scaled by `scale` (mm per file
/// unit). Throws tsf::Error "FILE: what is wrong".
MeshFile read_mesh_file(const std::filesystem::path& path, double scale = 1.0);

}  // namespace tsf::app
