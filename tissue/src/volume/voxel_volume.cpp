#include "tsf/volume/voxel_volume.h"

#include <algorithm>
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

bool VolumeGeometry::mirrors() const {
  const auto& m = direction;
  return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
             m[2] * (m[3] * m[7] - m[4] * m[6]) <
         0.0;
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
  const int b = kBrickSize;
  brick_dims_ = {(geometry.dims.x + b - 1) / b, (geometry.dims.y + b - 1) / b,
                 (geometry.dims.z + b - 1) / b};
  const auto brick_count = static_cast<std::size_t>(brick_dims_.volume());
  brick_ranges_.assign(brick_count, BrickRange{0.0f, 0.0f});  // every density starts at 0
  brick_stamps_.assign(brick_count, 0);
}

VoxelBox VoxelVolume::brick_box(int bi, int bj, int bk) const {
  const int b = kBrickSize;
  const VoxelBox box{{bi * b, bj * b, bk * b}, {(bi + 1) * b, (bj + 1) * b, (bk + 1) * b}};
  return box.intersected(VoxelBox::of_dims(geometry_.dims));
}

VoxelVolume::BrickRange VoxelVolume::compute_brick_range(int bi, int bj, int bk) const {
  const VoxelBox box = brick_box(bi, bj, bk);
  const int width = box.hi.x - box.lo.x;
  if (width == kBrickSize) {
    // Full-width rows: eight running minima and maxima, one per column (vectorises).
    float lo[kBrickSize], hi[kBrickSize];
    const float* first = density_.data() + index(box.lo.x, box.lo.y, box.lo.z);
    for (int i = 0; i < kBrickSize; ++i) lo[i] = hi[i] = first[i];
    for (int k = box.lo.z; k < box.hi.z; ++k)
      for (int j = box.lo.y; j < box.hi.y; ++j) {
        const float* row = density_.data() + index(box.lo.x, j, k);
        for (int i = 0; i < kBrickSize; ++i) {
          lo[i] = row[i] < lo[i] ? row[i] : lo[i];
          hi[i] = row[i] > hi[i] ? row[i] : hi[i];
        }
      }
    BrickRange r{lo[0], hi[0]};
    for (int i = 1; i < kBrickSize; ++i) {
      r.min = std::min(r.min, lo[i]);
      r.max = std::max(r.max, hi[i]);
    }
    return r;
  }
  BrickRange r{density_[index(box.lo.x, box.lo.y, box.lo.z)],
               density_[index(box.lo.x, box.lo.y, box.lo.z)]};
  for (int k = box.lo.z; k < box.hi.z; ++k)
    for (int j = box.lo.y; j < box.hi.y; ++j) {
      const float* row = density_.data() + index(0, j, k);
      for (int i = box.lo.x; i < box.hi.x; ++i) {
        r.min = std::min(r.min, row[i]);
        r.max = std::max(r.max, row[i]);
      }
    }
  return r;
}

void VoxelVolume::mark_modified(const VoxelBox& box) {
  const VoxelBox clipped = box.intersected(VoxelBox::of_dims(geometry_.dims));
  if (clipped.empty()) return;
  ++modification_count_;
  const int b = kBrickSize;
  for (int bk = clipped.lo.z / b; bk <= (clipped.hi.z - 1) / b; ++bk)
    for (int bj = clipped.lo.y / b; bj <= (clipped.hi.y - 1) / b; ++bj)
      for (int bi = clipped.lo.x / b; bi <= (clipped.hi.x - 1) / b; ++bi) {
        recompute_brick_range(bi, bj, bk);
        brick_stamps_[brick_index(bi, bj, bk)] = modification_count_;
      }
}

void VoxelVolume::mark_all_modified() {
  ++modification_count_;
  const std::int64_t n = brick_dims_.volume();
  const int bx = brick_dims_.x, by = brick_dims_.y;
#pragma omp parallel for schedule(dynamic, 16) if (n >= 512)
  for (std::int64_t b = 0; b < n; ++b) {
    const int bi = static_cast<int>(b % bx);
    const int bj = static_cast<int>((b / bx) % by);
    const int bk = static_cast<int>(b / (static_cast<std::int64_t>(bx) * by));
    recompute_brick_range(bi, bj, bk);
    brick_stamps_[static_cast<std::size_t>(b)] = modification_count_;
  }
  ranges_current_ = true;
}

std::vector<std::size_t> VoxelVolume::bricks_modified_since(std::uint64_t stamp) const {
  std::vector<std::size_t> out;
  for (std::size_t b = 0; b < brick_stamps_.size(); ++b)
    if (brick_stamps_[b] > stamp) out.push_back(b);
  return out;
}

VoxelBox VoxelVolume::modified_since(std::uint64_t stamp) const {
  VoxelBox out{};
  for (int bk = 0; bk < brick_dims_.z; ++bk)
    for (int bj = 0; bj < brick_dims_.y; ++bj)
      for (int bi = 0; bi < brick_dims_.x; ++bi)
        if (brick_stamps_[brick_index(bi, bj, bk)] > stamp) out = out.united(brick_box(bi, bj, bk));
  return out;
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
