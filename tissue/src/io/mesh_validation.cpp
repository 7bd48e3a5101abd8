#include "tsf/io/mesh_validation.h"

namespace tsf::io {

void validate_mesh_quickly(const imt::SurfaceMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  bool ok = mesh.labels.size() == nv && (mesh.normals.empty() || mesh.normals.size() == nv);
  for (std::size_t v = 0; ok && v < nv; ++v) ok = all_finite(mesh.positions[v]);
  for (std::size_t v = 0; ok && v < mesh.normals.size(); ++v) ok = all_finite(mesh.normals[v]);
  for (std::size_t t = 0; ok && t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    ok = tri[0] < nv && tri[1] < nv && tri[2] < nv;
  }
  if (!ok) imt::validate_mesh(mesh);  // throws with the message naming the first bad element
}

}  // namespace tsf::io
