// One explicit time step of one node: force → acceleration → integration → stability controls →
// NaN/Inf guard. Called by the CPU loop and the CUDA kernel alike.
//
//   a = (F_springs + F_external)/m + g
//   explicit Euler (thesis Eq. 11):  u' = u + v·dt,  v' = v + a·dt
//   symplectic Euler:                v' = v + a·dt,  u' = u + v'·dt
// Stability controls act on the new velocity:
//   kinetic damping k_sys (thesis 5.2.2.1): a speed-dependent drag a = −k_sys·|v|·v, applied
//     implicitly in the speed, v' ← v'/(1 + dt·k_sys·|v'|): never reverses a velocity, removes
//     kinetic energy fastest where motion is fastest, costs nothing at rest;
//   velocity limit (thesis 5.2.2.1): |v'| ≤ v_max.
// Fixed nodes keep their displacement (constraint targets are written into it) and get v = 0;
// dead nodes keep theirs. A node whose new state is not finite keeps its old displacement with
// v = 0 and reports `finite = false`: the solver halts on that step and names the first such
// node instead of letting NaN spread through the springs.
#pragma once

#include <cfloat>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/crms/crms_math.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/node_force.h"
#include "tsf/crms/node_state_view.h"

namespace tsf::crms {

struct NodeStepResult {
  Vec3f u;  ///< new displacement, mm
  Vec3f v;  ///< new velocity, mm/s
  bool finite = true;
};

/// Applies kinetic damping and the velocity limit to a velocity (see header).
TSF_HD_INLINE Vec3f limit_velocity(Vec3f v, float dt, float kinetic_damping, float velocity_limit) {
  const float speed = crms_sqrt(dot(v, v));
  const float drag = 1.0f / (1.0f + dt * kinetic_damping * speed);
  const float damped = speed * drag;
  // The limited scale is computed unconditionally and selected: no division inside a branch, so
  // the CPU loops can if-convert and vectorize it.
  const float limited = drag * velocity_limit / crms_max(damped, FLT_MIN);
  const bool over = velocity_limit > 0.0f && damped > velocity_limit;
  return v * (over ? limited : drag);
}

/// Integrates one node given its spring force (node_force.h), µN: the second half of a step,
/// shared by the per-node kernels and the two-pass kernels.
template <unsigned kF>
TSF_HD_INLINE NodeStepResult integrate_node(unsigned flags, const Vec3f& u, const Vec3f& v,
                                            float inv_mass, const Vec3f& external_force,
                                            const Vec3f& spring_force, const StepParameters& p) {
  Vec3f f = spring_force;
  if constexpr ((kF & features::kExternalForces) != 0) f += external_force;
  const Vec3f a = f * inv_mass + p.gravity;

  NodeStepResult r;
  if (p.scheme == static_cast<int>(ExplicitScheme::kExplicitEuler)) {
    r.u = u + v * p.dt;
    r.v = limit_velocity(v + a * p.dt, p.dt, p.kinetic_damping, p.velocity_limit);
  } else {
    r.v = limit_velocity(v + a * p.dt, p.dt, p.kinetic_damping, p.velocity_limit);
    r.u = u + r.v * p.dt;
  }
  const bool moving = (flags & (kAliveBit | kFixedBit)) == kAliveBit;
  const Vec3f zero{0.0f, 0.0f, 0.0f};
  r.finite = !moving || (crms_finite(r.u) & crms_finite(r.v));
  const bool keep = !moving || !r.finite;
  r.u = select(keep, u, r.u);
  r.v = select(keep, zero, r.v);
  return r;
}

/// A force f (µN) applied after a step, to a moving node's new state (u, v): the effects' kick
/// (docs/effects.md, pass 4). v += dt·f/m within the velocity limit (no kinetic drag: the step
/// applied it) and, with symplectic Euler, u += dt·Δv (the position update the step made with its
/// own part of v). One copy for the effect passes and the CUDA launches that fold the kick into
/// their step.
TSF_HD_INLINE void kick_after_step(Vec3f& u, Vec3f& v, const Vec3f& f, float inv_mass, float dt,
                                   float velocity_limit, bool symplectic) {
  const Vec3f before = v;
  v = limit_velocity(before + f * (dt * inv_mass), dt, 0.0f, velocity_limit);
  if (symplectic)
    for (int a = 0; a < 3; ++a) u[a] += dt * (v[a] - before[a]);
}

/// One whole step of the stencil's centre node from its whole stencil (per-node evaluation).
template <unsigned kF, class St>
TSF_HD_INLINE NodeStepResult step_node(const St& st, const float rest_length[3],
                                       const StepParameters& p) {
  Vec3f external{0.0f, 0.0f, 0.0f};
  if constexpr ((kF & features::kExternalForces) != 0) external = st.external_force();
  return integrate_node<kF>(st.flags(0), st.u(0), st.v(0), st.inv_mass(), external,
                            spring_force<kF>(st, rest_length, p.palette), p);
}

}  // namespace tsf::crms
