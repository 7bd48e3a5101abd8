// A compact triangle mesh: the IMT surface without free slots or the sentinel vertex, for export,
// tests and tools. Tissue space (axis-aligned, mm).
//   positions  #V, mm
//   normals    #V unit vectors pointing out of the tissue (toward lower density); a vertex whose
//              triangles have no area gets a zero normal; may be empty when not computed
//   labels     #V tissue label of the tissue the vertex bounds (tsf/volume/tissue_labels.h)
//   triangles  #T vertex indices, counter-clockwise seen from outside
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"

namespace tsf::imt {

struct SurfaceMesh {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;
  std::vector<std::uint8_t> labels;
  std::vector<std::array<std::uint32_t, 3>> triangles;

  std::size_t vertex_count() const { return positions.size(); }
  std::size_t triangle_count() const { return triangles.size(); }
};

/// A triangle's label: the label shared by at least two of its vertices, else the smallest of the
/// three. Every triangle gets exactly one label, so per-label meshes partition the surface.
std::uint8_t triangle_label(const SurfaceMesh& mesh, std::size_t triangle);

/// Labels that own at least one triangle, ascending.
std::vector<std::uint8_t> triangle_labels_present(const SurfaceMesh& mesh);

/// The triangles labelled `label` (triangle_label) with only the vertices they use, re-indexed.
SurfaceMesh extract_label(const SurfaceMesh& mesh, std::uint8_t label);

/// Each triangle with its own three vertices (no sharing): the unwelded marching output, kept for
/// comparisons. Normals become the face normals.
SurfaceMesh unweld(const SurfaceMesh& mesh);

/// Throws tsf::Error naming the first bad element: index out of range, non-finite position or
/// normal, array sizes that disagree.
void validate_mesh(const SurfaceMesh& mesh);

}  // namespace tsf::imt
