// Edits of the voxel volume (R1): ablation by a sphere or capsule, a cut by a blade swept between
// two poses, and setting a box. Tools are in tissue space (mm).
//
// Ablation and cutting lower density: removal = strength · rate(label) · falloff_weight(d), with d
// the signed distance from the tool surface, new density = max(0, old − removal). A voxel's label
// picks its rate (cartilage ablates slower than mucosa); labels are never changed by removal.
// At strength 1 on solid tissue of rate 1 the 0.5 iso-level lands on the tool surface.
//
// Every edit writes through VoxelVolume::density_for_tracked_write(), calls mark_modified() on
// what it wrote and returns the box of voxels whose density or label actually changed (empty if
// none): hand that box to ImtSurface::update().
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "tsf/volume/tissue_labels.h"
#include "tsf/volume/tool_shapes.h"
#include "tsf/volume/voxel_box.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf {

/// Removal rate per tissue label, a multiplier in [0, 1] of the tool strength. Scenes set them
/// per label (`tissue.removal.rates`, docs/deform-cut.md), from the material library's
/// `removal_rates` or by value.
struct LabelRates {
  std::array<float, 256> rate{};

  float operator[](std::uint8_t label) const { return rate[label]; }
  /// Every label at `r` (label 0, outside, too: there is nothing to remove there anyway).
  static LabelRates uniform(float r);
  /// Defaults for sinus surgery: soft tissue, mucosa, fat, tumour 1; vessel and nerve 0.8;
  /// cartilage 0.35; cancellous bone 0.15; cortical bone 0.05; user labels 1. Scenes may override.
  static LabelRates tissue_defaults();
};

struct RemovalOptions {
  float strength = 1.0f;     ///< fraction of full density removed at weight 1 and rate 1, [0,1]
  double falloff_mm = -1.0;  ///< half-width of the smooth edge (mm); < 0: one voxel (min spacing)
  LabelRates rates = LabelRates::uniform(1.0f);
};

/// Lowers density inside a sphere. Returns the changed voxels.
VoxelBox ablate_sphere(VoxelVolume& volume, const SphereTool& sphere,
                       const RemovalOptions& options = {});

/// Lowers density inside a capsule (a wand swept along a segment). Returns the changed voxels.
VoxelBox ablate_capsule(VoxelVolume& volume, const CapsuleTool& capsule,
                        const RemovalOptions& options = {});

/// Cuts the slab swept by a blade moving from pose `from` to pose `to` (position interpolated
/// linearly, orientation by slerp, sub-steps so no blade point moves more than half a voxel
/// between samples). Each voxel is removed once with the largest weight any sub-step gives it.
/// Returns the changed voxels.
VoxelBox cut_swept_blade(VoxelVolume& volume, const BladeTool& blade, const ToolPose& from,
                         const ToolPose& to, const RemovalOptions& options = {});

/// Sets density (and, when given, the label) of every voxel whose centre lies in the tissue-space
/// box [lo_mm, hi_mm]. `density` must lie in [0,1]. Returns the changed voxels.
VoxelBox set_box(VoxelVolume& volume, const Vec3d& lo_mm, const Vec3d& hi_mm, float density,
                 std::optional<std::uint8_t> label = std::nullopt);

/// Labels as `label` every voxel holding tissue (density > 0) whose centre lies in the tissue-space
/// box [lo_mm, hi_mm]; densities stay. Returns the relabelled voxels.
VoxelBox label_box(VoxelVolume& volume, const Vec3d& lo_mm, const Vec3d& hi_mm, std::uint8_t label);
/// The same for the voxels whose centres lie within a capsule (a vessel's or a nerve's course).
VoxelBox label_capsule(VoxelVolume& volume, const CapsuleTool& capsule, std::uint8_t label);

/// Sets density 0 in every voxel of `boxes` (each clipped to the volume); labels stay. Returns
/// the bounding box of the voxels that changed (empty when none held tissue).
VoxelBox clear_voxels(VoxelVolume& volume, const std::vector<VoxelBox>& boxes);

/// The voxels whose centres may lie within `margin_mm` of the tissue-space box [lo_mm, hi_mm],
/// clipped to the volume (empty when outside).
VoxelBox voxels_near_box(const VolumeGeometry& geometry, const Vec3d& lo_mm, const Vec3d& hi_mm,
                         double margin_mm);

}  // namespace tsf
