// Triangle quality of a mesh: what vertex merging buys (fewer slivers) and what smoothing changes.
#pragma once

#include <cstddef>

#include "tsf/imt/surface_mesh.h"

namespace tsf::imt {

struct MeshQuality {
  std::size_t triangles = 0;
  std::size_t zero_area = 0;      ///< triangles with (numerically) no area
  std::size_t slivers = 0;        ///< smallest angle below the sliver threshold
  double min_angle_deg = 0;       ///< smallest angle of any non-degenerate triangle
  double mean_min_angle_deg = 0;  ///< mean over non-degenerate triangles of their smallest angle
  double mean_edge_length = 0;    ///< mm
  double area = 0;                ///< mm²
};

/// `sliver_angle_deg`: triangles whose smallest angle is below it count as slivers.
MeshQuality measure_quality(const SurfaceMesh& mesh, double sliver_angle_deg = 10.0);

}  // namespace tsf::imt
