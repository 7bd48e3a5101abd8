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
// Tissue space: every tissue representation (R1 voxels, R2 surface, R3 lattice, tools) works in
// an axis-aligned frame in mm, p = origin + (i·sx, j·sy, k·sz). The direction matrix is applied
// only where data leaves tissue/ (export, viewer slice planes): index_to_physical() does that.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"

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
  Vec3d index_to_tissue(const Vec3d& ijk) const {
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

  std::vector<float>& density_data() { return density_; }
  const std::vector<float>& density_data() const { return density_; }
  std::vector<std::uint8_t>& label_data() { return labels_; }
  const std::vector<std::uint8_t>& label_data() const { return labels_; }
  bool has_material_weights() const { return !weights_.empty(); }
  std::vector<std::array<std::uint8_t, 4>>& material_weight_data() { return weights_; }
  const std::vector<std::array<std::uint8_t, 4>>& material_weight_data() const { return weights_; }

  /// Checks sizes agree with the geometry and densities lie in [0,1] (finite);
  /// throws tsf::Error naming the first offending field and value.
  void validate() const;

 private:
  VolumeGeometry geometry_;
  std::vector<float> density_;
  std::vector<std::uint8_t> labels_;
  std::vector<std::array<std::uint8_t, 4>> weights_;
};

}  // namespace tsf
