#include "tsf/crms/stable_time_step.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

}  // namespace

StableTimeStep estimate_stable_time_step(const Lattice& lattice, const MaterialPalette& palette,
                                         bool symmetric_reactions) {
  const LatticeGeometry& g = lattice.geometry();
  const double r = symmetric_reactions ? 2.0 : 1.0;
  StableTimeStep out;
  out.symplectic_euler_s = std::numeric_limits<double>::infinity();
  out.explicit_euler_s = std::numeric_limits<double>::infinity();

  // Damping time over every spring type of every material in use.
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
