// The stylus as the force models see it: a sphere of `radius_mm` sampled two ways.
//
//   voxel stylus   the centres of the n×n×n grid cells (edge 2r/n) that lie inside the sphere,
//                  as offsets from the stylus centre; each stands for one cell of volume (2r/n)³.
//                  The voxel model samples the tissue density at each (voxel_force.h).
//   sphere stylus  a coarser grid whose cells are replaced by the spheres that cover them (radius
//                  √3/2 of the edge, thesis §8.5.3), shrunk so that every sphere stays inside the
//                  stylus (cell 2r/(n + √3), centres within r − √3/2·cell): the mesh model tests
//                  these against triangles (mesh_force.h), so triangles wholly inside the stylus
//                  still count. n = 1 is the stylus sphere itself.
//
// offsets  #cells, mm, stylus-local (the pose's orientation is applied by the models)
#pragma once

#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::haptics {

struct SphereStylus {
  double radius_mm = 0;
  int resolution = 0;           ///< grid cells across the diameter
  double cell_mm = 0;           ///< grid cell edge, 2r/n
  double cell_volume_mm3 = 0;   ///< cell_mm³
  double volume_mm3 = 0;        ///< #cells × cell volume (the discrete stylus volume)
  double sphere_radius_mm = 0;  ///< sphere stylus: radius of each covering sphere, √3/2·cell
  std::vector<Vec3f> offsets;   ///< #cells, mm, cell centres relative to the stylus centre
};

/// The cells of an n³ grid over the sphere's bounding cube whose centres lie inside the sphere.
/// Throws tsf::Error when radius ≤ 0 or not finite, or resolution is outside [1, 128].
SphereStylus make_sphere_stylus(double radius_mm, int resolution);

/// The covering spheres of a sphere of `radius_mm`, `resolution` spheres across (mesh model).
/// Throws tsf::Error like make_sphere_stylus.
SphereStylus make_sphere_set(double radius_mm, int resolution);

/// Exact sphere volume 4/3·π·r³, mm³.
double sphere_volume(double radius_mm);

/// A stylus pose in the deformed world (tissue space as it looks now, mm).
using StylusPose = ToolPose;

}  // namespace tsf::haptics
