// The CRMS spring forces: the one copy of the physics, called by the CPU loops, the CUDA kernels,
// the energy sums and (with dual numbers) the implicit integrator's Jacobian.
//
// Per node B (thesis Eq. 10, DESIGN R3):
//   6 linear springs     F_B += (ks·x + kd·ẋ)·x̂      x = (l − L)/L, ẋ = x̂·(v_A − v_B)/L
//   12 angular springs   at each right angle (A, B, C) of the node B, with q = kθ·ψ + cθ·ψ̇:
//                          F_A = −q·∇_A ψ,  F_C = −q·∇_C ψ,  F_B = −q·∇_B ψ = −(F_A + F_C)
// with ψ the deflection of the angle and ∇ its gradients:
//   exact (thesis Eq. 4): ψ = θ0 − acos(û·ŵ) = asin(c), c = û·ŵ, û = BA/|BA|, ŵ = BC/|BC|
//       ∇_A ψ = (ŵ − c·û)/(|BA|·sin θ),  ∇_C ψ = (û − c·ŵ)/(|BC|·sin θ),  ∇_B ψ = −(∇_A ψ + ∇_C ψ)
//   cosine (features::kCosineAngular): ψ = c, the same gradients without 1/sin θ; U = ½kθ·cos²θ
//       has the same stiffness at 90° and needs neither asin nor a square root per angle.
// At rest with equal arms ∇_B ψ is along the bisector (BA + BC) with magnitude √2/h, i.e. the
// thesis's ks2·δ·d̂ with ks2 = kθ·√2/h (spring_constants.h).
//
// Gather form (the thesis): each node keeps only its own terms F_B (vertex terms). Symmetric form
// (features::kSymmetricReactions): each node also receives the arm reactions F_A of the angles at
// its neighbours where it is an arm; then the angular forces of every angle sum to zero and are
// the gradient of Σ ½kθψ² (conservative, momentum preserving). In the long-wave limit the vertex
// terms alone are exactly half of the shear stiffness (calibration.h compensates).
//
// Evaluating every angle once. node_spring_terms() evaluates a node's 6 arms and 12 angles once
// and returns
//   self        the linear springs plus the node's own angular terms (−Σ_d reaction[d]), and
//   reaction[d] Σ F_A over its angles with arm d: the force its angles put on neighbour d;
// the symmetric force on n is then
//   F_n = self_n + Σ_d [link d] · reaction_{n+d}[opposite(d)]                        (two passes)
// so each angle is evaluated once per step instead of three times (once by its vertex, once by
// each arm), and a pass reads only the 7-node stencil. reaction_towards() is one reaction[d]
// alone (4 angles), for halo nodes and for spring_force(), the per-node form that evaluates the
// whole 19-node stencil at once (force queries, energies, the implicit Jacobian, and the
// ForceEvaluation::kPerNode kernels). All of them call the same arm_of() and angle_reactions().
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
    sigma = crms_rsqrt(s2);
  }
}

/// One arm of a node: the spring from the node to its face neighbour in direction d, seen from
/// the node. The arm of the neighbour towards the node is exactly its negation (dir, dv), with
/// the same inv_len and stretch.
template <typename S>
struct Arm {
  Vec3<S> dir;  ///< unit vector from the node to the neighbour (rest direction when absent)
  S inv_len;    ///< 1/|arm|, 1/mm
  S stretch;    ///< |arm| − rest length, mm, computed without cancellation (see arm_of)
  Vec3<S> dv;   ///< v_neighbour − v_node, mm/s (0 when absent)
  S w;          ///< 1 when the link exists, else 0
};

/// The arm of the stencil's centre node in direction d (compile-time or run-time d).
template <class St>
TSF_HD_INLINE Arm<typename St::Scalar> arm_of(const St& st, unsigned links,
                                              const Vec3<typename St::Scalar>& u0,
                                              const Vec3<typename St::Scalar>& v0,
                                              const float rest_length[3], int d) {
  using S = typename St::Scalar;
  using V = Vec3<S>;
  const int ax = direction_axis(d);
  const bool on = ((links >> d) & 1u) != 0;
  const float rest_ax = axis_value(rest_length, ax);
  const float signed_rest = static_cast<float>(direction_sign(d)) * rest_ax;
  V rest{S(0), S(0), S(0)};
  rest[ax] = S(signed_rest);
  const V du = select(on, st.u(face_slot(d)) - u0, V{S(0), S(0), S(0)});
  const V r = rest + du;
  const S floor_len = S(1e-6f * rest_ax);
  const S len2 = crms_max(dot(r, r), floor_len * floor_len);
  Arm<S> arm;
  arm.inv_len = crms_rsqrt(len2);
  const S len = len2 * arm.inv_len;
  // l − L = (l² − L²)/(l + L) with l² − L² = 2·rest·du + du·du: no subtraction of two numbers
  // near L, so small strains keep full float precision (and the CPU and CUDA backends, whose
  // roundings differ, agree to ~1e-6 instead of ~1e-3).
  const S rest_dot_du = S(signed_rest) * du[ax];
  arm.stretch = (S(2) * rest_dot_du + dot(du, du)) * crms_rcp(len + S(rest_ax));
  arm.dir = r * arm.inv_len;
  arm.dv = select(on, st.v(face_slot(d)) - v0, V{S(0), S(0), S(0)});
  arm.w = on ? S(1) : S(0);
  return arm;
}

/// The 6 arms of the stencil's centre node (compile-time directions).
template <typename S>
struct NodeArms {
  Arm<S> arm[6];
};
template <class St>
TSF_HD_INLINE void load_arms(const St& st, unsigned links, const float rest_length[3],
                             NodeArms<typename St::Scalar>& arms) {
  const auto u0 = st.u(0);
  const auto v0 = st.v(0);
  TSF_UNROLL
  for (int d = 0; d < 6; ++d) arms.arm[d] = arm_of(st, links, u0, v0, rest_length, d);
}

/// Linear spring along an arm: the force on the node, µN (its neighbour gets the opposite).
template <typename S>
TSF_HD_INLINE Vec3<S> linear_spring_force(const Arm<S>& arm, float ks, float kd,
                                          float rest_length) {
  const S inv_rest = S(1.0f / rest_length);
  const S strain = arm.stretch * inv_rest;
  const S strain_rate = dot(arm.dir, arm.dv) * inv_rest;
  return arm.dir * ((S(ks) * strain + S(kd) * strain_rate) * arm.w);
}

/// One angle at a vertex with arms a (the lower axis) and c: the forces on the two arm ends,
/// −q·∇_A ψ and −q·∇_C ψ (the vertex gets minus their sum).
template <unsigned kF, typename S>
TSF_HD_INLINE void angle_reactions(const Arm<S>& a, const Arm<S>& c, float k_angular,
                                   float c_angular, Vec3<S>& on_a, Vec3<S>& on_c) {
  const S cosine = crms_clamp(dot(a.dir, c.dir), S(-1), S(1));
  S psi, sigma;
  angle_deflection<kF>(cosine, psi, sigma);
  const Vec3<S> grad_a = (c.dir - a.dir * cosine) * (sigma * a.inv_len);
  const Vec3<S> grad_c = (a.dir - c.dir * cosine) * (sigma * c.inv_len);
  const S psi_rate = dot(grad_a, a.dv) + dot(grad_c, c.dv);
  const S q = (S(k_angular) * psi + S(c_angular) * psi_rate) * (a.w * c.w);
  on_a = grad_a * (-q);
  on_c = grad_c * (-q);
}

/// A node's own spring terms (see header): µN.
template <typename S>
struct NodeSpringTerms {
  Vec3<S> self;         ///< linear springs + the angular terms at this vertex
  Vec3<S> reaction[6];  ///< force of this vertex's angles on face neighbour d (symmetric form)
};

/// The centre node's constants: palette entry 0 (a reference into the palette) for homogeneous
/// tissue, its blend of palette entries (a value) for heterogeneous tissue.
template <unsigned kF, class St>
TSF_HD_INLINE decltype(auto) own_constants(const St& st, const MaterialPalette& palette) {
  if constexpr ((kF & features::kHeterogeneous) != 0) {
    return blend_constants(palette, st.material(0));
  } else {
    return (palette.entry[0]);
  }
}

/// Linear springs + the 12 angles of the stencil's centre node, each evaluated once (7-node
/// stencil). `reaction` is filled for the symmetric form only.
template <unsigned kF, class St>
TSF_HD_INLINE void node_spring_terms(const St& st, const float rest_length[3],
                                     const MaterialPalette& palette,
                                     NodeSpringTerms<typename St::Scalar>& terms) {
  using S = typename St::Scalar;
  using V = Vec3<S>;
  constexpr bool kHetero = (kF & features::kHeterogeneous) != 0;
  constexpr bool kSymmetric = (kF & features::kSymmetricReactions) != 0;
  const unsigned links = st.flags(0) & kLinkBits;
  const SpringConstants& own = own_constants<kF>(st, palette);
  NodeArms<S> arms;
  load_arms(st, links, rest_length, arms);

  V self{S(0), S(0), S(0)};
  TSF_UNROLL
  for (int d = 0; d < 6; ++d) {
    const int ax = direction_axis(d);
    float ks = own.ks_linear[ax];
    float kd = own.kd_linear[ax];
    if constexpr (kHetero) {
      float other_ks = 0.0f, other_kd = 0.0f;
      blend_linear(palette, st.material(face_slot(d)), ax, other_ks, other_kd);
      ks = series_stiffness(ks, other_ks);
      kd = series_stiffness(kd, other_kd);
    }
    self += linear_spring_force(arms.arm[d], ks, kd, rest_length[ax]);
  }

  if constexpr (kSymmetric) {
    TSF_UNROLL
    for (int d = 0; d < 6; ++d) terms.reaction[d] = V{S(0), S(0), S(0)};
  }
  TSF_UNROLL
  for (int t = 0; t < 12; ++t) {
    int d1 = 0, d2 = 0;
    angle_arms(t, d1, d2);
    const int plane = t >> 2;
    V on_a, on_c;
    angle_reactions<kF>(arms.arm[d1], arms.arm[d2], own.k_angular[plane], own.c_angular[plane],
                        on_a, on_c);
    if constexpr (kSymmetric) {
      terms.reaction[d1] += on_a;
      terms.reaction[d2] += on_c;
    } else {
      self -= on_a + on_c;
    }
  }
  if constexpr (kSymmetric) {
    TSF_UNROLL
    for (int d = 0; d < 6; ++d) self -= terms.reaction[d];
  }
  terms.self = self;
}

/// The two angles of reaction_towards() that lie in one of the two planes holding d's axis
/// (q = 0: the plane of lower normal axis, 1: the other), added to r in reaction_towards' order.
/// reaction_towards() is this for q = 0 then q = 1; the CUDA tile kernel splits a halo node's
/// reaction over two threads by q (docs/crms.md "The default kernel against the roofline").
template <unsigned kF, class St>
TSF_HD_INLINE void add_reaction_towards_in_plane(
    const St& st, unsigned links, const SpringConstants& own, const Vec3<typename St::Scalar>& u0,
    const Vec3<typename St::Scalar>& v0, const Arm<typename St::Scalar>& toward, int d, int q,
    const float rest_length[3], Vec3<typename St::Scalar>& r) {
  using S = typename St::Scalar;
  using V = Vec3<S>;
  const int ax = direction_axis(d);
  const int plane = q == 0 ? (ax == 0 ? 1 : 0) : (ax == 2 ? 1 : 2);  // ascending normal (= t order)
  const int other_axis = 3 - ax - plane;
  const float k_angular = axis_value(own.k_angular, plane);
  const float c_angular = axis_value(own.c_angular, plane);
  TSF_UNROLL
  for (int sign = 0; sign < 2; ++sign) {  // the other arm's − then + (= t order)
    const Arm<S> other = arm_of(st, links, u0, v0, rest_length, make_direction(other_axis, sign));
    V on_a, on_c;
    if (ax < other_axis) {
      angle_reactions<kF>(toward, other, k_angular, c_angular, on_a, on_c);
      r += on_a;
    } else {
      angle_reactions<kF>(other, toward, k_angular, c_angular, on_a, on_c);
      r += on_c;
    }
  }
}

/// reaction[d] of node_spring_terms alone: the force that the 4 angles at the stencil's centre
/// node with an arm d put on its neighbour d (d may be a run-time value). Same angles, same
/// order and same arithmetic as node_spring_terms.
template <unsigned kF, class St>
TSF_HD_INLINE Vec3<typename St::Scalar> reaction_towards(const St& st, int d,
                                                         const float rest_length[3],
                                                         const MaterialPalette& palette) {
  using S = typename St::Scalar;
  using V = Vec3<S>;
  const unsigned links = st.flags(0) & kLinkBits;
  const SpringConstants& own = own_constants<kF>(st, palette);
  const V u0 = st.u(0);
  const V v0 = st.v(0);
  const Arm<S> toward = arm_of(st, links, u0, v0, rest_length, d);
  V r{S(0), S(0), S(0)};
  TSF_UNROLL
  for (int q = 0; q < 2; ++q)
    add_reaction_towards_in_plane<kF>(st, links, own, u0, v0, toward, d, q, rest_length, r);
  return r;
}

/// A stencil accessor re-centred on the face neighbour B = n + d of another accessor's centre n:
/// B's centre and its face neighbours opposite(d) (= n) and perpendicular to d (edge-diagonal
/// slots of n). B's neighbour in direction d (n + 2d) is outside the 19-node stencil and never
/// read by reaction_towards(B, opposite(d)).
template <class St>
struct NeighbourStencil {
  using Scalar = typename St::Scalar;
  const St& st;
  int d;

  TSF_HD_INLINE int slot(int s) const {
    if (s == 0) return face_slot(d);
    const int e = s - 1;
    if (e == opposite_direction(d)) return 0;
    if (direction_axis(e) == direction_axis(d)) return face_slot(d);  // not used
    return edge_slot(d, e);
  }
  TSF_HD_INLINE Vec3<Scalar> u(int s) const { return st.u(slot(s)); }
  TSF_HD_INLINE Vec3<Scalar> v(int s) const { return st.v(slot(s)); }
  TSF_HD_INLINE unsigned flags(int s) const { return st.flags(slot(s)); }
  TSF_HD_INLINE MaterialBlend material(int s) const { return st.material(slot(s)); }
};

/// Spring force on the stencil's centre node, µN (no gravity, no external force), evaluated from
/// the whole stencil at once (19 nodes for the symmetric form). Equal to what the two-pass
/// kernels compute (self + the neighbours' reactions), up to rounding.
template <unsigned kF, class St>
TSF_HD_INLINE Vec3<typename St::Scalar> spring_force(const St& st, const float rest_length[3],
                                                     const MaterialPalette& palette) {
  using S = typename St::Scalar;
  using V = Vec3<S>;
  NodeSpringTerms<S> terms;
  node_spring_terms<kF>(st, rest_length, palette, terms);
  V force = terms.self;
  if constexpr ((kF & features::kSymmetricReactions) != 0) {
    const unsigned links = st.flags(0) & kLinkBits;
    TSF_UNROLL
    for (int d = 0; d < 6; ++d) {
      const NeighbourStencil<St> nb{st, d};
      const V r = reaction_towards<kF>(nb, opposite_direction(d), rest_length, palette);
      force += select(((links >> d) & 1u) != 0, r, V{S(0), S(0), S(0)});
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
  const SpringConstants& own = own_constants<kF>(st, palette);
  NodeArms<S> arms;
  load_arms(st, links, rest_length, arms);
  S energy = S(0);
  TSF_UNROLL
  for (int ax = 0; ax < 3; ++ax) {
    const int d = make_direction(ax, +1);
    float ks = own.ks_linear[ax];
    if constexpr (kHetero) {
      float other_ks = 0.0f, other_kd = 0.0f;
      blend_linear(palette, st.material(face_slot(d)), ax, other_ks, other_kd);
      ks = series_stiffness(ks, other_ks);
    }
    const S stretch = arms.arm[d].stretch;
    energy += S(0.5f * ks / rest_length[ax]) * stretch * stretch * arms.arm[d].w;
  }
  TSF_UNROLL
  for (int t = 0; t < 12; ++t) {
    int d1 = 0, d2 = 0;
    angle_arms(t, d1, d2);
    const Arm<S>& a = arms.arm[d1];
    const Arm<S>& c = arms.arm[d2];
    const S cosine = crms_clamp(dot(a.dir, c.dir), S(-1), S(1));
    S psi, sigma;
    angle_deflection<kF>(cosine, psi, sigma);
    energy += S(0.5f * own.k_angular[t >> 2]) * psi * psi * a.w * c.w;
  }
  return energy;
}

}  // namespace tsf::crms
