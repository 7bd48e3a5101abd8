// One tissue instance pushing another (one way: the stiffer body pushes, the pushed tissue does
// not push back): mucosa resting on bone, pushed by it when the bone moves. The pushing body is a
// contact field (collision::DistanceField) of the pushed tissue's TissueModel (set_pushers), and
// takes part in its every contact pass like a pressing tool: nodes of the pushed lattice that
// enter the body are moved to its surface and held there while they press against it.
//
// The body is its rest surface as a signed-distance grid (collision/distance_grid.h, built once,
// and again after an edit changed the body's surface) carried by its lattice's deformation: a
// world point p is mapped into the body's rest space through its lattice (coupler/local_warp.h:
// X + u(X) = p), the grid is read at X, and the normal is mapped back by F⁻ᵀ. The body's motion is
// carried two node layers beyond its alive nodes (empty nodes take their filled neighbours' mean
// displacement), so what lies against a moving body is pushed with it; farther away the body is
// taken at rest.
//
// The pushed tissue's surface does not lie at its nodes: an outer node sits up to half a spacing
// inside or outside it. Each node keeps the distance from the body at which its own surface
// (along the body's normal, where the tissue's density crosses the iso-level) touches the body,
// so the tissue's surface, not its nodes, rests on the body. Bodies that overlap at rest (two
// instances segmented from one CT share their boundary voxels) keep their overlap: a node that lay
// closer at rest keeps that distance (allowance_mm), so the first step does not kick the tissue
// off the bone.
//
// Threading: the owner thread of both models (follow() between advance() calls).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "tsf/collision/distance_grid.h"
#include "tsf/collision/world_tool.h"
#include "tsf/coupler/local_warp.h"

namespace tsf::interaction {

class TissueModel;

class BodyField final : public collision::DistanceField {
 public:
  /// The body's current surface, in its rest space, sampled every `spacing_mm` (> 0). Throws
  /// tsf::Error when the body's surface is not closed or the grid would be too large.
  BodyField(const TissueModel& body, double spacing_mm);

  /// Follows the body's deformation now (its lattice positions), and rebuilds the grid when an
  /// edit changed its surface since the last call.
  void follow(const TissueModel& body);
  /// Records for each node of the pushed tissue the distance it keeps from the body: where its
  /// own surface touches the body, or less where it lay closer at rest (call once, with the body
  /// as it is now, before the pushed tissue steps).
  void set_rest_allowance(const TissueModel& pushed);

  double distance(const Vec3d& p, Vec3d& normal) const override;
  void bounds(Vec3d& lo, Vec3d& hi) const override;
  double allowance_mm(std::int64_t node) const override {
    return node >= 0 && static_cast<std::size_t>(node) < allowance_.size()
               ? static_cast<double>(allowance_[static_cast<std::size_t>(node)])
               : 0.0;
  }
  bool keeps_vertices_out() const override { return false; }

  const collision::SignedDistanceGrid& grid() const { return *grid_; }
  /// Nodes of the pushed tissue that lay closer to the body at rest than their surface allows.
  std::size_t nodes_overlapping_at_rest() const { return overlapping_; }

 private:
  void build_grid(const TissueModel& body);
  static constexpr int kDilation = 2;  ///< node layers the motion is carried beyond the body

  double spacing_mm_;
  std::shared_ptr<collision::SignedDistanceGrid> grid_;
  std::size_t edits_seen_ = 0;
  std::vector<Vec3f> displacement_;
  std::vector<std::uint8_t> alive_;
  coupler::LatticeWindowView view_;
  double max_displacement_ = 0;
  std::vector<float> allowance_;
  std::size_t overlapping_ = 0;
};

}  // namespace tsf::interaction
