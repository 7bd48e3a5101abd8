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
#include <memory>
#include <vector>

#include "tsf/common/open_hash_map.h"
#include "tsf/volume/tool_shapes.h"
#include "tsf/volume/volume_edits.h"
#include "tsf/volume/voxel_box.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::interaction {

/// One sub-step of a blade sweep: the blade's pose and the voxels its world-axis box reaches.
struct BladeSweepStep {
  ToolPose pose;
  VoxelBox box;  ///< within the sweep's box
};

struct BladeSweepPlan;

/// Computes a blade sweep's weights somewhere other than the calling thread (the CUDA backend's
/// edits: make_cuda_blade_sweeper). Gives exactly what the host's sweep gives: weight[v] over the
/// voxels of the plan's box (x fastest) is falloff_weight(d, h) (0 at d >= h) of the blade's
/// smallest distance d from v over the sub-steps whose box holds v, each placed along its row
/// (BladeRowFrame from the row's voxel at the box's first x) and kept as a BladeDistanceMin:
/// the same IEEE operations (tool_shapes.h) in the same order, nothing contracted into FMA.
class BladeSweeper {
 public:
  virtual ~BladeSweeper() = default;
  virtual void sweep(const BladeSweepPlan& plan, const VolumeGeometry& geometry,
                     std::vector<float>& weight) = 0;
};

/// The blade sweep on the CUDA device (one thread per voxel of the swept box; the weights come
/// back to the host, where the stroke applies them). Throws tsf::Error, with the reason, where
/// CUDA is not built or there is no device.
std::unique_ptr<BladeSweeper> make_cuda_blade_sweeper();

/// A blade's move from one pose to another as its sweep runs it: the sub-steps (position linear,
/// orientation slerp, no point moving more than half a voxel between two), each with the voxels
/// its world-axis extent |R|·e reaches within the fall-off h, and their box: all that
/// ToolStroke::cut_blade() may change.
struct BladeSweepPlan {
  BladeTool blade{};
  std::vector<BladeSweepStep> steps;
  VoxelBox box{};
  double h = 0;             ///< fall-off half-width, mm
  std::int64_t visits = 0;  ///< Σ of the steps' voxels
};

/// Throws tsf::Error, naming what is wrong, for non-finite poses, negative extents or options
/// out of range (what cut_blade() throws for the same input).
BladeSweepPlan plan_blade_sweep(const VolumeGeometry& geometry, const BladeTool& blade,
                                const ToolPose& from, const ToolPose& to,
                                const RemovalOptions& options);

/// The weight a stroke has applied so far, per voxel index (0 where it has not reached yet).
using AppliedWeights = OpenHashMap<float>;

class ToolStroke {
 public:
  /// Ends the stroke: the next move starts a fresh one.
  void end() { applied_.clear(); }
  std::size_t voxels_remembered() const { return applied_.size(); }
  /// Per tissue label, the density the last move would have removed at rate 1 (Σ over its
  /// voxels of min(density, s·w − already applied)): with the density it did remove, the
  /// effective rate of each label (removed / reached).
  const std::array<double, 256>& last_reached() const { return reached_; }
  /// Seconds the last cut_blade() spent on its sweep's weights (before applying them).
  double last_sweep_seconds() const { return sweep_seconds_; }

  /// A ball of `radius` moving from `from` to `to` (mm). Returns the changed voxels.
  VoxelBox ablate_ball(VoxelVolume& volume, const Vec3d& from, const Vec3d& to, double radius,
                       const RemovalOptions& options);
  /// A capsule (wand) moving from one placement to another.
  VoxelBox ablate_wand(VoxelVolume& volume, const CapsuleTool& from, const CapsuleTool& to,
                       const RemovalOptions& options);
  /// A blade moving between two poses (position linear, orientation slerp). With a `sweeper` the
  /// weights of the sub-steps are computed there (the same weights, so the same edit).
  VoxelBox cut_blade(VoxelVolume& volume, const BladeTool& blade, const ToolPose& from,
                     const ToolPose& to, const RemovalOptions& options,
                     BladeSweeper* sweeper = nullptr);
  /// The same from its plan (plan_blade_sweep on this volume's geometry, with these options).
  VoxelBox cut_blade(VoxelVolume& volume, const BladeSweepPlan& plan, const RemovalOptions& options,
                     BladeSweeper* sweeper = nullptr);

 private:
  /// Applies weights w(i,j,k) ∈ [0,1] over `box` with the stroke's memory.
  template <typename Weight>
  VoxelBox apply(VoxelVolume& volume, const VoxelBox& box, const RemovalOptions& options,
                 const Weight& weight);

  AppliedWeights applied_;
  std::array<double, 256> reached_{};
  double sweep_seconds_ = 0;
};

}  // namespace tsf::interaction
