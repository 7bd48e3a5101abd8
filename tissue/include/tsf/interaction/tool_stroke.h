// One stroke of an ablating or cutting tool, in rest space: consecutive moves of the same tool in
// the same mode. Each voxel loses density once, with the largest strength-scaled fall-off weight
// the stroke has given it so far (removal = rate(label) · (s·w − (s·w)_already_applied), s the
// move's strength: force-dependent ablation scales it per move, docs/deform-cut.md), so
//   * a ball or wand dragged through tissue carves one smooth channel (moves overlap at their
//     shared pose; applying each move on its own would lower the fall-off band twice there and
//     widen the channel by up to the band's width);
//   * a stroke removes exactly the tool's swept volume (AblationVolume tests: within 2 %).
// Within one move the tool is swept continuously: a ball from a to b is the capsule a–b; a wand
// and a blade are sampled so no point of them moves more than half a voxel between samples
// (volume_edits.h's rule for blades). The memory holds the weights of voxels the stroke touched
// and is dropped by end() (the tool lifted, or a new stroke).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <unordered_map>

#include "tsf/volume/tool_shapes.h"
#include "tsf/volume/volume_edits.h"
#include "tsf/volume/voxel_box.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::interaction {

class ToolStroke {
 public:
  /// Ends the stroke: the next move starts a fresh one.
  void end() { applied_.clear(); }
  std::size_t voxels_remembered() const { return applied_.size(); }
  /// Per tissue label, the density the last move would have removed at rate 1 (Σ over its
  /// voxels of min(density, s·w − already applied)): with the density it did remove, the
  /// effective rate of each label (removed / reached).
  const std::array<double, 256>& last_reached() const { return reached_; }

  /// A ball of `radius` moving from `from` to `to` (mm). Returns the changed voxels.
  VoxelBox ablate_ball(VoxelVolume& volume, const Vec3d& from, const Vec3d& to, double radius,
                       const RemovalOptions& options);
  /// A capsule (wand) moving from one placement to another.
  VoxelBox ablate_wand(VoxelVolume& volume, const CapsuleTool& from, const CapsuleTool& to,
                       const RemovalOptions& options);
  /// A blade moving between two poses (position linear, orientation slerp).
  VoxelBox cut_blade(VoxelVolume& volume, const BladeTool& blade, const ToolPose& from,
                     const ToolPose& to, const RemovalOptions& options);

 private:
  /// Applies weights w(i,j,k) ∈ [0,1] over `box` with the stroke's memory.
  template <typename Weight>
  VoxelBox apply(VoxelVolume& volume, const VoxelBox& box, const RemovalOptions& options,
                 const Weight& weight);

  std::unordered_map<std::size_t, float> applied_;
  std::array<double, 256> reached_{};
};

}  // namespace tsf::interaction
