// Splitting a surface into one mesh per tissue (--split-labels).
//
// Each triangle belongs to exactly one part, the part of imt::triangle_label (the label shared by
// at least two of its vertices, else the smallest), so the parts partition the triangles: their
// union is the whole surface and no triangle is in two parts. Vertices on a border between
// tissues are duplicated into every part that uses them.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "tsf/imt/surface_mesh.h"

namespace tsf::exporter {

struct LabelPart {
  std::uint8_t label = 0;                   ///< triangle label of every triangle in the part
  std::vector<std::uint32_t> vertices;      ///< part vertex i is mesh vertex vertices[i]
  std::vector<std::uint32_t> triangle_ids;  ///< the mesh triangles of the part, ascending
  std::vector<std::array<std::uint32_t, 3>> triangles;  ///< re-indexed into `vertices`
};

/// One part per triangle label present, in ascending label order.
std::vector<LabelPart> partition_by_label(const imt::SurfaceMesh& mesh);

/// The whole mesh as one part (identity vertex map); `label` names it.
LabelPart whole_mesh_part(const imt::SurfaceMesh& mesh, std::uint8_t label);

}  // namespace tsf::exporter
