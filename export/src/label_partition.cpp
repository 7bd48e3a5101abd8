#include "tsf/export/label_partition.h"

#include <numeric>

namespace tsf::exporter {

std::vector<LabelPart> partition_by_label(const imt::SurfaceMesh& mesh) {
  // Bucket the triangles by label (a counting sort keeps each bucket ascending).
  std::array<std::size_t, 257> start{};
  std::vector<std::uint8_t> label_of(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    label_of[t] = imt::triangle_label(mesh, t);
    ++start[label_of[t] + 1u];
  }
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<std::uint32_t> order(mesh.triangles.size());
  std::array<std::size_t, 256> fill{};
  std::copy(start.begin(), start.end() - 1, fill.begin());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    order[fill[label_of[t]]++] = static_cast<std::uint32_t>(t);

  std::vector<LabelPart> parts;
  std::vector<std::uint32_t> index_of(mesh.positions.size(), UINT32_MAX);
  for (int label = 0; label < 256; ++label) {
    const std::size_t begin = start[static_cast<std::size_t>(label)];
    const std::size_t end = start[static_cast<std::size_t>(label) + 1];
    if (begin == end) continue;
    LabelPart part;
    part.label = static_cast<std::uint8_t>(label);
    part.triangle_ids.assign(order.begin() + static_cast<std::ptrdiff_t>(begin),
                             order.begin() + static_cast<std::ptrdiff_t>(end));
    part.triangles.reserve(end - begin);
    for (std::uint32_t t : part.triangle_ids) {
      std::array<std::uint32_t, 3> tri{};
      for (std::size_t k = 0; k < 3; ++k) {
        const std::uint32_t v = mesh.triangles[t][k];
        if (index_of[v] == UINT32_MAX) {
          index_of[v] = static_cast<std::uint32_t>(part.vertices.size());
          part.vertices.push_back(v);
        }
        tri[k] = index_of[v];
      }
      part.triangles.push_back(tri);
    }
    for (std::uint32_t v : part.vertices) index_of[v] = UINT32_MAX;
    parts.push_back(std::move(part));
  }
  return parts;
}

LabelPart whole_mesh_part(const imt::SurfaceMesh& mesh, std::uint8_t label) {
  LabelPart part;
  part.label = label;
  part.vertices.resize(mesh.positions.size());
  std::iota(part.vertices.begin(), part.vertices.end(), 0u);
  part.triangle_ids.resize(mesh.triangles.size());
  std::iota(part.triangle_ids.begin(), part.triangle_ids.end(), 0u);
  part.triangles = mesh.triangles;
  return part;
}

}  // namespace tsf::exporter
