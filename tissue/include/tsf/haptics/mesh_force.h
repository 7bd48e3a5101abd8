// Mesh-based haptic rendering (thesis §8.5.3): the stylus as a set of small spheres against the
// coupled (deformed) IMT triangles near it, the force along density-like weighted normals.
// Per-pair and per-sphere math, TSF_HD; MeshForceModel (force_models.h) is the thin loop.
//
// For stylus sphere s (centre q, radius r) and triangle t with closest point y at distance d and
// interpolated vertex normal n (pointing out of the tissue):
//   q outside the tissue (n·(q − y) ≥ 0):  depth h = r − d     (the sphere dips in)
//   q inside:                               depth h = r + d     (the surface crosses the sphere)
// touching when the triangle passes within r of q (then 0 < h < 2r). The sphere's depth h_s is its
// largest over triangles; its normal is Σ_t h·n over the triangles it touches. Then, with the same
// law as the voxel model,
//   V = Σ_s cap(h_s) · V_stylus / Σ_s sphere volume     cap(h) = π h² (3r − h)/3
//   F = law(V) · normalize(Σ_s Σ_t h·n)
// Spheres whose reach holds no triangle (wholly inside or outside) count nothing: deep inside
// thick tissue the mesh model pops through, which is the cost of a surface representation.
//
// Cost: #spheres × #triangles in the patch (triangles farther than the stylus radius + r from its
// centre are skipped once per evaluation).
#pragma once

#include <cmath>

#include "tsf/common/closest_point.h"
#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"

namespace tsf::haptics {

using tsf::closest_point_on_triangle;

/// Sphere (q, r) against triangle t (corners a,b,c, vertex normals na,nb,nc): true when the
/// triangle passes within r of q; `distance` receives |q − y| for the closest point y, `normal`
/// the normal interpolated there (unit, out of the tissue) and `inside` whether q lies behind it.
TSF_HD_INLINE bool sphere_triangle_contact(const Vec3d& q, double r, const Vec3f* corners,
                                           const Vec3f* normals, double& distance, Vec3d& normal,
                                           bool& inside) {
  double wa, wb, wc;
  const Vec3d y = closest_point_on_triangle(q, to_double(corners[0]), to_double(corners[1]),
                                            to_double(corners[2]), wa, wb, wc);
  const Vec3d qy = q - y;
  const double d2 = dot(qy, qy);
  if (!(d2 < r * r)) return false;  // the triangle misses the sphere
  normal = normalized_or_zero(to_double(normals[0]) * wa + to_double(normals[1]) * wb +
                              to_double(normals[2]) * wc);
  distance = sqrt(d2);
  inside = dot(normal, qy) < 0.0;
  return true;
}

/// Depth of a sphere of radius r whose centre is `distance` from the nearest surface point,
/// on the inside or not: r − d outside, r + d inside (0 < depth < 2r).
TSF_HD_INLINE double sphere_depth(double r, double distance, bool inside) {
  return inside ? r + distance : r - distance;
}

/// Volume of a cap of height h cut from a sphere of radius r, mm³.
TSF_HD_INLINE double sphere_cap_volume(double h, double r) {
  const double pi = 3.14159265358979323846;
  h = h < 0 ? 0 : (h > 2 * r ? 2 * r : h);
  return pi * h * h * (3.0 * r - h) / 3.0;
}

}  // namespace tsf::haptics
