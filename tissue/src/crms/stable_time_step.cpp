#include "tsf/crms/stable_time_step.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "tsf/crms/node_force.h"

namespace tsf::crms {
namespace {

double series(double a, double b) {
  return a + b > 0.0 ? 2.0 * a * b / (a + b) : 0.0;
}

/// Explicit Euler bound for one damped mode.
double explicit_euler_bound(double omega, double zeta) {
  if (zeta >= 1.0) return 2.0 / (omega * (zeta + std::sqrt(zeta * zeta - 1.0)));
  return 2.0 * zeta / omega;
}

/// Per node, the volumetric term's contribution to the top mode's stiffness and damping (the same
/// for every axis; see header); empty when there is no term.
struct VolumeRows {
  std::vector<double> stiffness, damping;  // [n]
};

/// The volume gradient of corner q of a cube at rest, mm² (volume_term.h).
Vec3d rest_volume_gradient(int q, const Vec3d& h) {
  const double sx = (q & 1) ? 1.0 : -1.0, sy = ((q >> 1) & 1) ? 1.0 : -1.0,
               sz = (q >> 2) ? 1.0 : -1.0;
  return {0.25 * sx * h.y * h.z, 0.25 * sy * h.x * h.z, 0.25 * sz * h.x * h.y};
}

VolumeRows volume_rows(const Lattice& lattice, const VolumeParameters& vp) {
  VolumeRows rows;
  bool any = false;
  for (int m = 0; m < kMaxMaterials; ++m) any = any || vp.lambda[m] > 0.0f;
  if (!any) return rows;
  const LatticeGeometry& g = lattice.geometry();
  const std::int64_t count = lattice.node_count();
  const std::vector<std::uint8_t> flags = lattice.packed_flags();
  std::vector<std::uint32_t> index(static_cast<std::size_t>(count)),
      weight(static_cast<std::size_t>(count));
  for (std::int64_t n = 0; n < count; ++n) {
    index[n] = lattice.material(n).index;
    weight[n] = lattice.material(n).weight;
  }
  LatticeView lat;
  lat.dims = g.dims;
  lat.count = count;
  lat.stride_y = g.dims.x;
  lat.stride_z = static_cast<std::int64_t>(g.dims.x) * g.dims.y;
  for (int a = 0; a < 3; ++a) lat.rest_length[a] = static_cast<float>(g.spacing[a]);
  lat.flags = flags.data();
  lat.material_index = index.data();
  lat.material_weight = weight.data();
  // Each cube's stiffness and damping (0: no term).
  std::vector<double> cube_k(static_cast<std::size_t>(count), 0.0),
      cube_eta(static_cast<std::size_t>(count), 0.0);
  for_each_volume_cube(lat, vp, [&](std::int64_t c, int, int, int, float k, float eta) {
    cube_k[c] = k;
    cube_eta[c] = eta;
  });
  const double v0 = g.spacing.x * g.spacing.y * g.spacing.z;
  auto free_node = [&](std::int64_t n) { return lattice.alive(n) && !lattice.fixed(n); };
  // Gershgorin on the cubes' Gram matrix S_cd = √(k_c·k_d)/V0·Σ_{n ∈ c∩d, free} g_cn·g_dn/m_n,
  // whose eigenvalues are those of M⁻¹K of the term: a bound on its top mode whatever the
  // polarisation (a lone cube breathes at 1.5·k·h/m; the infinite lattice's top is 4·k·h/m
  // against this row's 6·k·h/m). The row of every cube is charged to its corners (the largest).
  rows.stiffness.assign(static_cast<std::size_t>(count), 0.0);
  rows.damping.assign(static_cast<std::size_t>(count), 0.0);
  for (std::int64_t c = 0; c < count; ++c) {
    if (!(cube_k[c] > 0.0)) continue;
    const Int3 ijk = g.coordinates(c);
    double row_k = 0.0, row_eta = 0.0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const Int3 o{ijk.x + dx, ijk.y + dy, ijk.z + dz};
          if (o.x < 0 || o.y < 0 || o.z < 0 || o.x >= g.dims.x || o.y >= g.dims.y ||
              o.z >= g.dims.z)
            continue;
          const std::int64_t d = g.index(o.x, o.y, o.z);
          if (!(cube_k[d] > 0.0)) continue;
          double overlap = 0.0;  // Σ over the shared free corners of g_cn·g_dn/m_n
          for (int q = 0; q < 8; ++q) {
            const int bit[3] = {q & 1, (q >> 1) & 1, q >> 2};
            const int off[3] = {dx, dy, dz};
            int r = 0;
            bool shared = true;
            for (int a = 0; a < 3; ++a) {
              const int other = bit[a] - off[a];  // the corner's bit in cube d
              shared = shared && (other == 0 || other == 1);
              r |= (other & 1) << a;
            }
            if (!shared) continue;
            const std::int64_t n = cube_corner(lat, c, q);
            if (!free_node(n)) continue;
            overlap += dot(rest_volume_gradient(q, g.spacing), rest_volume_gradient(r, g.spacing)) /
                       static_cast<double>(lattice.mass(n));
          }
          row_k += std::sqrt(cube_k[c] * cube_k[d]) / v0 * std::fabs(overlap);
          row_eta += std::sqrt(cube_eta[c] * cube_eta[d]) / v0 * std::fabs(overlap);
        }
    for (int q = 0; q < 8; ++q) {
      const std::int64_t n = cube_corner(lat, c, q);
      if (!free_node(n)) continue;
      // Back to a stiffness at the node's own mass (ω² = stiffness/m_n, stable_time_step.h).
      const double mass = lattice.mass(n);
      if (row_k * mass > rows.stiffness[n]) {
        rows.stiffness[n] = row_k * mass;
        rows.damping[n] = row_eta * mass;
      }
    }
  }
  return rows;
}

}  // namespace

StableTimeStep estimate_stable_time_step(const Lattice& lattice, const MaterialPalette& palette,
                                         bool symmetric_reactions, const VolumeParameters* volume) {
  const VolumeRows volume_row = volume ? volume_rows(lattice, *volume) : VolumeRows{};
  const LatticeGeometry& g = lattice.geometry();
  const double r = symmetric_reactions ? 2.0 : 1.0;
  StableTimeStep out;
  out.symplectic_euler_s = std::numeric_limits<double>::infinity();
  out.explicit_euler_s = std::numeric_limits<double>::infinity();

  // Damping time over every spring type of every material in use (the volumetric term's is the
  // same τ as its material's springs).
  double tau = std::numeric_limits<double>::infinity();
  for (int m = 0; m < palette.count; ++m) {
    const SpringConstants& s = palette.entry[m];
    for (int a = 0; a < 3; ++a) {
      if (s.ks_linear[a] > 0) tau = std::min(tau, double(s.kd_linear[a]) / double(s.ks_linear[a]));
      if (s.k_angular[a] > 0) tau = std::min(tau, double(s.c_angular[a]) / double(s.k_angular[a]));
    }
  }
  out.damping_time_s = std::isfinite(tau) ? tau : 0.0;

  for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
    if (!lattice.alive(n) || lattice.fixed(n)) continue;
    const SpringConstants own = blend_constants(palette, lattice.material(n));
    const double mass = lattice.mass(n);
    bool link[6];
    for (int d = 0; d < 6; ++d) link[d] = lattice.link(n, d);
    for (int a = 0; a < 3; ++a) {
      double lambda = 0.0, damping = 0.0;
      for (int sign = -1; sign <= 1; sign += 2) {
        const int d = make_direction(a, sign);
        if (!link[d]) continue;
        const SpringConstants other =
            blend_constants(palette, lattice.material(lattice.neighbour(n, d)));
        lambda += 2.0 * series(double(own.ks_linear[a]), double(other.ks_linear[a])) / g.spacing[a];
        damping +=
            2.0 * series(double(own.kd_linear[a]), double(other.kd_linear[a])) / g.spacing[a];
      }
      for (int t = 0; t < kAnglesPerNode; ++t) {
        int d1 = 0, d2 = 0;
        angle_arms(t, d1, d2);
        const int a1 = direction_axis(d1), a2 = direction_axis(d2);
        if ((a1 != a && a2 != a) || !link[d1] || !link[d2]) continue;
        const int b = a1 == a ? a2 : a1;
        const int plane = t >> 2;
        const double hb2 = g.spacing[b] * g.spacing[b];
        lambda += r * 2.0 * double(own.k_angular[plane]) / hb2;
        damping += r * 2.0 * double(own.c_angular[plane]) / hb2;
      }
      if (!volume_row.stiffness.empty()) {
        lambda += volume_row.stiffness[n];
        damping += volume_row.damping[n];
      }
      if (lambda <= 0.0) continue;
      const double omega = std::sqrt(lambda / mass);
      const double zeta = damping / (2.0 * std::sqrt(lambda * mass));
      const double symplectic = 2.0 / omega * (std::sqrt(1.0 + zeta * zeta) - zeta);
      if (symplectic < out.symplectic_euler_s) {
        out.symplectic_euler_s = symplectic;
        out.critical_node = n;
      }
      if (omega > out.omega_max) {
        out.omega_max = omega;
        out.zeta_at_omega_max = zeta;
      }
      out.explicit_euler_s = std::min(out.explicit_euler_s, explicit_euler_bound(omega, zeta));
    }
  }
  if (!std::isfinite(out.symplectic_euler_s)) {
    // No springs at all (isolated or fixed nodes): any step is stable for the springs; gravity
    // and constraints do not limit dt.
    out.symplectic_euler_s = std::numeric_limits<double>::max();
    out.explicit_euler_s = std::numeric_limits<double>::max();
    return out;
  }
  out.explicit_euler_s = std::min(out.explicit_euler_s, out.damping_time_s);
  return out;
}

}  // namespace tsf::crms
