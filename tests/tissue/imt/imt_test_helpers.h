// Helpers for the IMT tests: analytic volumes, surface error, canonical mesh comparison.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "tsf/imt/imt_surface.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/imt/surface_mesh.h"
#include "tsf/volume/analytic_volumes.h"

namespace tsf::imt::test {

struct SurfaceError {
  double mean = 0, max = 0;  // in voxels
};

/// |signed distance| of every vertex to the analytic surface, in voxels (isotropic spacing).
inline SurfaceError surface_error(const SurfaceMesh& mesh,
                                  const std::function<double(const Vec3d&)>& sdf,
                                  double spacing = 1.0) {
  SurfaceError e;
  for (const Vec3f& p : mesh.positions) {
    const double d = std::fabs(sdf(to_double(p))) / spacing;
    e.mean += d;
    e.max = std::max(e.max, d);
  }
  if (!mesh.positions.empty()) e.mean /= static_cast<double>(mesh.positions.size());
  return e;
}

/// Asserts the mesh is a closed, consistently oriented 2-manifold; returns its topology.
inline MeshTopology expect_closed_manifold(const SurfaceMesh& mesh, const std::string& what) {
  const MeshTopology t = analyse_topology(mesh);
  EXPECT_EQ(t.boundary_edges, 0u) << what;
  EXPECT_EQ(t.nonmanifold_edges, 0u) << what;
  EXPECT_EQ(t.misoriented_edges, 0u) << what;
  EXPECT_EQ(t.degenerate_triangles, 0u) << what;
  EXPECT_EQ(t.unreferenced_vertices, 0u) << what;
  EXPECT_EQ(t.nonmanifold_vertices, 0u) << what;
  return t;
}

/// Volume-weighted orientation check: Σ (p · n_face) area over a closed mesh is 3 × enclosed
/// volume, positive when normals point outward.
inline double signed_volume(const SurfaceMesh& mesh) {
  double v = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3d a = to_double(mesh.positions[t[0]]), b = to_double(mesh.positions[t[1]]),
                c = to_double(mesh.positions[t[2]]);
    v += dot(a, cross(b, c)) / 6.0;
  }
  return v;
}

/// A mesh as sorted triangles of vertex identities (positions, bitwise), each rotated so its
/// smallest vertex comes first (orientation kept): two meshes are equal up to numbering iff their
/// canonical forms are equal.
using CanonicalVertex = std::array<float, 3>;
using CanonicalTriangle = std::array<CanonicalVertex, 3>;
inline std::vector<CanonicalTriangle> canonical_triangles(const SurfaceMesh& mesh) {
  std::vector<CanonicalTriangle> out;
  out.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    CanonicalTriangle c;
    for (int k = 0; k < 3; ++k) {
      const Vec3f& p = mesh.positions[t[static_cast<std::size_t>(k)]];
      c[static_cast<std::size_t>(k)] = {p.x, p.y, p.z};
    }
    const auto first = std::min_element(c.begin(), c.end()) - c.begin();
    std::rotate(c.begin(), c.begin() + first, c.end());
    out.push_back(c);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace tsf::imt::test
