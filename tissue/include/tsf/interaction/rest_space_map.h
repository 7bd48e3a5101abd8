// From the deformed world back to rest space: the inverse of the coupler's trilinear deformation,
// so a tool placed on the tissue as it looks now edits the voxels that are there now.
//
// For a point x: the nearest gathered deformed node seeds the search; each cube having that node
// as a corner is tried with Newton's method on the cube's trilinear map φ(w) = x (corners from
// the coupler's resolver, with the cube's sources restricted to the seed node's piece, so a
// point on one side of a cut maps into that side); w inside [0,1]³ accepts the cube. Otherwise
// the search walks to the neighbouring cube that w points to (a few steps), and a point outside
// every cube (a tool tip in the air beside the tissue) keeps the nearest cube's extrapolation
// (w clamped to [−1, 2]). The result carries the deformation gradient F = ∂x/∂p there, which
// maps tool orientations (blades) back to rest space.
#pragma once

#include <array>
#include <cstdint>

#include "tsf/collision/node_neighbourhood.h"
#include "tsf/coupler/vertex_binder.h"
#include "tsf/crms/lattice.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::interaction {

struct RestPoint {
  Vec3d rest{0, 0, 0};           ///< mm, tissue (rest) space
  bool found = false;            ///< a node was gathered near the point
  bool inside_cube = false;      ///< converged inside a cube (not extrapolated)
  double residual_mm = 0.0;      ///< |φ(rest) − x| of the chosen cube
  double nearest_node_mm = 0.0;  ///< distance from x to the seed node, mm
  std::int64_t cell = -1;        ///< the cube used (lower corner node)
  std::array<double, 9> gradient{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< F, row-major
};

/// Maps x (deformed world, mm) to rest space using the nodes in `neighbourhood` (which must
/// cover the point and the cubes around it) and the lattice topology (`binder`).
RestPoint map_to_rest(const collision::NodeNeighbourhood& neighbourhood,
                      coupler::VertexBinder& binder, const crms::LatticeGeometry& geometry,
                      const Vec3d& x);

/// A tool orientation in the deformed world mapped to rest space at a point with gradient F:
/// the rest frame whose image under F is closest to the world frame (F⁻¹·R, orthonormalised
/// along the tool's x axis first, then y).
Rotation rest_orientation(const Rotation& world, const std::array<double, 9>& gradient);

}  // namespace tsf::interaction
