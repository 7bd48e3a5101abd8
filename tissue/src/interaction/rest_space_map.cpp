#include "tsf/interaction/rest_space_map.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tsf/coupler/cube_corners.h"

namespace tsf::interaction {
namespace {

struct CubeTry {
  Int3 cell{};
  double w[3] = {0.5, 0.5, 0.5};
  double residual = std::numeric_limits<double>::infinity();
  double out_of_range = std::numeric_limits<double>::infinity();
  Vec3d axes[3];
  std::uint32_t sources = 0;
  bool valid = false;
};

/// Trilinear map of 8 corners (double) and its columns ∂φ/∂w.
Vec3d trilinear(const Vec3d q[8], const double w[3], Vec3d axes[3]) {
  const double x = w[0], y = w[1], z = w[2], mx = 1 - x, my = 1 - y, mz = 1 - z;
  axes[0] = (q[1] - q[0]) * (my * mz) + (q[3] - q[2]) * (y * mz) + (q[5] - q[4]) * (my * z) +
            (q[7] - q[6]) * (y * z);
  axes[1] = (q[2] - q[0]) * (mx * mz) + (q[3] - q[1]) * (x * mz) + (q[6] - q[4]) * (mx * z) +
            (q[7] - q[5]) * (x * z);
  axes[2] = (q[4] - q[0]) * (mx * my) + (q[5] - q[1]) * (x * my) + (q[6] - q[2]) * (mx * y) +
            (q[7] - q[3]) * (x * y);
  Vec3d p{0, 0, 0};
  for (int c = 0; c < 8; ++c) {
    const double wx = (c & 1) ? x : mx, wy = (c & 2) ? y : my, wz = (c & 4) ? z : mz;
    p += q[c] * (wx * wy * wz);
  }
  return p;
}

/// Solves [a0 a1 a2]·s = r (columns); false when singular.
bool solve3(const Vec3d a[3], const Vec3d& r, double s[3]) {
  const double det = dot(a[0], cross(a[1], a[2]));
  const double scale = length(a[0]) * length(a[1]) * length(a[2]);
  if (!(std::fabs(det) > 1e-12 * scale) || !std::isfinite(det)) return false;
  s[0] = dot(r, cross(a[1], a[2])) / det;
  s[1] = dot(a[0], cross(r, a[2])) / det;
  s[2] = dot(a[0], cross(a[1], r)) / det;
  return true;
}

bool valid_cell(const crms::LatticeGeometry& g, const Int3& c) {
  for (int a = 0; a < 3; ++a) {
    const int top = g.dims[a] >= 2 ? g.dims[a] - 2 : 0;
    if (c[a] < 0 || c[a] > top) return false;
  }
  return true;
}

}  // namespace

RestPoint map_to_rest(const collision::NodeNeighbourhood& nb, coupler::VertexBinder& binder,
                      const crms::LatticeGeometry& g, const Vec3d& x) {
  RestPoint out;
  out.rest = x;
  if (nb.size() == 0 || !all_finite(x)) return out;
  coupler::DeformedLatticeView view;
  view.dims = g.dims;
  view.stride_y = g.dims.x;
  view.stride_z = static_cast<std::int64_t>(g.dims.x) * g.dims.y;
  for (int a = 0; a < 3; ++a) {
    view.origin[a] = static_cast<float>(g.origin[a]);
    view.spacing[a] = static_cast<float>(g.spacing[a]);
  }
  const collision::NeighbourhoodReader reader{&nb, view, nullptr};

  std::size_t nearest = 0;
  double best_d2 = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < nb.size(); ++i) {
    const Vec3d p = g.rest_position(nb.nodes[i]) + to_double(nb.displacement[i]);
    const double d2 = length_squared(p - x);
    if (d2 < best_d2) {
      best_d2 = d2;
      nearest = i;
    }
  }
  out.found = true;
  out.nearest_node_mm = std::sqrt(best_d2);
  const float h[3] = {view.spacing[0], view.spacing[1], view.spacing[2]};

  auto try_cube = [&](const Int3& cell, int anchor_bit) {
    CubeTry t;
    t.cell = cell;
    const std::uint32_t sources = binder.connected_sources(cell, anchor_bit);
    t.sources = sources;
    if (sources == 0) return t;
    Vec3f qf[8];
    coupler::resolve_cube_corners(reader, cell, h, sources, qf);
    Vec3d q[8];
    for (int c = 0; c < 8; ++c) q[c] = to_double(qf[c]);
    const Vec3d xr = x - g.rest_position(cell.x, cell.y, cell.z);
    const double tol = 1e-9 * g.min_spacing();
    for (int it = 0; it < 40; ++it) {
      const Vec3d p = trilinear(q, t.w, t.axes);
      const Vec3d r = p - xr;
      t.residual = length(r);
      if (t.residual < tol) break;
      double s[3];
      if (!solve3(t.axes, r, s)) break;
      for (int a = 0; a < 3; ++a) t.w[a] = std::clamp(t.w[a] - s[a], -3.0, 4.0);
    }
    trilinear(q, t.w, t.axes);
    t.out_of_range = 0;
    for (int a = 0; a < 3; ++a) t.out_of_range += std::max({0.0, -t.w[a], t.w[a] - 1.0});
    t.valid = std::isfinite(t.residual);
    return t;
  };
  auto better = [](const CubeTry& a, const CubeTry& b) {
    if (!b.valid) return a.valid;
    if (!a.valid) return false;
    const bool ai = a.out_of_range < 1e-6, bi = b.out_of_range < 1e-6;
    if (ai != bi) return ai;
    if (!ai && std::fabs(a.out_of_range - b.out_of_range) > 1e-9)
      return a.out_of_range < b.out_of_range;
    return a.residual < b.residual;
  };

  const Int3 m = g.coordinates(nb.nodes[nearest]);
  CubeTry best;
  for (int o = 0; o < 8; ++o) {
    const Int3 cell{m.x - coupler::corner_bit(o, 0), m.y - coupler::corner_bit(o, 1),
                    m.z - coupler::corner_bit(o, 2)};
    if (!valid_cell(g, cell)) continue;
    const CubeTry t = try_cube(cell, o);
    if (better(t, best)) best = t;
  }
  // Walk towards the cube w points to.
  for (int walk = 0; walk < 4 && best.valid && best.out_of_range >= 1e-6; ++walk) {
    Int3 next = best.cell;
    for (int a = 0; a < 3; ++a) next[a] += best.w[a] < 0 ? -1 : (best.w[a] > 1 ? 1 : 0);
    for (int a = 0; a < 3; ++a) {
      const int top = g.dims[a] >= 2 ? g.dims[a] - 2 : 0;
      next[a] = std::clamp(next[a], 0, top);
    }
    if (next == best.cell) break;
    // Anchor: the gathered corner of the next cube nearest to x.
    int anchor = -1;
    double ad = std::numeric_limits<double>::infinity();
    for (int c = 0; c < 8; ++c) {
      const Int3 p{next.x + coupler::corner_bit(c, 0), next.y + coupler::corner_bit(c, 1),
                   next.z + coupler::corner_bit(c, 2)};
      if (!g.contains(p.x, p.y, p.z)) continue;
      const std::ptrdiff_t at = nb.find(p.x, p.y, p.z, g.dims);
      if (at < 0) continue;
      const double d = length_squared(g.rest_position(p.x, p.y, p.z) +
                                      to_double(nb.displacement[static_cast<std::size_t>(at)]) - x);
      if (d < ad) {
        ad = d;
        anchor = c;
      }
    }
    if (anchor < 0) break;
    const CubeTry t = try_cube(next, anchor);
    if (!better(t, best)) break;
    best = t;
  }
  if (!best.valid) {
    // No usable cube: translate by the nearest node's displacement.
    out.rest = x - to_double(nb.displacement[nearest]);
    return out;
  }
  // Beyond [−1, 2] the trilinear polynomial is no longer a faithful extension of the cube:
  // continue linearly with the map's Jacobian at the clamped point.
  double w[3];
  bool clamped = false;
  for (int a = 0; a < 3; ++a) {
    w[a] = std::clamp(best.w[a], -1.0, 2.0);
    clamped = clamped || w[a] != best.w[a];
  }
  if (clamped) {
    const Int3 c = best.cell;
    Vec3f qf[8];
    coupler::resolve_cube_corners(reader, c, h, best.sources, qf);
    Vec3d q[8];
    for (int k = 0; k < 8; ++k) q[k] = to_double(qf[k]);
    const Vec3d xr = x - g.rest_position(c.x, c.y, c.z);
    const Vec3d p = trilinear(q, w, best.axes);
    double s[3];
    if (solve3(best.axes, xr - p, s))
      for (int a = 0; a < 3; ++a) w[a] += s[a];
  }
  const Vec3d r = g.rest_position(best.cell.x, best.cell.y, best.cell.z);
  out.rest = {r.x + w[0] * g.spacing.x, r.y + w[1] * g.spacing.y, r.z + w[2] * g.spacing.z};
  out.inside_cube = best.out_of_range < 1e-6;
  out.residual_mm = best.residual;
  out.cell = g.index(best.cell.x, best.cell.y, best.cell.z);
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col)
      out.gradient[static_cast<std::size_t>(3 * row + col)] = best.axes[col][row] / g.spacing[col];
  return out;
}

Rotation rest_orientation(const Rotation& world, const std::array<double, 9>& F) {
  // F⁻¹ by cofactors.
  const double a = F[0], b = F[1], c = F[2], d = F[3], e = F[4], f = F[5], gg = F[6], h = F[7],
               i = F[8];
  const double det = a * (e * i - f * h) - b * (d * i - f * gg) + c * (d * h - e * gg);
  if (!(std::fabs(det) > 1e-12) || !std::isfinite(det)) return world;
  const double inv[9] = {(e * i - f * h) / det,  (c * h - b * i) / det,  (b * f - c * e) / det,
                         (f * gg - d * i) / det, (a * i - c * gg) / det, (c * d - a * f) / det,
                         (d * h - e * gg) / det, (b * gg - a * h) / det, (a * e - b * d) / det};
  auto apply_inv = [&](const Vec3d& v) {
    return Vec3d{inv[0] * v.x + inv[1] * v.y + inv[2] * v.z,
                 inv[3] * v.x + inv[4] * v.y + inv[5] * v.z,
                 inv[6] * v.x + inv[7] * v.y + inv[8] * v.z};
  };
  const Vec3d ax = apply_inv(world.apply({1, 0, 0}));
  const Vec3d ay = apply_inv(world.apply({0, 1, 0}));
  const Vec3d x = normalized_or_zero(ax);
  const Vec3d y = normalized_or_zero(ay - x * dot(ay, x));
  if (length_squared(x) < 0.5 || length_squared(y) < 0.5) return world;
  const Vec3d z = cross(x, y);
  // Rotation matrix with columns x, y, z → quaternion.
  const double m00 = x.x, m10 = x.y, m20 = x.z, m01 = y.x, m11 = y.y, m21 = y.z, m02 = z.x,
               m12 = z.y, m22 = z.z;
  const double trace = m00 + m11 + m22;
  Rotation q;
  if (trace > 0) {
    const double s = 0.5 / std::sqrt(trace + 1.0);
    q = {0.25 / s, (m21 - m12) * s, (m02 - m20) * s, (m10 - m01) * s};
  } else if (m00 > m11 && m00 > m22) {
    const double s = 2.0 * std::sqrt(1.0 + m00 - m11 - m22);
    q = {(m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s};
  } else if (m11 > m22) {
    const double s = 2.0 * std::sqrt(1.0 + m11 - m00 - m22);
    q = {(m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m22 - m00 - m11);
    q = {(m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s};
  }
  return q.normalized();
}

}  // namespace tsf::interaction
