// The CRMS spring terms of node_force.h split by angle plane: a node's 12 angles, 6 arms and 6
// linear springs shared among three threads, one per plane, so that a step of a small lattice
// takes a third of the arithmetic on its longest path (the CUDA backend's node-parallel kernel,
// docs/crms.md "Small lattices"). The same arm_of(), angle_reactions() and linear_spring_force()
// as node_spring_terms, grouped differently; CrmsNodeForce.PlaneTermsSumToTheNodeTerms checks
// that the planes add up to node_spring_terms.
#pragma once

#include "tsf/crms/node_force.h"

namespace tsf::crms {

/// The terms of node_spring_terms split by angle plane, for kernels that spread a node over three
/// threads (one per plane) to cut the latency of a step on small lattices. Plane P (its normal
/// axis) holds the arms a−, a+, b− and b+ (slots 0–3, a < b its two axes: plane_arm_direction),
/// its 4 angles, and the linear springs along axis (P + 1) % 3, so every spring and angle belongs
/// to exactly one plane. `reaction[q]` is the force the plane's angles put on the neighbour of
/// arm q, `self` the linear springs plus the plane's own angular terms (−Σ_q reaction[q]); summed
/// over the planes they are node_spring_terms' self and reaction[d] (symmetric form), up to
/// rounding.
TSF_HD_INLINE constexpr int plane_arm_axis(int plane, int which) {
  return which == 0 ? (plane == 0 ? 1 : 0) : (plane == 2 ? 1 : 2);
}
TSF_HD_INLINE constexpr int plane_arm_direction(int plane, int q) {
  return make_direction(plane_arm_axis(plane, q >> 1), (q & 1) ? 1 : -1);
}
/// The arm slot of direction d in a plane that holds d's axis.
TSF_HD_INLINE constexpr int plane_arm_slot(int plane, int d) {
  return 2 * (direction_axis(d) == plane_arm_axis(plane, 0) ? 0 : 1) + (d & 1);
}

template <unsigned kF, int P, class St>
TSF_HD_INLINE void plane_spring_terms(const St& st, const float rest_length[3],
                                      const MaterialPalette& palette,
                                      Vec3<typename St::Scalar>& self,
                                      Vec3<typename St::Scalar> reaction[4]) {
  using S = typename St::Scalar;
  using V = Vec3<S>;
  static_assert(P >= 0 && P < 3, "three angle planes");
  constexpr bool kHetero = (kF & features::kHeterogeneous) != 0;
  const unsigned links = st.flags(0) & kLinkBits;
  const SpringConstants& own = own_constants<kF>(st, palette);
  const V u0 = st.u(0);
  const V v0 = st.v(0);
  Arm<S> arm[4];
  TSF_UNROLL
  for (int q = 0; q < 4; ++q)
    arm[q] = arm_of(st, links, u0, v0, rest_length, plane_arm_direction(P, q));

  V f{S(0), S(0), S(0)};
  constexpr int kLinearAxis = (P + 1) % 3;
  TSF_UNROLL
  for (int q = 0; q < 4; ++q) {
    const int d = plane_arm_direction(P, q);
    if (direction_axis(d) != kLinearAxis) continue;
    float ks = own.ks_linear[kLinearAxis];
    float kd = own.kd_linear[kLinearAxis];
    if constexpr (kHetero) {
      float other_ks = 0.0f, other_kd = 0.0f;
      blend_linear(palette, st.material(face_slot(d)), kLinearAxis, other_ks, other_kd);
      ks = series_stiffness(ks, other_ks);
      kd = series_stiffness(kd, other_kd);
    }
    f += linear_spring_force(arm[q], ks, kd, rest_length[kLinearAxis]);
  }
  TSF_UNROLL
  for (int q = 0; q < 4; ++q) reaction[q] = V{S(0), S(0), S(0)};
  TSF_UNROLL
  for (int l = 0; l < 4; ++l) {  // angle 4P + l: arms (a, (l & 2) ? + : −) and (b, (l & 1) ? + : −)
    const int qa = (l & 2) ? 1 : 0, qb = 2 + (l & 1);
    V on_a, on_c;
    angle_reactions<kF>(arm[qa], arm[qb], own.k_angular[P], own.c_angular[P], on_a, on_c);
    reaction[qa] += on_a;
    reaction[qb] += on_c;
  }
  TSF_UNROLL
  for (int q = 0; q < 4; ++q) f -= reaction[q];
  self = f;
}

}  // namespace tsf::crms
