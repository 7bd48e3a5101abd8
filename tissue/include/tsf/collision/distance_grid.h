// A closed body as a signed-distance grid: how a tool read from a mesh file (an endoscope, a
// retractor; world_tool.h, ToolShape::kMesh, the grid in the tool's frame) presses the tissue, and
// how one tissue instance's surface pushes another (interaction/body_field.h, in its rest space).
//
// The grid samples the signed distance (mm, negative inside) of a closed triangle mesh at the
// points origin + (i, j, k)·spacing of its own frame, with a margin of empty space around the
// mesh. Between samples the distance is trilinear, and the normal is the normalised gradient of
// that interpolation; outside the grid the distance grows with the distance to the grid's box.
//
// Building it (from_closed_mesh):
//   1 check   the mesh is closed: every edge is shared by exactly two triangles (an open mesh
//             has no inside), the vertices are finite, the grid is not too large;
//   2 near    exact point–triangle distances at the samples within two spacings of each triangle;
//   3 far     the nearest surface point carried outward by sweeps over the grid (each sample
//             takes a neighbour's nearest point when it is nearer): Euclidean distances, not
//             chamfer steps;
//   4 sign    rays along x, y and z through every row of samples count the surface crossings
//             (odd: inside); each sample takes the majority of the three (a ray grazing an edge
//             miscounts on one axis, not on three).
// Cost: O(triangles × 5³ + samples) time and 28 bytes per sample while building, 4 bytes per
// sample kept.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "tsf/collision/world_tool.h"
#include "tsf/common/vec3.h"

namespace tsf::collision {

/// The first edge of `triangles` not shared by exactly two of them, described ("edge 3–7 is used
/// by 1 triangle"), or empty when the mesh is closed. Also rejects out-of-range indices.
std::string closed_mesh_problem(std::size_t vertex_count,
                                const std::vector<std::array<std::uint32_t, 3>>& triangles);

class SignedDistanceGrid {
 public:
  /// The most samples a grid may hold (64 MiB of floats).
  static constexpr std::int64_t kMaxSamples = std::int64_t{1} << 24;

  SignedDistanceGrid() = default;
  /// The signed distance of the closed mesh (vertices in mm, in the body's own frame) sampled
  /// every `spacing_mm`, with `margin_mm` (≥ 2 spacings is used at least) around its bounds.
  /// Throws tsf::Error naming what is wrong: an open or empty mesh, non-finite vertices, a grid
  /// of more than kMaxSamples samples (with the spacing that would fit), a mesh that encloses no
  /// sample (thinner than the spacing).
  static SignedDistanceGrid from_closed_mesh(
      const std::vector<Vec3f>& vertices,
      const std::vector<std::array<std::uint32_t, 3>>& triangles, double spacing_mm,
      double margin_mm);

  /// Signed distance at `p` (the body's frame, mm) and the outward unit normal there.
  double distance(const Vec3d& p, Vec3d& normal) const;
  /// The grid's box in the body's frame, mm (the body lies inside it with the margin).
  Vec3d lo() const { return origin_; }
  Vec3d hi() const;
  Int3 dims() const { return dims_; }
  double spacing() const { return spacing_; }
  /// Raw sample (i, j, k), mm.
  float sample(int i, int j, int k) const {
    return values_[static_cast<std::size_t>(i) +
                   static_cast<std::size_t>(dims_.x) *
                       (static_cast<std::size_t>(j) + static_cast<std::size_t>(dims_.y) * k)];
  }
  /// Volume inside the body, mm³ (samples with d < 0 times the sample cell): a check that the
  /// grid holds the mesh it was made from.
  double inside_volume_mm3() const;
  std::size_t bytes() const { return values_.size() * sizeof(float); }

 private:
  Int3 dims_{0, 0, 0};
  Vec3d origin_{0, 0, 0};
  double spacing_ = 1.0;
  std::vector<float> values_;
};

}  // namespace tsf::collision
