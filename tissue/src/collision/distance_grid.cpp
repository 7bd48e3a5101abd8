#include "tsf/collision/distance_grid.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <unordered_map>

#include "tsf/common/closest_point.h"
#include "tsf/common/error.h"

namespace tsf::collision {
namespace {

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

/// Crossings of the rows of samples parallel to `axis` with the mesh: per row (the two other
/// axes' indices), the coordinates along `axis` where the row passes through a triangle. The row
/// is moved off the sample by a tiny irrational fraction of a spacing so it does not run exactly
/// through the vertices and edges of a mesh built on the same grid.
void row_parity(const std::vector<Vec3d>& v, const std::vector<std::array<std::uint32_t, 3>>& tris,
                const Int3& dims, const Vec3d& origin, double h, int axis,
                std::vector<std::uint8_t>& votes) {
  const int b = (axis + 1) % 3, c = (axis + 2) % 3;
  const double eb = h * 1.2345678e-4, ec = h * 2.7182818e-4;
  const int nb = dims[b], nc = dims[c];
  std::vector<std::vector<double>> rows(static_cast<std::size_t>(nb) * nc);
  for (const auto& t : tris) {
    const Vec3d& p0 = v[t[0]];
    const Vec3d& p1 = v[t[1]];
    const Vec3d& p2 = v[t[2]];
    const double bmin = std::min({p0[b], p1[b], p2[b]}), bmax = std::max({p0[b], p1[b], p2[b]});
    const double cmin = std::min({p0[c], p1[c], p2[c]}), cmax = std::max({p0[c], p1[c], p2[c]});
    const int j0 = std::max(0, static_cast<int>(std::ceil((bmin - origin[b] - eb) / h)));
    const int j1 = std::min(nb - 1, static_cast<int>(std::floor((bmax - origin[b] - eb) / h)));
    const int k0 = std::max(0, static_cast<int>(std::ceil((cmin - origin[c] - ec) / h)));
    const int k1 = std::min(nc - 1, static_cast<int>(std::floor((cmax - origin[c] - ec) / h)));
    for (int k = k0; k <= k1; ++k)
      for (int j = j0; j <= j1; ++j) {
        const double y = origin[b] + j * h + eb, z = origin[c] + k * h + ec;
        // 2D barycentric test in the (b, c) plane.
        const double d0 = (p1[b] - p0[b]) * (z - p0[c]) - (p1[c] - p0[c]) * (y - p0[b]);
        const double d1 = (p2[b] - p1[b]) * (z - p1[c]) - (p2[c] - p1[c]) * (y - p1[b]);
        const double d2 = (p0[b] - p2[b]) * (z - p2[c]) - (p0[c] - p2[c]) * (y - p2[b]);
        const bool neg = d0 < 0 || d1 < 0 || d2<0, pos = d0> 0 || d1 > 0 || d2 > 0;
        if (neg && pos) continue;
        const double area = d0 + d1 + d2;
        if (!(std::fabs(area) > 0)) continue;  // the triangle is edge-on to the row
        const double x = (d1 * p0[axis] + d2 * p1[axis] + d0 * p2[axis]) / area;
        rows[static_cast<std::size_t>(j) + static_cast<std::size_t>(nb) * k].push_back(x);
      }
  }
  for (int k = 0; k < nc; ++k)
    for (int j = 0; j < nb; ++j) {
      std::vector<double>& row =
          rows[static_cast<std::size_t>(j) + static_cast<std::size_t>(nb) * k];
      std::sort(row.begin(), row.end());
      std::size_t crossed = 0;
      for (int i = 0; i < dims[axis]; ++i) {
        const double x = origin[axis] + i * h;
        while (crossed < row.size() && row[crossed] < x) ++crossed;
        if (crossed % 2 == 0) continue;
        int idx[3];
        idx[axis] = i;
        idx[b] = j;
        idx[c] = k;
        ++votes[static_cast<std::size_t>(idx[0]) +
                static_cast<std::size_t>(dims.x) *
                    (static_cast<std::size_t>(idx[1]) + static_cast<std::size_t>(dims.y) * idx[2])];
      }
    }
}

}  // namespace

std::string closed_mesh_problem(std::size_t vertex_count,
                                const std::vector<std::array<std::uint32_t, 3>>& triangles) {
  std::unordered_map<std::uint64_t, int> uses;
  uses.reserve(triangles.size() * 3);
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const auto& tri = triangles[t];
    for (int k = 0; k < 3; ++k)
      if (tri[k] >= vertex_count) {
        std::ostringstream s;
        s << "triangle " << t << " names vertex " << tri[k] << ", but there are " << vertex_count
          << " vertices";
        return s.str();
      }
    for (int k = 0; k < 3; ++k) ++uses[edge_key(tri[k], tri[(k + 1) % 3])];
  }
  for (const auto& [key, n] : uses)
    if (n != 2) {
      std::ostringstream s;
      s << "edge " << (key >> 32) << "–" << (key & 0xffffffffu) << " is used by " << n
        << (n == 1 ? " triangle" : " triangles")
        << " (a closed surface shares every edge between exactly two)";
      return s.str();
    }
  return {};
}

SignedDistanceGrid SignedDistanceGrid::from_closed_mesh(
    const std::vector<Vec3f>& vertices, const std::vector<std::array<std::uint32_t, 3>>& triangles,
    double spacing_mm, double margin_mm) {
  require(std::isfinite(spacing_mm) && spacing_mm > 0,
          "distance grid: the spacing must be > 0 mm, got " + std::to_string(spacing_mm));
  require(triangles.size() >= 4, "distance grid: a closed mesh needs at least 4 triangles, got " +
                                     std::to_string(triangles.size()));
  const std::string open = closed_mesh_problem(vertices.size(), triangles);
  if (!open.empty()) throw Error("distance grid: the mesh is not closed: " + open);
  std::vector<Vec3d> v(vertices.size());
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    v[i] = to_double(vertices[i]);
    require(all_finite(v[i]), "distance grid: vertex " + std::to_string(i) + " is not finite");
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], v[i][a]);
      hi[a] = std::max(hi[a], v[i][a]);
    }
  }
  const double h = spacing_mm;
  const double margin = std::max(std::isfinite(margin_mm) ? margin_mm : 0.0, 2.0 * h);
  SignedDistanceGrid g;
  g.spacing_ = h;
  double samples = 1;
  for (int a = 0; a < 3; ++a) {
    g.origin_[a] = lo[a] - margin;
    const double n = std::ceil((hi[a] - lo[a] + 2 * margin) / h) + 1;
    samples *= n;
    if (!(samples <= static_cast<double>(kMaxSamples))) break;
    g.dims_[a] = static_cast<int>(n);
  }
  if (!(samples <= static_cast<double>(kMaxSamples))) {
    const Vec3d size = hi - lo + Vec3d{2 * margin, 2 * margin, 2 * margin};
    const double fit = std::cbrt(size.x * size.y * size.z / static_cast<double>(kMaxSamples));
    std::ostringstream s;
    s << "distance grid: a body of " << size.x << " × " << size.y << " × " << size.z << " mm at "
      << h << " mm needs more than " << kMaxSamples << " samples; use a spacing of at"
      << " least " << fit << " mm";
    throw Error(s.str());
  }
  const Int3 dims = g.dims_;
  const std::size_t count = static_cast<std::size_t>(dims.volume());
  auto index = [&](int i, int j, int k) {
    return static_cast<std::size_t>(i) +
           static_cast<std::size_t>(dims.x) *
               (static_cast<std::size_t>(j) + static_cast<std::size_t>(dims.y) * k);
  };
  auto point = [&](int i, int j, int k) { return g.origin_ + Vec3d{i * h, j * h, k * h}; };

  // 2: exact distances near each triangle, with the nearest surface point.
  std::vector<Vec3d> nearest(count);
  std::vector<double> dist(count, 1e300);
  const int band = 2;
  for (const auto& t : triangles) {
    const Vec3d &a = v[t[0]], &b = v[t[1]], &c = v[t[2]];
    int r0[3], r1[3];
    for (int ax = 0; ax < 3; ++ax) {
      const double tmin = std::min({a[ax], b[ax], c[ax]}), tmax = std::max({a[ax], b[ax], c[ax]});
      r0[ax] = std::max(0, static_cast<int>(std::floor((tmin - g.origin_[ax]) / h)) - band);
      r1[ax] =
          std::min(dims[ax] - 1, static_cast<int>(std::ceil((tmax - g.origin_[ax]) / h)) + band);
    }
    for (int k = r0[2]; k <= r1[2]; ++k)
      for (int j = r0[1]; j <= r1[1]; ++j)
        for (int i = r0[0]; i <= r1[0]; ++i) {
          const Vec3d p = point(i, j, k);
          double wa, wb, wc;
          const Vec3d y = closest_point_on_triangle(p, a, b, c, wa, wb, wc);
          const double d = length(p - y);
          const std::size_t at = index(i, j, k);
          if (d < dist[at]) {
            dist[at] = d;
            nearest[at] = y;
          }
        }
  }
  // 3: sweeps carry the nearest points outward (forward and backward, twice).
  for (int pass = 0; pass < 4; ++pass) {
    const bool forward = pass % 2 == 0;
    const int step = forward ? 1 : -1;
    for (int k = forward ? 0 : dims.z - 1; k >= 0 && k < dims.z; k += step)
      for (int j = forward ? 0 : dims.y - 1; j >= 0 && j < dims.y; j += step)
        for (int i = forward ? 0 : dims.x - 1; i >= 0 && i < dims.x; i += step) {
          const std::size_t at = index(i, j, k);
          const Vec3d p = point(i, j, k);
          for (int dk = -1; dk <= 1; ++dk)
            for (int dj = -1; dj <= 1; ++dj)
              for (int di = -1; di <= 1; ++di) {
                const int ni = i + di, nj = j + dj, nk = k + dk;
                if (ni < 0 || nj < 0 || nk < 0 || ni >= dims.x || nj >= dims.y || nk >= dims.z)
                  continue;
                const std::size_t from = index(ni, nj, nk);
                if (!(dist[from] < 1e299)) continue;
                const double d = length(p - nearest[from]);
                if (d < dist[at]) {
                  dist[at] = d;
                  nearest[at] = nearest[from];
                }
              }
        }
  }
  nearest.clear();
  nearest.shrink_to_fit();
  // 4: the sign by ray parity, the majority of three axes.
  std::vector<std::uint8_t> votes(count, 0);
  for (int axis = 0; axis < 3; ++axis) row_parity(v, triangles, dims, g.origin_, h, axis, votes);
  g.values_.resize(count);
  std::size_t inside = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const bool in = votes[i] >= 2;
    inside += in;
    g.values_[i] = static_cast<float>(in ? -dist[i] : dist[i]);
  }
  if (inside == 0)
    throw Error("distance grid: the mesh encloses no sample at " + std::to_string(h) +
                " mm (is it thinner than the spacing?)");
  return g;
}

Vec3d SignedDistanceGrid::hi() const {
  return origin_ +
         Vec3d{(dims_.x - 1) * spacing_, (dims_.y - 1) * spacing_, (dims_.z - 1) * spacing_};
}

double SignedDistanceGrid::inside_volume_mm3() const {
  std::size_t n = 0;
  for (float x : values_) n += x < 0.0f;
  return static_cast<double>(n) * spacing_ * spacing_ * spacing_;
}

double SignedDistanceGrid::distance(const Vec3d& p, Vec3d& normal) const {
  // Clamp into the grid; outside it, add the distance to the box (the box's samples lie outside
  // the body by the margin, so the value stays positive and grows away from it).
  Vec3d q = p;
  const Vec3d top = hi();
  Vec3d out{0, 0, 0};
  for (int a = 0; a < 3; ++a) {
    if (q[a] < origin_[a]) {
      out[a] = q[a] - origin_[a];
      q[a] = origin_[a];
    } else if (q[a] > top[a]) {
      out[a] = q[a] - top[a];
      q[a] = top[a];
    }
  }
  int c[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    const double s = (q[a] - origin_[a]) / spacing_;
    c[a] = std::min(std::max(static_cast<int>(std::floor(s)), 0), dims_[a] - 2);
    t[a] = std::min(std::max(s - c[a], 0.0), 1.0);
  }
  double value = 0;
  Vec3d grad{0, 0, 0};
  for (int corner = 0; corner < 8; ++corner) {
    const int o[3] = {corner & 1, (corner >> 1) & 1, (corner >> 2) & 1};
    const double v = sample(c[0] + o[0], c[1] + o[1], c[2] + o[2]);
    double f[3], df[3];
    for (int a = 0; a < 3; ++a) {
      f[a] = o[a] ? t[a] : 1.0 - t[a];
      df[a] = (o[a] ? 1.0 : -1.0) / spacing_;
    }
    value += v * f[0] * f[1] * f[2];
    grad += Vec3d{df[0] * f[1] * f[2], f[0] * df[1] * f[2], f[0] * f[1] * df[2]} * v;
  }
  const double away = length(out);
  if (away > 0) {
    normal = out / away;
    return value + away;
  }
  const double g = length(grad);
  normal = g > 1e-12 ? grad / g : Vec3d{0, 0, 1};
  return value;
}

double posed_grid_distance(const SignedDistanceGrid& grid, const ToolPose& pose, const Vec3d& p,
                           Vec3d& normal) {
  Vec3d n;
  const double d = grid.distance(pose.orientation.apply_inverse(p - pose.position), n);
  normal = pose.orientation.apply(n);
  return d;
}

void posed_grid_bounds(const SignedDistanceGrid& grid, const ToolPose& pose, Vec3d& lo, Vec3d& hi) {
  const Vec3d a = grid.lo(), b = grid.hi();
  lo = {1e300, 1e300, 1e300};
  hi = {-1e300, -1e300, -1e300};
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3d local{corner & 1 ? b.x : a.x, corner & 2 ? b.y : a.y, corner & 4 ? b.z : a.z};
    const Vec3d w = pose.position + pose.orientation.apply(local);
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], w[k]);
      hi[k] = std::max(hi[k], w[k]);
    }
  }
}

}  // namespace tsf::collision
