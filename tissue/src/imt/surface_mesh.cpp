#include "tsf/imt/surface_mesh.h"

#include <algorithm>
#include <string>

#include "tsf/common/error.h"

namespace tsf::imt {

std::uint8_t triangle_label(const SurfaceMesh& mesh, std::size_t triangle) {
  const auto& t = mesh.triangles[triangle];
  const std::uint8_t a = mesh.labels[t[0]], b = mesh.labels[t[1]], c = mesh.labels[t[2]];
  if (a == b || a == c) return a;
  if (b == c) return b;
  return std::min(a, std::min(b, c));
}

std::vector<std::uint8_t> triangle_labels_present(const SurfaceMesh& mesh) {
  bool seen[256] = {};
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) seen[triangle_label(mesh, t)] = true;
  std::vector<std::uint8_t> out;
  for (int l = 0; l < 256; ++l)
    if (seen[l]) out.push_back(static_cast<std::uint8_t>(l));
  return out;
}

SurfaceMesh extract_label(const SurfaceMesh& mesh, std::uint8_t label) {
  SurfaceMesh out;
  std::vector<std::uint32_t> index_of(mesh.positions.size(), UINT32_MAX);
  const bool normals = mesh.normals.size() == mesh.positions.size();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (triangle_label(mesh, t) != label) continue;
    std::array<std::uint32_t, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = mesh.triangles[t][static_cast<std::size_t>(k)];
      if (index_of[v] == UINT32_MAX) {
        index_of[v] = static_cast<std::uint32_t>(out.positions.size());
        out.positions.push_back(mesh.positions[v]);
        out.labels.push_back(mesh.labels[v]);
        if (normals) out.normals.push_back(mesh.normals[v]);
      }
      tri[static_cast<std::size_t>(k)] = index_of[v];
    }
    out.triangles.push_back(tri);
  }
  return out;
}

SurfaceMesh unweld(const SurfaceMesh& mesh) {
  SurfaceMesh out;
  out.positions.reserve(mesh.triangles.size() * 3);
  out.normals.reserve(mesh.triangles.size() * 3);
  out.labels.reserve(mesh.triangles.size() * 3);
  out.triangles.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    const Vec3f& a = mesh.positions[t[0]];
    const Vec3f n = normalized_or_zero(cross(mesh.positions[t[1]] - a, mesh.positions[t[2]] - a));
    const auto base = static_cast<std::uint32_t>(out.positions.size());
    for (std::uint32_t v : t) {
      out.positions.push_back(mesh.positions[v]);
      out.normals.push_back(n);
      out.labels.push_back(mesh.labels[v]);
    }
    out.triangles.push_back({base, base + 1, base + 2});
  }
  return out;
}

void validate_mesh(const SurfaceMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  require(mesh.labels.size() == nv, "mesh has " + std::to_string(mesh.labels.size()) +
                                        " labels for " + std::to_string(nv) + " vertices");
  require(mesh.normals.empty() || mesh.normals.size() == nv,
          "mesh has " + std::to_string(mesh.normals.size()) + " normals for " + std::to_string(nv) +
              " vertices (expected the same or none)");
  for (std::size_t v = 0; v < nv; ++v) {
    require(all_finite(mesh.positions[v]),
            "mesh vertex " + std::to_string(v) + " has a non-finite position");
    if (!mesh.normals.empty())
      require(all_finite(mesh.normals[v]),
              "mesh vertex " + std::to_string(v) + " has a non-finite normal");
  }
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (std::uint32_t v : mesh.triangles[t])
      require(v < nv, "mesh triangle " + std::to_string(t) + " uses vertex " + std::to_string(v) +
                          " of " + std::to_string(nv));
}

}  // namespace tsf::imt
