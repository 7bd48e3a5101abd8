// Voxel-based haptic rendering (thesis §8.5.1): the stylus's voxels against the tissue density.
// Per-voxel and per-evaluation math, TSF_HD; VoxelForceModel (force_models.h) is the thin loop.
//
// For every stylus cell centre, offset δ from the stylus centre p in the world, the tissue density
// ρ is read at its rest point X + F⁻¹·δ (local_warp.h: the stylus inverse-warped by the lattice)
// by trilinear interpolation of the density window (0 outside it). Then
//   V  = Σ ρ_i · v_cell                   intersection volume, density-weighted, mm³
//   c  = p + Σ ρ_i·δ_i / Σ ρ_i            intersection centroid (weighted by density), world
//   F  = law(V) · (p − c)/|p − c|          force_law.h; zero when Σρ = 0 or p = c
// Trilinear density makes V a smooth function of the stylus position (a binary voxel test would
// step by one cell volume at a time: jitter).
//
// Cost: a 3×3 product per stylus cell (~0.52·n³ cells for an n³ grid) and one byte read where the
// cube of 8 voxels around it is uniformly empty or full (classified at capture,
// haptic_frame.h), else a trilinear read (8 loads); independent of the tissue's size.
#pragma once

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/haptics/force_law.h"
#include "tsf/haptics/haptic_frame.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::haptics {

/// Trilinear density at grid coordinates g = (X − origin) / spacing (voxel units); 0 outside
/// the window, and interpolated towards 0 across its last layer.
TSF_HD_INLINE float sample_density_grid(const DensityWindowView& w, float gx, float gy, float gz) {
  if (!(gx >= 0.0f && gy >= 0.0f && gz >= 0.0f)) return 0.0f;
  const int nx = w.dims.x, ny = w.dims.y, nz = w.dims.z;
  const int i = static_cast<int>(gx), j = static_cast<int>(gy), k = static_cast<int>(gz);
  if (i > nx - 1 || j > ny - 1 || k > nz - 1) return 0.0f;
  const float fx = gx - static_cast<float>(i), fy = gy - static_cast<float>(j),
              fz = gz - static_cast<float>(k);
  const long long sy = nx, sz = static_cast<long long>(nx) * ny;
  const long long base = i + sy * j + sz * k;
  const float* d = w.density;
  float c000, c100, c010, c110, c001, c101, c011, c111;
  if (i + 1 < nx && j + 1 < ny && k + 1 < nz) {  // the common case: all eight inside
    c000 = d[base];
    c100 = d[base + 1];
    c010 = d[base + sy];
    c110 = d[base + 1 + sy];
    c001 = d[base + sz];
    c101 = d[base + 1 + sz];
    c011 = d[base + sy + sz];
    c111 = d[base + 1 + sy + sz];
  } else {
    const bool ix = i + 1 < nx, jy = j + 1 < ny, kz = k + 1 < nz;
    c000 = d[base];
    c100 = ix ? d[base + 1] : 0.0f;
    c010 = jy ? d[base + sy] : 0.0f;
    c110 = ix && jy ? d[base + 1 + sy] : 0.0f;
    c001 = kz ? d[base + sz] : 0.0f;
    c101 = ix && kz ? d[base + 1 + sz] : 0.0f;
    c011 = jy && kz ? d[base + sy + sz] : 0.0f;
    c111 = ix && jy && kz ? d[base + 1 + sy + sz] : 0.0f;
  }
  const float c00 = c000 + (c100 - c000) * fx, c10 = c010 + (c110 - c010) * fx;
  const float c01 = c001 + (c101 - c001) * fx, c11 = c011 + (c111 - c011) * fx;
  const float c0 = c00 + (c10 - c00) * fy, c1 = c01 + (c11 - c01) * fy;
  return c0 + (c1 - c0) * fz;
}

/// Trilinear density at grid coordinates known to lie in [0, n − 1) on every axis (the caller
/// checked the stylus's bounds once): no per-cell bounds tests.
TSF_HD_INLINE float sample_density_interior(const DensityWindowView& w, float gx, float gy,
                                            float gz) {
  const int i = static_cast<int>(gx), j = static_cast<int>(gy), k = static_cast<int>(gz);
  const float fx = gx - static_cast<float>(i), fy = gy - static_cast<float>(j),
              fz = gz - static_cast<float>(k);
  const long long sy = w.dims.x, sz = static_cast<long long>(w.dims.x) * w.dims.y;
  const float* d = w.density + (i + sy * j + sz * k);
  const float c00 = d[0] + (d[1] - d[0]) * fx;
  const float c10 = d[sy] + (d[sy + 1] - d[sy]) * fx;
  const float c01 = d[sz] + (d[sz + 1] - d[sz]) * fx;
  const float c11 = d[sy + sz] + (d[sy + sz + 1] - d[sy + sz]) * fx;
  const float c0 = c00 + (c10 - c00) * fy, c1 = c01 + (c11 - c01) * fy;
  return c0 + (c1 - c0) * fz;
}

/// As sample_density_interior, reading the cube's classification first: uniform cubes (empty or
/// full tissue, most of a stylus away from the surface) cost one byte instead of eight floats.
TSF_HD_INLINE float sample_density_classified(const DensityWindowView& w, float gx, float gy,
                                              float gz) {
  const int i = static_cast<int>(gx), j = static_cast<int>(gy), k = static_cast<int>(gz);
  const std::uint8_t c =
      w.cells[i + static_cast<long long>(w.dims.x) * (j + static_cast<long long>(w.dims.y) * k)];
  if (c == kCellEmpty) return 0.0f;
  if (c == kCellFull) return 1.0f;
  return sample_density_interior(w, gx, gy, gz);
}

/// Nearest-voxel density at grid coordinates (the thesis's binary voxels when the volume is
/// binary): one load instead of eight, at the cost of a stepwise force (jitter).
TSF_HD_INLINE float sample_density_nearest(const DensityWindowView& w, float gx, float gy,
                                           float gz) {
  const float hx = gx + 0.5f, hy = gy + 0.5f, hz = gz + 0.5f;
  if (!(hx >= 0.0f && hy >= 0.0f && hz >= 0.0f)) return 0.0f;
  const int i = static_cast<int>(hx), j = static_cast<int>(hy), k = static_cast<int>(hz);
  if (i >= w.dims.x || j >= w.dims.y || k >= w.dims.z) return 0.0f;
  return w
      .density[i + static_cast<long long>(w.dims.x) * (j + static_cast<long long>(w.dims.y) * k)];
}

/// Trilinear density at rest point X (mm); 0 outside the window.
TSF_HD_INLINE float sample_density(const DensityWindowView& w, const Vec3d& X) {
  return sample_density_grid(w, static_cast<float>((X.x - w.origin.x) / w.spacing.x),
                             static_cast<float>((X.y - w.origin.y) / w.spacing.y),
                             static_cast<float>((X.z - w.origin.z) / w.spacing.z));
}

/// Running sums of one evaluation. Float: a few thousand cells of densities in [0, 1] keep ~1e-6
/// relative accuracy, and the per-cell work stays in single precision.
struct VoxelAccumulation {
  float density_sum = 0;           ///< Σ ρ_i
  Vec3f weighted_offset{0, 0, 0};  ///< Σ ρ_i·δ_i, mm (stylus-local)
  int cells_touched = 0;           ///< cells with ρ > 0
};

/// One stylus cell: its offset δ from the centre (stylus-local, mm) and the density there.
TSF_HD_INLINE void accumulate_voxel(const Vec3f& offset, float rho, VoxelAccumulation& acc) {
  acc.density_sum += rho;
  acc.weighted_offset += offset * rho;
  acc.cells_touched += rho > 0.0f;
}

/// The force from the sums: V = Σρ·v_cell, direction from the centroid to the centre.
/// `rotation` turns the stylus-local centroid offset into the world.
TSF_HD_INLINE Vec3d voxel_force(const VoxelAccumulation& acc, const Rotation& rotation,
                                double cell_volume_mm3, double stylus_volume_mm3,
                                const ForceLaw& law, double& intersection_mm3) {
  const double sum = static_cast<double>(acc.density_sum);
  intersection_mm3 = sum * cell_volume_mm3;
  if (!(sum > 0.0)) return {0, 0, 0};
  const Vec3d centroid_offset = rotation.apply(to_double(acc.weighted_offset) / sum);  // c − p
  const Vec3d direction = normalized_or_zero(-centroid_offset, 1e-12);
  return direction * law.magnitude(intersection_mm3, stylus_volume_mm3);
}

}  // namespace tsf::haptics
