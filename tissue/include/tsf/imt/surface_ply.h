// Binary PLY (little endian) for surface meshes, until the export module (assimp) takes over.
//
// Vertex properties: float x y z (mm, tissue space), float nx ny nz (when the mesh has normals),
// uchar red green blue (a colour per tissue label, so viewers show tissues apart), uchar label.
// Faces: uchar count (3), int vertex_indices. Writes are atomic (temporary file, then rename).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>

#include "tsf/imt/surface_mesh.h"

namespace tsf::imt {

/// Writes `mesh` (validated first) to `path`; throws tsf::Error naming the file on failure and
/// leaves no partial file.
void write_surface_ply(const std::filesystem::path& path, const SurfaceMesh& mesh);

/// Reads a binary little-endian PLY with at least float x y z and triangle faces (as written by
/// write_surface_ply; normals and label are read when present). Throws tsf::Error naming the
/// file and what is wrong.
SurfaceMesh read_surface_ply(const std::filesystem::path& path);

/// Display colour of a tissue label (RGB).
std::array<std::uint8_t, 3> label_colour(std::uint8_t label);

}  // namespace tsf::imt
