// The volumetric term of the CRMS lattice: the Poisson response the springs cannot give
// (docs/effects.md, "Volumetric term (Poisson ratio)"; derivation in docs/crms.md, "Calibration").
// One copy of the per-cube math, TSF_HD and templated on the scalar: the effect passes run it in
// float (cpu_effects.cpp, cuda_effects.cu), the implicit integrator and the static solver of the
// accuracy report with dual numbers for their exact Jacobians.
//
// Cube c = the 8 nodes (i..i+1, j..j+1, k..k+1), corner q = (a, b, c) bits (q & 1, q >> 1 & 1,
// q >> 2): node (i + a, j + b, k + c). A cube is *intact* when its 8 corners are alive and its 12
// edge springs linked (a cut or a tear removes its term). Edge vectors averaged over the 4
// parallel edges, e_x = h_x·x̂ + ¼Σ(u_{1bc} − u_{0bc}) (likewise y, z), volume V = e_x·(e_y × e_z)
// (exact for parallelepipeds; V0 = h_x·h_y·h_z), J = V/V0. Corner q's volume gradient
//   ∂V/∂x_q = ¼·(s_a·e_y×e_z + s_b·e_z×e_x + s_c·e_x×e_y),   s = −1 low end, +1 high end.
// Energy and dissipation of a cube (k: stiffness, Pa; η: damping, Pa·s):
//   U = k·V0·φ(J),   φ(J) = ½(J − 1)² (J ≤ 1),   J − 1 − ln J (J > 1)
//   F_q = −∂U/∂x_q − η·φ''(J)·J̇·∂V/∂x_q = π·∂V/∂x_q,   π = −k·φ'(J) − η·φ''(J)·J̇
// with φ'(J) = J − 1 or 1 − 1/J, φ''(J) = 1 or 1/J², J̇ = Σ_q ∂V/∂x_q·v_q / V0. φ is C² at J = 1
// (so small strains see ½k(ΔV/V0)²V0 = ½k(tr ε)²V0: the Lamé-λ energy when k = λ); under
// stretch (J > 1) φ'' falls as 1/J², which keeps the tangent stiffness k·φ''·|∂V/∂x|²/V0 from
// growing with the stretched faces (the explicit step stays valid at large deformation); under
// compression the quadratic keeps a collapsing or inverted cube's push finite (π ≤ k·(1 − J)).
// The damping η (default 0: the term is elastic, the material's viscosity acts through the
// springs; a material's volume_damping_time_s τ_v gives η = λ·τ_v, calibration.h) is a
// Kelvin–Voigt rate term scaled by φ'' like the stiffness.
//
// k and η of a cube: the harmonic mean of its corners' λ and λ·τ_v (series, as the linear springs
// combine across a material interface; a corner blended from palette entries takes the weighted
// mean of their values). Every cube counts once: the term covers the node-to-node cubes, not the
// half cells beyond the surface nodes (a 1/n effect on a body n nodes across; weighting the
// surface cubes up to cover them was measured: slightly closer to the FEM, but thin parts and
// lone cubes then breathe 2.5× faster and set the explicit step, docs/effects.md).
#pragma once

#include <cmath>
#include <cstdint>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/crms/crms_math.h"
#include "tsf/crms/lattice_geometry.h"
#include "tsf/crms/node_state_view.h"
#include "tsf/crms/spring_constants.h"

namespace tsf::crms {

/// Per palette entry: Lamé λ (Pa) and the term's viscosity λ·τ_v (Pa·s); λ = 0: no term.
struct VolumeParameters {
  float lambda[kMaxMaterials] = {};
  float damping[kMaxMaterials] = {};
  bool heterogeneous = false;  ///< corners read their blends (else entry 0 everywhere)
};

/// Node index of corner q of the cube with lower corner c.
TSF_HD_INLINE std::int64_t cube_corner(const LatticeView& lat, std::int64_t c, int q) {
  return c + (q & 1) + ((q >> 1) & 1) * lat.stride_y + (q >> 2) * lat.stride_z;
}

/// True when the cube with lower corner (i, j, k) lies inside the lattice with 8 live corners
/// and its 12 edge springs linked.
TSF_HD_INLINE bool cube_intact(const LatticeView& lat, int i, int j, int k) {
  if (i < 0 || j < 0 || k < 0 || i + 1 >= lat.dims.x || j + 1 >= lat.dims.y || k + 1 >= lat.dims.z)
    return false;
  const std::int64_t c = i + j * lat.stride_y + k * lat.stride_z;
  bool intact = true;
  for (int q = 0; q < 8; ++q) {
    const unsigned f = lat.flags[cube_corner(lat, c, q)];
    intact = intact && (f & kAliveBit) != 0;
    // The edges leaving corner q towards the cube's high ends.
    for (int a = 0; a < 3; ++a)
      if (((q >> a) & 1) == 0) intact = intact && ((f >> make_direction(a, 1)) & 1u) != 0;
  }
  return intact;
}

/// J − 1 of a cube and its face vectors ¼·e_y×e_z, ¼·e_z×e_x, ¼·e_x×e_y (mm²), from the 8
/// corners' displacements.
template <class S>
struct CubeShape {
  S strain;         ///< J − 1 = (V − V0)/V0, without cancellation
  Vec3<S> face[3];  ///< ∂V/∂x_q = Σ_a s_a·face[a]
  TSF_HD_INLINE Vec3<S> gradient(int q) const {
    const S one(1);
    return face[0] * ((q & 1) ? one : -one) + face[1] * (((q >> 1) & 1) ? one : -one) +
           face[2] * ((q >> 2) ? one : -one);
  }
};

template <class S>
TSF_HD_INLINE CubeShape<S> cube_shape(const Vec3<S> u[8], const float rest[3]) {
  // d_a = ¼Σ over the 4 edges along a of (u_high − u_low): e_a = h_a·â + d_a.
  Vec3<S> d[3];
  for (int a = 0; a < 3; ++a) {
    d[a] = Vec3<S>{S(0), S(0), S(0)};
    for (int q = 0; q < 8; ++q)
      if (((q >> a) & 1) == 0) d[a] += u[q | (1 << a)] - u[q];
    d[a] = d[a] * S(0.25);
  }
  const S h[3] = {S(rest[0]), S(rest[1]), S(rest[2])};
  Vec3<S> e[3];
  for (int a = 0; a < 3; ++a) {
    e[a] = d[a];
    e[a][a] = e[a][a] + h[a];
  }
  // det(H + D) − det(H) for diagonal H, expanded so that no term cancels (rows d_a):
  //   Σ_i h_j·h_k·D_ii + Σ_i h_i·(D_jj·D_kk − D_jk·D_kj) + det D,   (i, j, k) cyclic.
  S dv(0);
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3, k = (i + 2) % 3;
    dv = dv + h[j] * h[k] * d[i][i] + h[i] * (d[j][j] * d[k][k] - d[j][k] * d[k][j]);
  }
  dv = dv + dot(d[0], cross(d[1], d[2]));
  CubeShape<S> s;
  s.strain = dv / (h[0] * h[1] * h[2]);
  s.face[0] = cross(e[1], e[2]) * S(0.25);
  s.face[1] = cross(e[2], e[0]) * S(0.25);
  s.face[2] = cross(e[0], e[1]) * S(0.25);
  return s;
}

/// The generalised pressure π (Pa) of a cube with J − 1 = strain and J̇ = rate (1/s): the force
/// on corner q is π·∂V/∂x_q (see header).
template <class S>
TSF_HD_INLINE S volume_pressure(const S& strain, const S& rate, float stiffness, float damping) {
  const S j = S(1) + strain;
  if (j <= S(1)) return -S(stiffness) * strain - S(damping) * rate;
  const S inv = S(1) / j;
  return -S(stiffness) * strain * inv - S(damping) * inv * inv * rate;
}

/// φ(J) of the energy U = k·V0·φ(J), from J − 1 (double).
TSF_HD_INLINE double volume_energy_shape(double strain) {
  if (strain <= 0.0) return 0.5 * strain * strain;
#ifdef __CUDA_ARCH__
  return strain - ::log1p(strain);
#else
  return strain - std::log1p(strain);
#endif
}

/// A palette table blended over a node's material (weighted mean of its entries).
TSF_HD_INLINE float blend_table(const float* table, MaterialBlend b) {
  if (b.pure()) return table[b.entry(0)];
  float sum = 0.0f;
  for (int c = 0; c < 4; ++c) {
    const unsigned w = b.weight_of(c);
    if (w != 0u) sum += static_cast<float>(w) * table[b.entry(c)];
  }
  return sum * (1.0f / 255.0f);
}

/// Stiffness k (Pa) and damping η (Pa·s) of the intact cube with lower corner c (see header);
/// k = 0: no term.
TSF_HD_INLINE void cube_moduli(const LatticeView& lat, const VolumeParameters& p, std::int64_t c,
                               float& stiffness, float& damping) {
  if (!p.heterogeneous) {
    stiffness = p.lambda[0];
    damping = p.damping[0];
    return;
  }
  float inv_lambda = 0.0f, inv_damping = 0.0f;
  bool any_zero = false, damping_zero = false;
  for (int q = 0; q < 8; ++q) {
    const MaterialBlend b = node_material(lat, cube_corner(lat, c, q));
    const float lambda = blend_table(p.lambda, b), eta = blend_table(p.damping, b);
    any_zero = any_zero || !(lambda > 0.0f);
    damping_zero = damping_zero || !(eta > 0.0f);
    inv_lambda += lambda > 0.0f ? 1.0f / lambda : 0.0f;
    inv_damping += eta > 0.0f ? 1.0f / eta : 0.0f;
  }
  stiffness = any_zero ? 0.0f : 8.0f / inv_lambda;
  damping = any_zero || damping_zero ? 0.0f : 8.0f / inv_damping;
}

/// The cube pass's result for one cube: π·face[a] (µN) for the three face vectors; the force on
/// corner q is Σ_a s_a·π·face[a] (volume_force_from).
struct CubeTerms {
  Vec3f face[3];
};

/// The cube pass for the cube with lower corner c = (i, j, k): zeros when the cube is not intact or
/// has no term. Reads the lattice and the state where they live (any backend, any memory).
TSF_HD_INLINE CubeTerms cube_volume_faces(const LatticeView& lat, const ConstStateView& s,
                                          const VolumeParameters& p, std::int64_t c, int i, int j,
                                          int k) {
  CubeTerms t{{{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}}};
  float stiffness = 0.0f, damping = 0.0f;
  if (cube_intact(lat, i, j, k)) cube_moduli(lat, p, c, stiffness, damping);
  if (stiffness > 0.0f) {
    Vec3f u[8];
    for (int q = 0; q < 8; ++q) {
      const std::int64_t m = cube_corner(lat, c, q);
      u[q] = {s.u[0][m], s.u[1][m], s.u[2][m]};
    }
    const CubeShape<float> shape = cube_shape(u, lat.rest_length);
    float rate = 0.0f;  // J̇, read only when the term is damped
    if (damping > 0.0f) {
      for (int q = 0; q < 8; ++q) {
        const std::int64_t m = cube_corner(lat, c, q);
        rate += dot(shape.gradient(q), Vec3f{s.v[0][m], s.v[1][m], s.v[2][m]});
      }
      rate /= lat.rest_length[0] * lat.rest_length[1] * lat.rest_length[2];
    }
    const float pressure = volume_pressure(shape.strain, rate, stiffness, damping);
    for (int a = 0; a < 3; ++a) t.face[a] = shape.face[a] * pressure;
  }
  return t;
}

/// The cube pass into arrays: terms[3a + component][c] = cube_volume_faces(…).face[a][component].
TSF_HD_INLINE void cube_volume_terms(const LatticeView& lat, const ConstStateView& s,
                                     const VolumeParameters& p, std::int64_t c, int i, int j, int k,
                                     float* const terms[9]) {
  const CubeTerms t = cube_volume_faces(lat, s, p, c, i, j, k);
  for (int a = 0; a < 3; ++a)
    for (int comp = 0; comp < 3; ++comp) terms[3 * a + comp][c] = t.face[a][comp];
}

/// Host loops over the cubes that carry the term (the energy, the implicit integrator's
/// assembly, the stable-step bound): fn(c, i, j, k, stiffness, damping) for every intact cube with
/// k > 0, c its lower corner.
template <class Fn>
inline void for_each_volume_cube(const LatticeView& lat, const VolumeParameters& p, Fn&& fn) {
  for (std::int64_t c = 0; c < lat.count; ++c) {
    const std::int64_t rem = c % lat.stride_z;
    const int i = static_cast<int>(rem % lat.stride_y), j = static_cast<int>(rem / lat.stride_y);
    const int k = static_cast<int>(c / lat.stride_z);
    if (!cube_intact(lat, i, j, k)) continue;
    float stiffness = 0.0f, damping = 0.0f;
    cube_moduli(lat, p, c, stiffness, damping);
    if (stiffness > 0.0f) fn(c, i, j, k, stiffness, damping);
  }
}

/// V0 = h_x·h_y·h_z, mm³.
TSF_HD_INLINE double cube_rest_volume(const LatticeView& lat) {
  return static_cast<double>(lat.rest_length[0]) * static_cast<double>(lat.rest_length[1]) *
         static_cast<double>(lat.rest_length[2]);
}

/// The term's energy k·V0·φ(J) in the intact cube with lower corner c and stiffness k, nJ
/// (double): the host's sum over for_each_volume_cube and the CUDA reduction alike.
TSF_HD_INLINE double intact_cube_volume_energy(const LatticeView& lat, const ConstStateView& s,
                                               std::int64_t c, float stiffness) {
  Vec3<double> u[8];
  for (int q = 0; q < 8; ++q) {
    const std::int64_t m = cube_corner(lat, c, q);
    u[q] = {s.u[0][m], s.u[1][m], s.u[2][m]};
  }
  const CubeShape<double> shape = cube_shape(u, lat.rest_length);
  return static_cast<double>(stiffness) * cube_rest_volume(lat) * volume_energy_shape(shape.strain);
}

/// The same for any cube c = (i, j, k): 0 when it is not intact or has no term (the CUDA
/// reduction runs one thread per cube).
TSF_HD_INLINE double cube_volume_energy(const LatticeView& lat, const ConstStateView& s,
                                        const VolumeParameters& p, std::int64_t c, int i, int j,
                                        int k) {
  if (!cube_intact(lat, i, j, k)) return 0.0;
  float stiffness = 0.0f, damping = 0.0f;
  cube_moduli(lat, p, c, stiffness, damping);
  return stiffness > 0.0f ? intact_cube_volume_energy(lat, s, c, stiffness) : 0.0;
}

/// The volumetric force on node n = (i, j, k), µN: Σ over its (up to 8) cubes of π·∂V/∂x_n, in a
/// fixed order. `terms(c, ci, cj, ck)` gives the cube pass's CubeTerms of the cube with lower
/// corner c = (ci, cj, ck) wherever they are kept (arrays, a thread block's shared memory).
template <class Terms>
TSF_HD_INLINE Vec3f volume_force_from(const LatticeView& lat, std::int64_t n, int i, int j, int k,
                                      const Terms& terms) {
  Vec3f f{0.0f, 0.0f, 0.0f};
  for (int q = 0; q < 8; ++q) {  // n is corner (a, b, c) of the cube at (i − a, j − b, k − c)
    const int a = q & 1, b = (q >> 1) & 1, cz = q >> 2;
    if (i - a < 0 || j - b < 0 || k - cz < 0 || i - a + 1 >= lat.dims.x ||
        j - b + 1 >= lat.dims.y || k - cz + 1 >= lat.dims.z)
      continue;
    const std::int64_t c = n - a - b * lat.stride_y - cz * lat.stride_z;
    const CubeTerms t = terms(c, i - a, j - b, k - cz);
    const float sa = a ? 1.0f : -1.0f, sb = b ? 1.0f : -1.0f, sc = cz ? 1.0f : -1.0f;
    for (int comp = 0; comp < 3; ++comp)
      f[comp] += sa * t.face[0][comp] + sb * t.face[1][comp] + sc * t.face[2][comp];
  }
  return f;
}

/// The cube pass's arrays as volume_force_from's source (terms[3a + component][c]).
struct ArrayCubeTerms {
  float* const* terms;
  TSF_HD_INLINE CubeTerms operator()(std::int64_t c, int, int, int) const {
    CubeTerms t;
    for (int a = 0; a < 3; ++a)
      t.face[a] = {terms[3 * a][c], terms[3 * a + 1][c], terms[3 * a + 2][c]};
    return t;
  }
};

/// The same from the cube pass's arrays.
TSF_HD_INLINE Vec3f volume_force(const LatticeView& lat, float* const terms[9], std::int64_t n,
                                 int i, int j, int k) {
  return volume_force_from(lat, n, i, j, k, ArrayCubeTerms{terms});
}

}  // namespace tsf::crms
