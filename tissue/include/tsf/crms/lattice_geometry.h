// R3 CRMS lattice geometry: a regular grid of nodes in tissue space, implicitly addressed.
//
// Node (i,j,k) has linear index n = i + nx*(j + ny*k) (x fastest, like the voxel volume) and rest
// position origin + (i·hx, j·hy, k·hz) in mm. Each node owns the dual cell of size hx×hy×hz
// centred on it, so a box of nx·hx × ny·hy × nz·hz mm is tiled exactly by nx×ny×nz nodes whose
// outermost layer sits half a spacing inside the box surface.
//
// Face directions d = 0..5 are −x,+x,−y,+y,−z,+z: axis d/2, sign (d&1 ? + : −). The link bit d of
// a node is set while the linear spring to that neighbour exists (both nodes alive, in range and
// the spring not broken). Angular springs live at a vertex between two links of different axes:
// 4 per axis plane, 12 per node; the plane is named by its normal axis (0 = yz, 1 = zx, 2 = xy).
#pragma once

#include <cmath>
#include <cstdint>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"

namespace tsf::crms {

constexpr int kFaceDirections = 6;
constexpr int kAnglesPerNode = 12;

TSF_HD_INLINE constexpr int direction_axis(int d) {
  return d >> 1;
}
TSF_HD_INLINE constexpr int direction_sign(int d) {
  return (d & 1) ? 1 : -1;
}
TSF_HD_INLINE constexpr int opposite_direction(int d) {
  return d ^ 1;
}
TSF_HD_INLINE constexpr int make_direction(int axis, int sign) {
  return 2 * axis + (sign > 0);
}
/// Axis-plane index of two different axes: the third axis (0 = yz, 1 = zx, 2 = xy).
TSF_HD_INLINE constexpr int plane_of_axes(int a, int b) {
  return 3 - a - b;
}

/// Offset (di,dj,dk) of the face neighbour in direction d.
TSF_HD_INLINE Int3 direction_offset(int d) {
  Int3 o{0, 0, 0};
  o[direction_axis(d)] = direction_sign(d);
  return o;
}

/// The 12 angles at a vertex, as (first arm direction, second arm direction); the first arm's
/// axis is the lower one. Order: plane yz (4), zx (4), xy (4); within a plane
/// (−,−),(−,+),(+,−),(+,+).
TSF_HD_INLINE void angle_arms(int angle, int& d1, int& d2) {
  const int plane = angle >> 2;  // normal axis
  const int a = plane == 0 ? 1 : 0;
  const int b = plane == 2 ? 1 : 2;
  d1 = make_direction(a, (angle & 2) ? 1 : -1);
  d2 = make_direction(b, (angle & 1) ? 1 : -1);
}

struct LatticeGeometry {
  Int3 dims;                     ///< nodes along x, y, z
  Vec3d origin{0.0, 0.0, 0.0};   ///< mm, rest position of node (0,0,0) in tissue space
  Vec3d spacing{1.0, 1.0, 1.0};  ///< mm, rest length of the x, y, z springs

  std::int64_t node_count() const { return dims.volume(); }
  std::int64_t index(int i, int j, int k) const {
    return static_cast<std::int64_t>(i) +
           static_cast<std::int64_t>(dims.x) *
               (static_cast<std::int64_t>(j) + static_cast<std::int64_t>(dims.y) * k);
  }
  Int3 coordinates(std::int64_t n) const {
    const std::int64_t nx = dims.x, ny = dims.y;
    return {static_cast<int>(n % nx), static_cast<int>((n / nx) % ny),
            static_cast<int>(n / (nx * ny))};
  }
  bool contains(int i, int j, int k) const {
    return i >= 0 && j >= 0 && k >= 0 && i < dims.x && j < dims.y && k < dims.z;
  }
  /// Rest position in mm of node (i,j,k).
  Vec3d rest_position(int i, int j, int k) const {
    return {origin.x + i * spacing.x, origin.y + j * spacing.y, origin.z + k * spacing.z};
  }
  Vec3d rest_position(std::int64_t n) const {
    const Int3 c = coordinates(n);
    return rest_position(c.x, c.y, c.z);
  }
  /// Smallest rest spring length, mm.
  double min_spacing() const {
    const double m = spacing.x < spacing.y ? spacing.x : spacing.y;
    return m < spacing.z ? m : spacing.z;
  }
  /// Volume of one node's dual cell, mm³.
  double cell_volume() const { return spacing.x * spacing.y * spacing.z; }
};

/// Where a tissue-space rest point lies in the lattice (for the coupler).
struct LatticeCellLocation {
  Int3 cell;    ///< lower corner node of the cube of 8 nodes holding the point
  Vec3d local;  ///< local coordinates in the cube: [0,1]³ inside the node hull
  /// False when the point lies outside the hull of node centres: the cube is the nearest one
  /// and `local` extrapolates beyond [0,1] (at most ½ + the distance outside, in spacings).
  /// Points of a voxel-built lattice lie at most half a spacing outside the hull.
  bool inside_hull = true;
};

/// Maps a rest point (mm, tissue space) to the cube of 8 nodes around it and its local
/// coordinates, w = (p − rest(cell)) / spacing. A lattice with a single node along an axis has no
/// cube along it: cell 0 and local 0 there (the coupler then follows that node alone).
inline LatticeCellLocation locate_rest_point(const LatticeGeometry& g, const Vec3d& p) {
  LatticeCellLocation loc;
  for (int a = 0; a < 3; ++a) {
    const double t = (p[a] - g.origin[a]) / g.spacing[a];
    const int n = g.dims[a];
    if (n < 2) {
      loc.cell[a] = 0;
      loc.local[a] = 0.0;
      if (t < -0.5 || t > 0.5) loc.inside_hull = false;
      continue;
    }
    const double f = std::floor(t);  // clamp in double: a far-away point must not overflow int
    const int c = f >= 0.0 ? (f > n - 2 ? n - 2 : static_cast<int>(f)) : 0;  // NaN -> 0
    loc.cell[a] = c;
    loc.local[a] = t - c;
    if (t < 0.0 || t > n - 1) loc.inside_hull = false;
  }
  return loc;
}

}  // namespace tsf::crms
