// An axis-aligned box of voxel indices, half-open: voxel (i,j,k) is inside when lo <= ijk < hi
// on every axis. Edits report the box of voxels they changed; the surface re-meshes from it.
#pragma once

#include <algorithm>
#include <cstdint>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"

namespace tsf {

struct VoxelBox {
  Int3 lo;  ///< first voxel index on each axis
  Int3 hi;  ///< one past the last voxel index on each axis

  TSF_HD_INLINE bool empty() const { return hi.x <= lo.x || hi.y <= lo.y || hi.z <= lo.z; }
  TSF_HD_INLINE Int3 extent() const {
    return empty() ? Int3{0, 0, 0} : Int3{hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
  }
  TSF_HD_INLINE std::int64_t voxel_count() const { return extent().volume(); }
  TSF_HD_INLINE bool contains(int i, int j, int k) const {
    return i >= lo.x && j >= lo.y && k >= lo.z && i < hi.x && j < hi.y && k < hi.z;
  }
  bool operator==(const VoxelBox& o) const {
    return (empty() && o.empty()) || (lo == o.lo && hi == o.hi);
  }
  bool operator!=(const VoxelBox& o) const { return !(*this == o); }

  /// The whole grid of `dims` voxels.
  static VoxelBox of_dims(const Int3& dims) { return {{0, 0, 0}, dims}; }
  /// The single voxel (i,j,k).
  static VoxelBox of_voxel(int i, int j, int k) { return {{i, j, k}, {i + 1, j + 1, k + 1}}; }

  /// Grows the box by `lower` voxels below and `upper` above on every axis (no clamping).
  VoxelBox dilated(int lower, int upper) const {
    if (empty()) return *this;
    return {{lo.x - lower, lo.y - lower, lo.z - lower}, {hi.x + upper, hi.y + upper, hi.z + upper}};
  }
  VoxelBox dilated(int by) const { return dilated(by, by); }
  VoxelBox intersected(const VoxelBox& o) const {
    return {{std::max(lo.x, o.lo.x), std::max(lo.y, o.lo.y), std::max(lo.z, o.lo.z)},
            {std::min(hi.x, o.hi.x), std::min(hi.y, o.hi.y), std::min(hi.z, o.hi.z)}};
  }
  /// Smallest box holding both (an empty box is the identity).
  VoxelBox united(const VoxelBox& o) const {
    if (empty()) return o;
    if (o.empty()) return *this;
    return {{std::min(lo.x, o.lo.x), std::min(lo.y, o.lo.y), std::min(lo.z, o.lo.z)},
            {std::max(hi.x, o.hi.x), std::max(hi.y, o.hi.y), std::max(hi.z, o.hi.z)}};
  }
  /// Adds voxel (i,j,k) to the box.
  void include(int i, int j, int k) { *this = united(of_voxel(i, j, k)); }
};

}  // namespace tsf
