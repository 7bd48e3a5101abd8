// The CRMS spring force on one node: the one copy of the physics, called by the CPU loop, the
// CUDA kernel, the energy sums and (with dual numbers) the implicit integrator's Jacobian.
//
// Gather form (thesis Eq. 10, DESIGN R3): each node computes the force on itself only:
//   6 linear springs     F += (ks·x + kd·ẋ)·x̂      x = (l − L)/L, ẋ = x̂·(v_A − v_B)/L
//   12 angular springs   F += −(kθ·ψ + cθ·ψ̇)·∇_B ψ  at each right angle (A, B, C) of the node B
// with ψ the deflection of the angle and ∇ its gradient:
//   exact (thesis Eq. 4): ψ = θ0 − acos(û·ŵ) = asin(c), c = û·ŵ, û = BA/|BA|, ŵ = BC/|BC|
//       ∇_A ψ = (ŵ − c·û)/(|BA|·sin θ),  ∇_C ψ = (û − c·ŵ)/(|BC|·sin θ),  ∇_B ψ = −(∇_A ψ + ∇_C ψ)
//   cosine (features::kCosineAngular): ψ = c, the same gradients without 1/sin θ; U = ½kθ·cos²θ
//       has the same stiffness at 90° and needs neither asin nor a square root per angle.
// At rest with equal arms ∇_B ψ is along the bisector (BA + BC) with magnitude √2/h, i.e. the
// thesis's ks2·δ·d̂ with ks2 = kθ·√2/h (spring_constants.h).
//
// features::kSymmetricReactions adds, for each angle (A = this node, B = a neighbour, C = B's
// other arm), the arm reaction −(kθ·ψ + cθ·ψ̇)·∇_A ψ. Then the angular forces of every angle sum
// to zero and are the gradient of Σ ½kθψ² (conservative, momentum preserving), at the cost of
// reading the 12 edge-diagonal nodes. The gather form keeps only the vertex terms: in the long-wave
// limit that is exactly half of the shear stiffness (calibration.h compensates).
//
// Branch-free on purpose: missing links select the rest geometry and weight 0, so the CPU loop
// vectorizes and CUDA threads at the surface do not diverge.
#pragma once

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/crms/crms_math.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/lattice_geometry.h"
#include "tsf/crms/node_state_view.h"
#include "tsf/crms/spring_constants.h"
#include "tsf/crms/stencil.h"

namespace tsf::crms {

/// Below this sin θ the exact form's 1/sin θ is capped; ∇ψ then shrinks smoothly to zero
/// instead of blowing up at a fully folded (0° or 180°) angle.
constexpr float kMinSinTheta = 1e-3f;

/// Series combination of two half-springs (each node's material fills half the spring).
template <typename S>
TSF_HD_INLINE S series_stiffness(S a, S b) {
  const S sum = a + b;
  return sum > S(0) ? S(2) * a * b / sum : S(0);
}

/// One angle's generalised deflection ψ and the factor σ of its gradients (see header).
template <unsigned kF, typename S>
TSF_HD_INLINE void angle_deflection(S c, S& psi, S& sigma) {
  if constexpr ((kF & features::kCosineAngular) != 0) {
    psi = c;
    sigma = S(1);
  } else {
    psi = crms_asin(c);
    const S s2 = crms_max(S(1) - c * c, S(kMinSinTheta * kMinSinTheta));
    sigma = S(1) / crms_sqrt(s2);
  }
}

/// Arm data of a node: unit vectors, inverse lengths, relative velocities, presence weights.
template <typename S>
struct NodeArms {
  Vec3<S> dir[6];  ///< unit vector from the node to neighbour d (rest direction when absent)
  S inv_len[6];    ///< 1/|arm|, 1/mm
  S len[6];        ///< |arm|, mm
  S stretch[6];    ///< |arm| − rest length, mm, computed without cancellation (see load_arms)
  Vec3<S> dv[6];   ///< v_neighbour − v_node, mm/s (0 when absent)
  S w[6];          ///< 1 when the link exists, else 0
};

/// Builds the 6 arms of the stencil's centre node from its link bits.
template <class St>
TSF_HD_INLINE void load_arms(const St& st, unsigned links, const float rest_length[3],
                             NodeArms<typename St::Scalar>& arms) {
  using S = typename St::Scalar;
  using V = Vec3<S>;
  const V u0 = st.u(0);
  const V v0 = st.v(0);
  TSF_UNROLL
  for (int d = 0; d < 6; ++d) {
    const int ax = direction_axis(d);
    const bool on = ((links >> d) & 1u) != 0;
    V rest{S(0), S(0), S(0)};
    rest[ax] = S(direction_sign(d) * rest_length[ax]);
    const V du = select(on, st.u(face_slot(d)) - u0, V{S(0), S(0), S(0)});
    const V r = rest + du;
    const S l = crms_max(crms_length(r), S(1e-6f * rest_length[ax]));
    arms.len[d] = l;
    // l − L = (l² − L²)/(l + L) with l² − L² = 2·rest·du + du·du: no subtraction of two numbers
    // near L, so small strains keep full float precision (and the CPU and CUDA backends, whose
    // roundings differ, agree to ~1e-6 instead of ~1e-3).
    const S rest_dot_du = S(direction_sign(d) * rest_length[ax]) * du[ax];
    arms.stretch[d] = (S(2) * rest_dot_du + dot(du, du)) / (l + S(rest_length[ax]));
    arms.inv_len[d] = S(1) / l;
    arms.dir[d] = r * arms.inv_len[d];
    arms.dv[d] = select(on, st.v(face_slot(d)) - v0, V{S(0), S(0), S(0)});
    arms.w[d] = on ? S(1) : S(0);
  }
}

/// Spring force on the stencil's centre node, µN (no gravity, no external force).
template <unsigned kF, class St>
TSF_HD_INLINE Vec3<typename St::Scalar> spring_force(const St& st, const float rest_length[3],
                                                     const MaterialPalette& palette) {
  using S = typename St::Scalar;
  using V = Vec3<S>;
  constexpr bool kHetero = (kF & features::kHeterogeneous) != 0;
  const unsigned flags = st.flags(0);
  const unsigned links = flags & kLinkBits;
  const SpringConstants& own = palette.entry[kHetero ? st.material(0) : 0];

  NodeArms<S> arms;
  load_arms(st, links, rest_length, arms);
  V force{S(0), S(0), S(0)};

  // Linear springs.
  TSF_UNROLL
  for (int d = 0; d < 6; ++d) {
    const int ax = direction_axis(d);
    float ks = own.ks_linear[ax];
    float kd = own.kd_linear[ax];
    if constexpr (kHetero) {
      const SpringConstants& other = palette.entry[st.material(face_slot(d))];
      ks = series_stiffness(ks, other.ks_linear[ax]);
      kd = series_stiffness(kd, other.kd_linear[ax]);
    }
    const S inv_rest = S(1.0f / rest_length[ax]);
    const S strain = arms.stretch[d] * inv_rest;
    const S strain_rate = dot(arms.dir[d], arms.dv[d]) * inv_rest;
    force += arms.dir[d] * ((S(ks) * strain + S(kd) * strain_rate) * arms.w[d]);
  }

  // Angular springs at this vertex.
  TSF_UNROLL
  for (int t = 0; t < 12; ++t) {
    int d1 = 0, d2 = 0;
    angle_arms(t, d1, d2);
    const int plane = t >> 2;
    const S c = crms_clamp(dot(arms.dir[d1], arms.dir[d2]), S(-1), S(1));
    S psi, sigma;
    angle_deflection<kF>(c, psi, sigma);
    const V grad_a = (arms.dir[d2] - arms.dir[d1] * c) * (sigma * arms.inv_len[d1]);
    const V grad_c = (arms.dir[d1] - arms.dir[d2] * c) * (sigma * arms.inv_len[d2]);
    const S psi_rate = dot(grad_a, arms.dv[d1]) + dot(grad_c, arms.dv[d2]);
    const S q = S(own.k_angular[plane]) * psi + S(own.c_angular[plane]) * psi_rate;
    force += (grad_a + grad_c) * (q * arms.w[d1] * arms.w[d2]);  // −q·∇_B ψ
  }

  // Reactions of the angles at the neighbours where this node is an arm.
  if constexpr ((kF & features::kSymmetricReactions) != 0) {
    TSF_UNROLL
    for (int d = 0; d < 6; ++d) {
      const unsigned nb_links = st.flags(face_slot(d)) & kLinkBits;
      const V ub = st.u(face_slot(d));
      const V vb = st.v(face_slot(d));
      const SpringConstants& at_b = palette.entry[kHetero ? st.material(face_slot(d)) : 0];
      // Arm B→A (A = this node) is the reverse of this node's arm d.
      const V dir_ba = -arms.dir[d];
      const V dv_ba = -arms.dv[d];
      TSF_UNROLL
      for (int e = 0; e < 6; ++e) {
        if (direction_axis(e) == direction_axis(d)) continue;  // compile-time after unrolling
        const int ax = direction_axis(e);
        const bool on = ((nb_links >> e) & 1u) != 0;
        const int slot = edge_slot(d, e);
        V rest{S(0), S(0), S(0)};
        rest[ax] = S(direction_sign(e) * rest_length[ax]);
        const V r = select(on, rest + (st.u(slot) - ub), rest);
        const S l = crms_max(crms_length(r), S(1e-6f * rest_length[ax]));
        const S inv_l = S(1) / l;
        const V dir_bc = r * inv_l;
        const V dv_bc = select(on, st.v(slot) - vb, V{S(0), S(0), S(0)});
        const S c = crms_clamp(dot(dir_ba, dir_bc), S(-1), S(1));
        S psi, sigma;
        angle_deflection<kF>(c, psi, sigma);
        const V grad_a = (dir_bc - dir_ba * c) * (sigma * arms.inv_len[d]);
        const V grad_c = (dir_ba - dir_bc * c) * (sigma * inv_l);
        const S psi_rate = dot(grad_a, dv_ba) + dot(grad_c, dv_bc);
        const int plane = plane_of_axes(direction_axis(d), ax);
        const S q = S(at_b.k_angular[plane]) * psi + S(at_b.c_angular[plane]) * psi_rate;
        const S weight = on ? arms.w[d] : S(0);
        force -= grad_a * (q * weight);
      }
    }
  }
  return force;
}

/// Elastic energy attributed to the stencil's centre node, nJ (g·mm²/s²):
/// the linear springs towards +x, +y, +z (each spring counted once over the lattice) and the
/// angles at this vertex, U = ½·(ks/L)·(l − L)² + Σ ½·kθ·ψ². For the gather form this is the
/// energy of the potential whose vertex terms the force keeps.
template <unsigned kF, class St>
TSF_HD_INLINE typename St::Scalar elastic_energy(const St& st, const float rest_length[3],
                                                 const MaterialPalette& palette) {
  using S = typename St::Scalar;
  constexpr bool kHetero = (kF & features::kHeterogeneous) != 0;
  const unsigned links = st.flags(0) & kLinkBits;
  const SpringConstants& own = palette.entry[kHetero ? st.material(0) : 0];
  NodeArms<S> arms;
  load_arms(st, links, rest_length, arms);
  S energy = S(0);
  TSF_UNROLL
  for (int ax = 0; ax < 3; ++ax) {
    const int d = make_direction(ax, +1);
    float ks = own.ks_linear[ax];
    if constexpr (kHetero) {
      ks = series_stiffness(ks, palette.entry[st.material(face_slot(d))].ks_linear[ax]);
    }
    const S stretch = arms.stretch[d];
    energy += S(0.5f * ks / rest_length[ax]) * stretch * stretch * arms.w[d];
  }
  TSF_UNROLL
  for (int t = 0; t < 12; ++t) {
    int d1 = 0, d2 = 0;
    angle_arms(t, d1, d2);
    const S c = crms_clamp(dot(arms.dir[d1], arms.dir[d2]), S(-1), S(1));
    S psi, sigma;
    angle_deflection<kF>(c, psi, sigma);
    energy += S(0.5f * own.k_angular[t >> 2]) * psi * psi * arms.w[d1] * arms.w[d2];
  }
  return energy;
}

}  // namespace tsf::crms
