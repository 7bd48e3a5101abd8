// Per-node queries of the CRMS state, one copy for the CPU loops and the CUDA kernels: the
// energy a node contributes (Solver::energy) and its tissue-space position (positions,
// snapshots). The backends differ only in how they sum (docs/crms.md, "Integrators"):
//   kinetic        T_n = ½·m_n·|v_n|²
//   elastic        U_n = Σ_{springs n → n+x,y,z} ½·(ks/L)·(l − L)² + Σ_{angles at n} ½·kθ·ψ²
//                  (elastic_energy in node_force.h: each spring and angle counted once)
//   gravitational  V_n = −m_n·g·u_n (fixed nodes: 0; 0 at rest)
//   position       x_n = origin + (i·hx, j·hy, k·hz) + u_n
// and the stability monitor's velocity signals (stability_monitor.h), summed over the moving
// nodes (alive, not fixed) from a node's velocity v0 before and v1 after a call's last step.
#pragma once

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/crms/node_force.h"
#include "tsf/crms/node_state_view.h"
#include "tsf/crms/velocity_signals.h"

namespace tsf::crms {

/// One node's energy terms, nJ (g·mm²/s²); evaluated in double from the float state.
struct NodeEnergy {
  double kinetic = 0;
  double elastic = 0;
  double gravitational = 0;
};

/// The energy terms of the stencil's centre node (zero for a dead node).
template <unsigned kF, class St>
TSF_HD_INLINE NodeEnergy node_energy(const St& st, const float rest_length[3],
                                     const StepParameters& p) {
  NodeEnergy e;
  const unsigned flags = st.flags(0);
  if ((flags & kAliveBit) == 0) return e;
  e.elastic = static_cast<double>(elastic_energy<kF>(st, rest_length, p.palette));
  const double m = 1.0 / static_cast<double>(st.inv_mass());
  const Vec3d v = to_double(st.v(0)), u = to_double(st.u(0));
  e.kinetic = 0.5 * m * dot(v, v);
  if ((flags & kFixedBit) == 0) e.gravitational = -m * dot(to_double(p.gravity), u);
  return e;
}

/// Rest position of node (i, j, k) plus its displacement, mm, evaluated in R (double on the
/// host, float on the device) and rounded to float.
template <class R>
TSF_HD_INLINE Vec3f node_position(const Vec3<R>& origin, const Vec3<R>& spacing, int i, int j,
                                  int k, const Vec3f& u) {
  return {static_cast<float>(origin.x + static_cast<R>(i) * spacing.x + static_cast<R>(u.x)),
          static_cast<float>(origin.y + static_cast<R>(j) * spacing.y + static_cast<R>(u.y)),
          static_cast<float>(origin.z + static_cast<R>(k) * spacing.z + static_cast<R>(u.z))};
}

/// Adds one node (any node: only moving ones count) with mass m, g.
TSF_HD_INLINE void add_velocity_signals(unsigned flags, double m, const Vec3d& v0, const Vec3d& v1,
                                        double velocity_limit, double k_sys, VelocitySignals& s) {
  if ((flags & (kAliveBit | kFixedBit)) != kAliveBit) return;
  const double speed = crms_sqrt(dot(v1, v1));
  s.moving += 1;
  if (velocity_limit > 0 && speed >= 0.999 * velocity_limit) s.at_limit += 1;
  s.drag_power += m * k_sys * speed * speed * speed;
  s.v1v1 += m * dot(v1, v1);
  s.v0v1 += m * dot(v0, v1);
  s.v0v0 += m * dot(v0, v0);
}

}  // namespace tsf::crms
