#include "tsf/volume/voxel_volume.h"

#include <cmath>
#include <string>

#include "tsf/common/error.h"

namespace tsf {

Vec3d VolumeGeometry::index_to_physical(const Vec3d& ijk) const {
  const Vec3d s{ijk.x * spacing.x, ijk.y * spacing.y, ijk.z * spacing.z};
  const auto& d = direction;
  return {origin.x + d[0] * s.x + d[1] * s.y + d[2] * s.z,
          origin.y + d[3] * s.x + d[4] * s.y + d[5] * s.z,
          origin.z + d[6] * s.x + d[7] * s.y + d[8] * s.z};
}

Vec3d VolumeGeometry::physical_to_index(const Vec3d& p) const {
  // direction is orthonormal for medical images: its inverse is its transpose.
  const Vec3d r = p - origin;
  const auto& d = direction;
  const Vec3d s{d[0] * r.x + d[3] * r.y + d[6] * r.z, d[1] * r.x + d[4] * r.y + d[7] * r.z,
                d[2] * r.x + d[5] * r.y + d[8] * r.z};
  return {s.x / spacing.x, s.y / spacing.y, s.z / spacing.z};
}

bool VolumeGeometry::identity_direction() const {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      if (std::abs(direction[r * 3 + c] - (r == c ? 1.0 : 0.0)) > 1e-9) return false;
  return true;
}

VoxelVolume::VoxelVolume(const VolumeGeometry& geometry, bool with_material_weights)
    : geometry_(geometry) {
  require(geometry.dims.x > 0 && geometry.dims.y > 0 && geometry.dims.z > 0,
          "voxel volume dimensions must be positive, got " + std::to_string(geometry.dims.x) + "x" +
              std::to_string(geometry.dims.y) + "x" + std::to_string(geometry.dims.z));
  require(geometry.spacing.x > 0 && geometry.spacing.y > 0 && geometry.spacing.z > 0,
          "voxel spacing must be positive (mm)");
  const std::size_t n = geometry.voxel_count();
  density_.assign(n, 0.0f);
  labels_.assign(n, 0);
  if (with_material_weights) weights_.assign(n, {255, 0, 0, 0});
}

void VoxelVolume::validate() const {
  const std::size_t n = voxel_count();
  require(density_.size() == n, "density has " + std::to_string(density_.size()) +
                                    " values, expected " + std::to_string(n));
  require(labels_.size() == n, "labels have " + std::to_string(labels_.size()) +
                                   " values, expected " + std::to_string(n));
  require(weights_.empty() || weights_.size() == n,
          "material weights have " + std::to_string(weights_.size()) + " values, expected " +
              std::to_string(n) + " or none");
  for (std::size_t v = 0; v < n; ++v) {
    const float d = density_[v];
    if (!(d >= 0.0f && d <= 1.0f))
      throw Error("density at voxel " + std::to_string(v) + " is " + std::to_string(d) +
                  ", expected a value in [0,1]");
  }
}

}  // namespace tsf
