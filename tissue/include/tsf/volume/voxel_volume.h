// R1: the voxel volume, the high-resolution representation that cuts and ablation edit.
//
// Layout: x (i) fastest, then y (j), then z (k); index = i + nx*(j + ny*k).
//   density           #voxels floats in [0,1]; the tissue surface is its iso-level (0.5)
//   labels            #voxels uint8 TissueLabel values
//   material_weights  #voxels × 4 uint8 blend weights over the segment palette channels, summing
//                     to 255; empty when the volume carries none
// Geometry: spacing in mm, origin = physical position (LPS, mm) of voxel (0,0,0)'s centre,
// direction = 3×3 row-major matrix whose columns are the i, j, k axes in LPS.
//
// Bricks: the volume is tiled into bricks of kBrickSize³ voxels (the last ones on each axis may be
// smaller). Each brick keeps the min and max density of its voxels (empty-brick skipping for the
// surface and other consumers) and a modification stamp: every mark_modified() call advances the
// volume's modification counter and stamps the bricks it touched, so several consumers can each ask
// "what changed since the stamp I last saw" (bricks_modified_since).
// Writers keep the ranges current by reporting what they wrote: the edits in volume_edits.h do it
// themselves; code that writes through density_data() marks the ranges stale (the full surface
// recomputes them) unless it calls mark_all_modified() afterwards.
//
// Tissue space: every tissue representation (R1 voxels, R2 surface, R3 lattice, tools) works in
// an axis-aligned frame in mm, p = origin + (i·sx, j·sy, k·sz). The direction matrix is applied
// only where data leaves tissue/ (export, viewer slice planes): index_to_physical() does that.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/volume/voxel_box.h"

namespace tsf {

struct VolumeGeometry {
  Int3 dims;                     ///< voxels along i, j, k
  Vec3d spacing{1.0, 1.0, 1.0};  ///< mm
  Vec3d origin{0.0, 0.0, 0.0};   ///< mm, LPS position of voxel (0,0,0)'s centre
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< row-major, columns = axes

  std::size_t voxel_count() const { return static_cast<std::size_t>(dims.volume()); }
  /// Continuous index (i,j,k) -> physical LPS position in mm.
  Vec3d index_to_physical(const Vec3d& ijk) const;
  /// Continuous index -> tissue-space position in mm (axis-aligned; direction not applied).
  TSF_HD_INLINE Vec3d index_to_tissue(const Vec3d& ijk) const {
    return {origin.x + ijk.x * spacing.x, origin.y + ijk.y * spacing.y,
            origin.z + ijk.z * spacing.z};
  }
  /// Tissue-space position in mm -> continuous index.
  Vec3d tissue_to_index(const Vec3d& p) const {
    return {(p.x - origin.x) / spacing.x, (p.y - origin.y) / spacing.y,
            (p.z - origin.z) / spacing.z};
  }
  /// Physical LPS position in mm -> continuous index (inverse of index_to_physical).
  Vec3d physical_to_index(const Vec3d& p) const;
  /// Tissue-space position -> patient (LPS) mm: origin + D·(p − origin) (docs/design.md,
  /// "Frames").
  Vec3d tissue_to_patient(const Vec3d& p) const { return index_to_physical(tissue_to_index(p)); }
  /// A tissue-space direction (or normal: D is orthonormal) -> patient (LPS).
  Vec3d direction_to_patient(const Vec3d& v) const {
    const auto& d = direction;
    return {d[0] * v.x + d[1] * v.y + d[2] * v.z, d[3] * v.x + d[4] * v.y + d[5] * v.z,
            d[6] * v.x + d[7] * v.y + d[8] * v.z};
  }
  /// A patient (LPS) direction -> tissue space: Dᵀ·v.
  Vec3d direction_to_tissue(const Vec3d& v) const {
    const auto& d = direction;
    return {d[0] * v.x + d[3] * v.y + d[6] * v.z, d[1] * v.x + d[4] * v.y + d[7] * v.z,
            d[2] * v.x + d[5] * v.y + d[8] * v.z};
  }
  /// det(D) < 0: the voxel axes are a mirror image of L, P, S (tissue → patient mirrors).
  bool mirrors() const;
  bool identity_direction() const;
};

class VoxelVolume {
 public:
  VoxelVolume() = default;
  /// Allocates a volume of `geometry.dims` with every density 0 and label kLabelOutside.
  explicit VoxelVolume(const VolumeGeometry& geometry, bool with_material_weights = false);

  const VolumeGeometry& geometry() const { return geometry_; }
  const Int3& dims() const { return geometry_.dims; }
  std::size_t voxel_count() const { return geometry_.voxel_count(); }

  std::size_t index(int i, int j, int k) const {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(geometry_.dims.x) *
               (static_cast<std::size_t>(j) +
                static_cast<std::size_t>(geometry_.dims.y) * static_cast<std::size_t>(k));
  }
  bool contains(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < geometry_.dims.x && j < geometry_.dims.y &&
           k < geometry_.dims.z;
  }

  float density(int i, int j, int k) const { return density_[index(i, j, k)]; }
  std::uint8_t label(int i, int j, int k) const { return labels_[index(i, j, k)]; }

  /// Writable density. Calling it marks the brick ranges stale (brick_ranges_current() is false)
  /// until mark_all_modified(); prefer density_for_tracked_write() for local edits.
  std::vector<float>& density_data() {
    ranges_current_ = false;
    return density_;
  }
  const std::vector<float>& density_data() const { return density_; }
  std::vector<std::uint8_t>& label_data() { return labels_; }
  const std::vector<std::uint8_t>& label_data() const { return labels_; }
  bool has_material_weights() const { return !weights_.empty(); }
  std::vector<std::array<std::uint8_t, 4>>& material_weight_data() { return weights_; }
  const std::vector<std::array<std::uint8_t, 4>>& material_weight_data() const { return weights_; }

  // ---- bricks ---------------------------------------------------------------------------------
  static constexpr int kBrickSize = 8;  ///< voxels per brick edge
  struct BrickRange {
    float min = 0.0f;  ///< smallest density in the brick
    float max = 0.0f;  ///< largest density in the brick
  };
  /// Bricks along i, j, k: ceil(dims / kBrickSize).
  const Int3& brick_dims() const { return brick_dims_; }
  std::size_t brick_count() const { return brick_ranges_.size(); }
  std::size_t brick_index(int bi, int bj, int bk) const {
    return static_cast<std::size_t>(bi) +
           static_cast<std::size_t>(brick_dims_.x) *
               (static_cast<std::size_t>(bj) +
                static_cast<std::size_t>(brick_dims_.y) * static_cast<std::size_t>(bk));
  }
  /// The voxels of brick (bi,bj,bk), clipped to the volume.
  VoxelBox brick_box(int bi, int bj, int bk) const;
  /// The density range of brick (bi,bj,bk) computed from the data now (what mark_modified stores).
  BrickRange compute_brick_range(int bi, int bj, int bk) const;
  /// Density range of each brick (index brick_index()); meaningful when brick_ranges_current().
  const std::vector<BrickRange>& brick_ranges() const { return brick_ranges_; }
  /// False after density_data() handed out writable access, until mark_all_modified().
  bool brick_ranges_current() const { return ranges_current_; }
  /// Modification stamp of each brick: the value of modification_count() when it last changed.
  const std::vector<std::uint64_t>& brick_stamps() const { return brick_stamps_; }
  /// Number of mark_modified()/mark_all_modified() calls so far (0 for a fresh volume).
  std::uint64_t modification_count() const { return modification_count_; }

  /// Writable density for code that reports its writes: call mark_modified(box) with a box that
  /// covers every voxel written. Unlike density_data() it leaves the brick ranges current.
  float* density_for_tracked_write() { return density_.data(); }
  /// Writable labels for code that reports its writes through mark_modified(box).
  std::uint8_t* labels_for_tracked_write() { return labels_.data(); }

  /// Recomputes the ranges of the bricks overlapping `box` (clipped to the volume), advances the
  /// modification counter and stamps those bricks. Does nothing for an empty box.
  void mark_modified(const VoxelBox& box);
  /// Recomputes every brick range (OpenMP), stamps every brick, and makes the ranges current.
  void mark_all_modified();
  /// Bricks stamped after `stamp` (brick indices, ascending).
  std::vector<std::size_t> bricks_modified_since(std::uint64_t stamp) const;
  /// Bounding box of the voxels of the bricks stamped after `stamp` (empty when none).
  VoxelBox modified_since(std::uint64_t stamp) const;

  /// Checks sizes agree with the geometry and densities lie in [0,1] (finite);
  /// throws tsf::Error naming the first offending field and value.
  void validate() const;

 private:
  VolumeGeometry geometry_;
  std::vector<float> density_;
  std::vector<std::uint8_t> labels_;
  std::vector<std::array<std::uint8_t, 4>> weights_;
  Int3 brick_dims_;
  std::vector<BrickRange> brick_ranges_;
  std::vector<std::uint64_t> brick_stamps_;
  std::uint64_t modification_count_ = 0;
  bool ranges_current_ = true;

  void recompute_brick_range(int bi, int bj, int bk) {
    brick_ranges_[brick_index(bi, bj, bk)] = compute_brick_range(bi, bj, bk);
  }
};

}  // namespace tsf
