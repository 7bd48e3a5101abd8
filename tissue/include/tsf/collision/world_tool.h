// A tool placed in the deformed world (tissue space as the tissue looks now, mm): its signed
// distance, outward normal and bounding box, for contact tests on nodes and coupled vertices.
// Per-point math, TSF_HD, shared by the CPU contact code and the CUDA gather kernel.
//
// Shapes (tool_shapes.h gives the rest-space versions the voxel edits use):
//   sphere   centre a, radius
//   capsule  segment a–b, radius (the ablation wand)
//   blade    box of ±half_extents in the pose's frame (length x, depth y, thickness z)
//   mesh     a closed mesh read from a file, as a signed-distance grid in the pose's frame
//            (distance_grid.h): an endoscope, a retractor
//   field    any closed body given by a host-side DistanceField: another tissue instance's
//            deforming surface (interaction/body_field.h)
// Mesh and field tools are evaluated on the host only: the gather takes their box (the CUDA
// kernel too) and the host tests the nodes (tool_contact.h).
#pragma once

#include <cstdint>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::collision {

enum class ToolShape : int { kSphere = 0, kCapsule = 1, kBlade = 2, kMesh = 3, kField = 4 };

/// Mesh and field tools are tested on the host only.
TSF_HD_INLINE bool host_only(ToolShape s) {
  return s == ToolShape::kMesh || s == ToolShape::kField;
}

class SignedDistanceGrid;

/// A closed body as a signed distance (host only): what a `field` tool is.
class DistanceField {
 public:
  virtual ~DistanceField() = default;
  /// Signed distance of the world point p from the body's surface (negative inside), mm, and the
  /// outward unit normal there.
  virtual double distance(const Vec3d& p, Vec3d& normal) const = 0;
  /// Axis-aligned bounds of the body in the world, mm.
  virtual void bounds(Vec3d& lo, Vec3d& hi) const = 0;
  /// Where the surface lies for lattice node `node` of the pushed tissue: the signed distance,
  /// mm, the node keeps from the body (0 for tools). A body keeps the outer node layer about half a
  /// spacing off its surface, where the pushed tissue's own surface is, and lets a node that
  /// overlapped it at rest keep that overlap.
  virtual double allowance_mm(std::int64_t node) const {
    (void)node;
    return 0.0;
  }
  /// Whether the contact's narrow phase keeps the coupled render vertices out of the body too
  /// (tools: yes; a large body such as another tissue instance: its nodes only).
  virtual bool keeps_vertices_out() const { return true; }
};

struct WorldTool {
  ToolShape shape = ToolShape::kSphere;
  Vec3d a{0, 0, 0};                          ///< sphere centre, or capsule end, mm
  Vec3d b{0, 0, 0};                          ///< capsule end, mm
  double radius = 0;                         ///< sphere, capsule, mm
  ToolPose pose;                             ///< blade (and field tool) centre and orientation
  Vec3d half_extents{0, 0, 0};               ///< blade, mm
  const SignedDistanceGrid* grid = nullptr;  ///< mesh: its grid (owned by the tool), host only
  const DistanceField* field = nullptr;      ///< field: the body (owned elsewhere), host only

  /// A point the torque is taken about: the sphere centre, the capsule's midpoint, the pose
  /// position of the others.
  TSF_HD_INLINE Vec3d reference_point() const {
    return shape == ToolShape::kCapsule ? (a + b) * 0.5
                                        : (shape == ToolShape::kSphere ? a : pose.position);
  }
};

/// A mesh tool's signed distance (distance_grid.cpp): the grid read in the pose's frame.
double posed_grid_distance(const SignedDistanceGrid& grid, const ToolPose& pose, const Vec3d& p,
                           Vec3d& normal);
/// A mesh tool's world bounds (distance_grid.cpp).
void posed_grid_bounds(const SignedDistanceGrid& grid, const ToolPose& pose, Vec3d& lo, Vec3d& hi);

/// Signed distance of p from the tool surface (negative inside), mm, and the outward unit normal
/// of the nearest surface point (the direction that leaves the tool fastest).
TSF_HD_INLINE double tool_distance(const WorldTool& t, const Vec3d& p, Vec3d& normal) {
  if (host_only(t.shape)) {
#ifdef __CUDA_ARCH__
    // Never reached: mesh and field tools are tested on the host (tool_contact.h).
    normal = Vec3d{0, 0, 1};
    return 1e30;
#else
    return t.shape == ToolShape::kMesh ? posed_grid_distance(*t.grid, t.pose, p, normal)
                                       : t.field->distance(p, normal);
#endif
  }
  if (t.shape == ToolShape::kBlade) {
    const Vec3d q = t.pose.orientation.apply_inverse(p - t.pose.position);
    const Vec3d e = t.half_extents;
    const Vec3d over{fabs(q.x) - e.x, fabs(q.y) - e.y, fabs(q.z) - e.z};
    const Vec3d outside{over.x > 0 ? over.x : 0.0, over.y > 0 ? over.y : 0.0,
                        over.z > 0 ? over.z : 0.0};
    const double out_len = length(outside);
    Vec3d n_local{0, 0, 0};
    double d;
    if (out_len > 0.0) {
      n_local = Vec3d{q.x < 0 ? -outside.x : outside.x, q.y < 0 ? -outside.y : outside.y,
                      q.z < 0 ? -outside.z : outside.z} /
                out_len;
      d = out_len;
    } else {
      // Inside: leave through the nearest face.
      int axis = 0;
      if (over.y > over[axis]) axis = 1;
      if (over.z > over[axis]) axis = 2;
      n_local[axis] = q[axis] < 0 ? -1.0 : 1.0;
      d = over[axis];
    }
    normal = t.pose.orientation.apply(n_local);
    return d;
  }
  Vec3d c = t.a;
  if (t.shape == ToolShape::kCapsule) {
    const Vec3d ab = t.b - t.a;
    const double len2 = dot(ab, ab);
    double s = len2 > 0.0 ? dot(p - t.a, ab) / len2 : 0.0;
    s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
    c = t.a + ab * s;
  }
  const Vec3d r = p - c;
  const double len = length(r);
  if (len > 1e-12) {
    normal = r / len;
  } else {
    // On the axis: any direction perpendicular to a capsule's axis, +z for a sphere.
    const Vec3d ab = t.b - t.a;
    normal = t.shape == ToolShape::kCapsule && length_squared(ab) > 0.0
                 ? normalized_or_zero(
                       cross(ab, fabs(ab.x) < 0.9 * length(ab) ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0}))
                 : Vec3d{0, 0, 1};
  }
  return len - t.radius;
}

/// Axis-aligned bounds of the tool, mm.
TSF_HD_INLINE void tool_bounds(const WorldTool& t, Vec3d& lo, Vec3d& hi) {
  if (host_only(t.shape)) {
#ifdef __CUDA_ARCH__
    lo = hi = t.pose.position;
#else
    if (t.shape == ToolShape::kMesh)
      posed_grid_bounds(*t.grid, t.pose, lo, hi);
    else
      t.field->bounds(lo, hi);
#endif
    return;
  }
  if (t.shape == ToolShape::kBlade) {
    // |R|·e per axis: the box's extent along each world axis.
    Vec3d ext{0, 0, 0};
    for (int k = 0; k < 3; ++k) {
      Vec3d axis{0, 0, 0};
      axis[k] = t.half_extents[k];
      const Vec3d w = t.pose.orientation.apply(axis);
      ext += Vec3d{fabs(w.x), fabs(w.y), fabs(w.z)};
    }
    lo = t.pose.position - ext;
    hi = t.pose.position + ext;
    return;
  }
  const Vec3d r{t.radius, t.radius, t.radius};
  const Vec3d other = t.shape == ToolShape::kCapsule ? t.b : t.a;
  lo = Vec3d{fmin(t.a.x, other.x), fmin(t.a.y, other.y), fmin(t.a.z, other.z)} - r;
  hi = Vec3d{fmax(t.a.x, other.x), fmax(t.a.y, other.y), fmax(t.a.z, other.z)} + r;
}

/// Nodes are placed this far outside the surface (mm) so float rounding of the stored
/// displacement never leaves them a hair inside.
constexpr double kContactSkinMm = 1e-4;

/// The exact tool-vs-node test: true when p is inside the tool; `target` is then the nearest
/// point of the tool surface (where the node is moved, kContactSkinMm outside) and `normal` the
/// outward normal there.
TSF_HD_INLINE bool node_in_tool(const WorldTool& t, const Vec3f& p, Vec3f& target, Vec3f& normal) {
  Vec3d n;
  const Vec3d pd = to_double(p);
  const double d = tool_distance(t, pd, n);
  if (!(d < 0.0)) return false;
  target = to_float(pd - n * (d - kContactSkinMm));
  normal = to_float(n);
  return true;
}

}  // namespace tsf::collision
