// Pieces shared by the full surfacing and the incremental surface. Private to tissue/src/imt.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/imt/bcc_lattice.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::imt::detail {

/// Owner cubes c ∈ [−1, n] per axis, stored at u = c + 1 ∈ [0, n + 2).
struct CubeGrid {
  Int3 size;  ///< n + 2 per axis

  explicit CubeGrid(const Int3& volume_dims)
      : size{volume_dims.x + 2, volume_dims.y + 2, volume_dims.z + 2} {}
  std::uint64_t linear(const Int3& c) const {
    return static_cast<std::uint64_t>(c.x + 1) +
           static_cast<std::uint64_t>(size.x) *
               (static_cast<std::uint64_t>(c.y + 1) +
                static_cast<std::uint64_t>(size.y) * static_cast<std::uint64_t>(c.z + 1));
  }
  Int3 cube(std::uint64_t linear) const {
    const auto sx = static_cast<std::uint64_t>(size.x), sy = static_cast<std::uint64_t>(size.y);
    return {static_cast<int>(linear % sx) - 1, static_cast<int>((linear / sx) % sy) - 1,
            static_cast<int>(linear / (sx * sy)) - 1};
  }
  std::uint64_t key(const Int3& c, int slot) const {
    return linear(c) * kSlotsPerCube + static_cast<std::uint64_t>(slot);
  }
};

/// Area-weighted normal sums in fixed point: exact under addition and removal, so an incremental
/// surface's normals equal a fresh build's, and the order of summation does not matter.
struct NormalSum {
  std::int64_t x = 0, y = 0, z = 0;
  NormalSum& operator+=(const NormalSum& o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  NormalSum& operator-=(const NormalSum& o) {
    x -= o.x;
    y -= o.y;
    z -= o.z;
    return *this;
  }
  bool operator==(const NormalSum& o) const { return x == o.x && y == o.y && z == o.z; }
};

/// Fixed-point units per mm²: 2^30 per (largest spacing)², far above float resolution of a
/// triangle's area, far below int64 overflow for any vertex's fan.
inline double normal_scale(const VolumeGeometry& g) {
  const double s = std::fmax(g.spacing.x, std::fmax(g.spacing.y, g.spacing.z));
  return 1073741824.0 / (s * s);
}

/// (b − a) × (c − a), twice the area-weighted face normal, in fixed point.
inline NormalSum face_normal_sum(const Vec3f& a, const Vec3f& b, const Vec3f& c, double scale) {
  const Vec3d u = to_double(b) - to_double(a), v = to_double(c) - to_double(a);
  const Vec3d n = cross(u, v) * scale;
  // Round half away from zero, inline (llround is a library call in the hot loop).
  auto round = [](double x) {
    return x >= 0.0 ? static_cast<std::int64_t>(x + 0.5) : -static_cast<std::int64_t>(0.5 - x);
  };
  return {round(n.x), round(n.y), round(n.z)};
}

inline Vec3f unit_normal(const NormalSum& s) {
  const Vec3d n{static_cast<double>(s.x), static_cast<double>(s.y), static_cast<double>(s.z)};
  return to_float(normalized_or_zero(n, 1e-300));
}

/// Index-space position -> tissue space (mm), rounded to float once.
inline Vec3f tissue_position(const VolumeGeometry& g, const Vec3d& index_position) {
  return to_float(g.index_to_tissue(index_position));
}

/// Outputs of the full surfacing that the incremental surface adopts.
struct ExtractionExtras {
  std::vector<std::uint64_t> vertex_keys;               ///< #V, CubeGrid::key
  std::vector<std::uint64_t> triangle_owner;            ///< #T, CubeGrid::linear of the owning cube
  std::vector<std::uint32_t> triangle_owner_signature;  ///< #T, LatticeWindow::signature of it
  std::vector<NormalSum> normal_sums;                   ///< #V
};

SurfaceMesh extract_surface_detailed(const VoxelVolume& volume, const SurfaceOptions& options,
                                     SurfaceBuildStats* stats, bool compute_normals,
                                     ExtractionExtras* extras);

/// Per-brick density ranges of `volume`: its own when current, else computed here (OpenMP).
std::vector<VoxelVolume::BrickRange> current_brick_ranges(const VoxelVolume& volume,
                                                          double* seconds);

/// Is there a value >= iso and one < iso among the samples of corners [lo, hi] (inclusive,
/// sample indices; samples outside the volume read 0)?
bool range_straddles(const VoxelVolume& volume, const std::vector<VoxelVolume::BrickRange>& ranges,
                     const Int3& lo, const Int3& hi, float iso);

}  // namespace tsf::imt::detail
