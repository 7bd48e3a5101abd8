// Tool shapes that edit the voxel volume, in tissue space (axis-aligned, mm), with their signed
// distance functions (negative inside, mm) and the smooth fall-off that turns a distance into an
// edit weight. Per-voxel math: TSF_HD, shared by the CPU edit loops and any GPU kernel.
//
// A tool pose given in the deformed world is mapped into rest (tissue) space by the coupler before
// it reaches these functions.
#pragma once

#include <cmath>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"

namespace tsf {

/// Unit quaternion (w, x, y, z) rotating tool-local coordinates into tissue space.
struct Rotation {
  double w = 1.0, x = 0.0, y = 0.0, z = 0.0;

  /// Rotation by `angle_rad` about `axis` (any length > 0).
  static Rotation about_axis(const Vec3d& axis, double angle_rad) {
    const Vec3d a = normalized_or_zero(axis);
    const double s = std::sin(0.5 * angle_rad);
    return {std::cos(0.5 * angle_rad), a.x * s, a.y * s, a.z * s};
  }
  /// R·v
  TSF_HD_INLINE Vec3d apply(const Vec3d& v) const {
    const Vec3d u{x, y, z};
    const Vec3d t = cross(u, v) * 2.0;
    return v + t * w + cross(u, t);
  }
  /// Rᵀ·v (tissue space -> tool-local)
  TSF_HD_INLINE Vec3d apply_inverse(const Vec3d& v) const {
    const Rotation inv{w, -x, -y, -z};
    return inv.apply(v);
  }
  /// Angle of the rotation taking *this to `o`, radians in [0, π].
  double angle_to(const Rotation& o) const {
    const double d = std::fabs(w * o.w + x * o.x + y * o.y + z * o.z);
    return 2.0 * std::acos(d > 1.0 ? 1.0 : d);
  }
  /// Spherical interpolation (shortest arc), t in [0,1].
  static Rotation slerp(const Rotation& a, Rotation b, double t);
  Rotation normalized() const {
    const double n = std::sqrt(w * w + x * x + y * y + z * z);
    return n > 0 ? Rotation{w / n, x / n, y / n, z / n} : Rotation{};
  }
};

/// Position and orientation of a tool in tissue space.
struct ToolPose {
  Vec3d position;  ///< mm
  Rotation orientation;
};

struct SphereTool {
  Vec3d centre;   ///< mm
  double radius;  ///< mm
};

/// A capsule (the ablation wand): all points within `radius` of the segment a–b.
struct CapsuleTool {
  Vec3d a, b;     ///< segment ends, mm
  double radius;  ///< mm
};

/// A blade: a box in its own frame, centred on the pose position, extending ±half_extents (mm)
/// along the pose's local x (length), y (depth) and z (thickness) axes.
struct BladeTool {
  Vec3d half_extents;  ///< mm
};

TSF_HD_INLINE double sphere_distance(const SphereTool& s, const Vec3d& p) {
  return length(p - s.centre) - s.radius;
}

TSF_HD_INLINE double capsule_distance(const CapsuleTool& c, const Vec3d& p) {
  const Vec3d ab = c.b - c.a;
  const double len2 = dot(ab, ab);
  double t = len2 > 0.0 ? dot(p - c.a, ab) / len2 : 0.0;
  t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
  return length(p - (c.a + ab * t)) - c.radius;
}

/// Signed distance to a box of `half_extents` centred at the origin (exact outside and inside).
/// Selects, not fmin/fmax (the same values for finite input: no q is −0), so loops over voxels
/// vectorise.
TSF_HD_INLINE double box_distance_local(const Vec3d& half_extents, const Vec3d& p_local) {
  const Vec3d q{fabs(p_local.x) - half_extents.x, fabs(p_local.y) - half_extents.y,
                fabs(p_local.z) - half_extents.z};
  const Vec3d outside{q.x > 0 ? q.x : 0.0, q.y > 0 ? q.y : 0.0, q.z > 0 ? q.z : 0.0};
  const double yz = q.y > q.z ? q.y : q.z;
  const double largest = q.x > yz ? q.x : yz;
  const double inside = largest < 0.0 ? largest : 0.0;
  return length(outside) + inside;
}

TSF_HD_INLINE double blade_distance(const BladeTool& b, const ToolPose& pose, const Vec3d& p) {
  return box_distance_local(b.half_extents, pose.orientation.apply_inverse(p - pose.position));
}

/// A blade's sub-step seen from a row of voxels along x: the tool-local position of the row's
/// first voxel and the step from one voxel of the row to the next, so that voxel m of the row
/// lies at base + step · m (three multiply-adds per voxel instead of a rotation).
struct BladeRowFrame {
  Vec3d base, step;
  TSF_HD_INLINE Vec3d at(int m) const {
    const double t = static_cast<double>(m);
    return {base.x + step.x * t, base.y + step.y * t, base.z + step.z * t};
  }
};
TSF_HD_INLINE BladeRowFrame blade_row_frame(const ToolPose& pose, const Vec3d& first_voxel,
                                            double spacing_x) {
  return {pose.orientation.apply_inverse(first_voxel - pose.position),
          pose.orientation.apply_inverse(Vec3d{spacing_x, 0.0, 0.0})};
}

/// A point's smallest signed distance from a blade over several sub-steps, in two parts so that
/// adding a sub-step takes no square root (box_distance_local is |outside| + inside, and one of
/// the two is zero): the most negative inside distance of the sub-steps that hold the point
/// (1 while none does) and the smallest squared outside distance (+inf while none). Both are
/// minima, so neither the order of the sub-steps nor how threads share them changes the result;
/// distance() is the smallest box_distance_local (sqrt is monotone and correctly rounded).
struct BladeDistanceMin {
  double inside = 1.0, outside2 = INFINITY;

  TSF_HD_INLINE void add(const Vec3d& half_extents, const Vec3d& p_local) {
    const Vec3d q{fabs(p_local.x) - half_extents.x, fabs(p_local.y) - half_extents.y,
                  fabs(p_local.z) - half_extents.z};
    const Vec3d outside{q.x > 0 ? q.x : 0.0, q.y > 0 ? q.y : 0.0, q.z > 0 ? q.z : 0.0};
    const double o2 = dot(outside, outside);
    const double yz = q.y > q.z ? q.y : q.z;
    const double largest = q.x > yz ? q.x : yz;  // <= 0 where o2 == 0: the point is inside
    inside = o2 == 0.0 && largest < inside ? largest : inside;
    outside2 = o2 < outside2 ? o2 : outside2;
  }
  TSF_HD_INLINE void merge(const BladeDistanceMin& o) {
    inside = o.inside < inside ? o.inside : inside;
    outside2 = o.outside2 < outside2 ? o.outside2 : outside2;
  }
  TSF_HD_INLINE double distance() const { return inside <= 0.0 ? inside : sqrt(outside2); }
};

/// Edit weight for a point at signed distance `d` (mm) from the tool surface: 1 deeper than
/// `half_width` inside, 0 farther than `half_width` outside, a smoothstep between (so an edit at
/// full strength on solid tissue puts the 0.5 iso-level on the tool surface and leaves a density
/// ramp that linear interpolation follows). half_width <= 0 gives a hard step.
TSF_HD_INLINE float falloff_weight(double d, double half_width) {
  if (half_width <= 0.0) return d <= 0.0 ? 1.0f : 0.0f;
  double s = 0.5 - 0.5 * d / half_width;  // 1 at d = -h, 0 at d = +h
  s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
  return static_cast<float>(s * s * (3.0 - 2.0 * s));
}

}  // namespace tsf
