#include "tsf/export/export_normals.h"

#include <cmath>
#include <vector>

namespace tsf::exporter {

namespace {

bool is_unit(const Vec3f& n) {
  if (!all_finite(n)) return false;
  const float l2 = length_squared(n);
  return l2 > 0.98f && l2 < 1.02f;
}

}  // namespace

std::size_t complete_normals(imt::SurfaceMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  if (mesh.normals.size() != nv) {
    // Area-weighted normals: the sum of the (unnormalised) face normals around each vertex.
    std::vector<Vec3d> sum(nv, Vec3d{0, 0, 0});
    for (const auto& t : mesh.triangles) {
      const Vec3d a = to_double(mesh.positions[t[0]]);
      const Vec3d n =
          cross(to_double(mesh.positions[t[1]]) - a, to_double(mesh.positions[t[2]]) - a);
      for (std::uint32_t v : t) sum[v] += n;
    }
    mesh.normals.assign(nv, Vec3f{0, 0, 0});
    for (std::size_t v = 0; v < nv; ++v) {
      const double l = length(sum[v]);
      if (l > 0.0) mesh.normals[v] = to_float(sum[v] / l);
    }
  }
  std::vector<std::size_t> bad;
  for (std::size_t v = 0; v < nv; ++v)
    if (!is_unit(mesh.normals[v])) {
      const float l = all_finite(mesh.normals[v]) ? length(mesh.normals[v]) : 0.0f;
      if (l > 1e-12f) {
        mesh.normals[v] = mesh.normals[v] / l;  // merely not normalised: not a repair
      } else {
        bad.push_back(v);
      }
    }
  if (bad.empty()) return 0;

  std::vector<char> is_bad(nv, 0);
  for (std::size_t v : bad) is_bad[v] = 1;
  std::vector<Vec3d> from_neighbours(nv, Vec3d{0, 0, 0}), from_faces(nv, Vec3d{0, 0, 0});
  for (const auto& t : mesh.triangles) {
    if (!is_bad[t[0]] && !is_bad[t[1]] && !is_bad[t[2]]) continue;
    const Vec3d a = to_double(mesh.positions[t[0]]);
    const Vec3d face =
        cross(to_double(mesh.positions[t[1]]) - a, to_double(mesh.positions[t[2]]) - a);
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = t[static_cast<std::size_t>(k)];
      if (!is_bad[v]) continue;
      from_faces[v] += face;
      for (int j = 1; j < 3; ++j) {
        const std::uint32_t u = t[static_cast<std::size_t>((k + j) % 3)];
        if (!is_bad[u]) from_neighbours[v] += to_double(mesh.normals[u]);
      }
    }
  }
  for (std::size_t v : bad) {
    Vec3d n = from_neighbours[v];
    if (!(length(n) > 1e-12)) n = from_faces[v];
    mesh.normals[v] = length(n) > 1e-12 ? to_float(n / length(n)) : Vec3f{0, 0, 1};
  }
  return bad.size();
}

}  // namespace tsf::exporter
