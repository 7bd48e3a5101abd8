#include "tsf/imt/mesh_smoothing.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "tsf/common/error.h"

namespace tsf::imt {

void TaubinOptions::validate() const {
  require(iterations >= 0 && iterations <= 100000,
          "smoothing iterations must lie in [0, 100000], got " + std::to_string(iterations));
  require(std::isfinite(lambda) && lambda > 0.0f && lambda < 1.0f,
          "smoothing lambda must lie in (0, 1), got " + std::to_string(lambda));
  require(std::isfinite(mu) && mu < -lambda && mu > -1.0f,
          "smoothing mu must lie in (-1, -lambda), got " + std::to_string(mu));
}

namespace {

/// Vertex neighbours through triangle edges, compressed rows, each row sorted and unique.
struct Neighbours {
  std::vector<std::uint32_t> first, index;
};

Neighbours neighbours_of(const SurfaceMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  std::vector<std::uint64_t> pairs;
  pairs.reserve(mesh.triangles.size() * 6);
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t a = t[static_cast<std::size_t>(k)],
                          b = t[static_cast<std::size_t>((k + 1) % 3)];
      if (a == b) continue;
      pairs.push_back((a << 32) | b);
      pairs.push_back((b << 32) | a);
    }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  Neighbours n;
  n.first.assign(nv + 1, 0);
  n.index.resize(pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    ++n.first[(pairs[i] >> 32) + 1];
    n.index[i] = static_cast<std::uint32_t>(pairs[i] & 0xffffffffu);
  }
  for (std::size_t v = 0; v < nv; ++v) n.first[v + 1] += n.first[v];
  return n;
}

void laplacian_step(const Neighbours& n, const std::vector<Vec3f>& in, std::vector<Vec3f>& out,
                    float factor) {
  const auto nv = static_cast<std::int64_t>(in.size());
#pragma omp parallel for schedule(static) if (nv > 20000)
  for (std::int64_t v = 0; v < nv; ++v) {
    const std::uint32_t b = n.first[static_cast<std::size_t>(v)],
                        e = n.first[static_cast<std::size_t>(v) + 1];
    const Vec3f p = in[static_cast<std::size_t>(v)];
    if (b == e) {
      out[static_cast<std::size_t>(v)] = p;
      continue;
    }
    Vec3d mean{};
    for (std::uint32_t i = b; i < e; ++i) mean += to_double(in[n.index[i]]);
    mean = mean / static_cast<double>(e - b);
    out[static_cast<std::size_t>(v)] =
        to_float(to_double(p) + (mean - to_double(p)) * static_cast<double>(factor));
  }
}

}  // namespace

void smooth_taubin(SurfaceMesh& mesh, const TaubinOptions& options) {
  options.validate();
  if (options.iterations == 0 || mesh.triangles.empty()) return;
  const Neighbours n = neighbours_of(mesh);
  std::vector<Vec3f> tmp(mesh.positions.size());
  for (int it = 0; it < options.iterations; ++it) {
    laplacian_step(n, mesh.positions, tmp, options.lambda);
    laplacian_step(n, tmp, mesh.positions, options.mu);
  }
  if (!mesh.normals.empty()) compute_area_weighted_normals(mesh);
}

void compute_area_weighted_normals(SurfaceMesh& mesh) {
  std::vector<Vec3d> sum(mesh.positions.size());
  for (const auto& t : mesh.triangles) {
    const Vec3d a = to_double(mesh.positions[t[0]]);
    const Vec3d n = cross(to_double(mesh.positions[t[1]]) - a, to_double(mesh.positions[t[2]]) - a);
    for (std::uint32_t v : t) sum[v] += n;
  }
  mesh.normals.resize(mesh.positions.size());
  for (std::size_t v = 0; v < sum.size(); ++v)
    mesh.normals[v] = to_float(normalized_or_zero(sum[v], 1e-300));
}

double enclosed_volume(const SurfaceMesh& mesh) {
  double v = 0;
  for (const auto& t : mesh.triangles) {
    const Vec3d a = to_double(mesh.positions[t[0]]), b = to_double(mesh.positions[t[1]]),
                c = to_double(mesh.positions[t[2]]);
    v += dot(a, cross(b, c));
  }
  return v / 6.0;
}

}  // namespace tsf::imt
