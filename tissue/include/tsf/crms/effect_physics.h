// Per-node physics of the optional CRMS effects (effects_config.h): one copy, called by the thin
// CPU loops (cpu_effects.cpp) and CUDA kernels (cuda_effects.cu).
//
// A step with effects is
//   1. cube pass    (fluid)              p_c = K·(content_c − ΔV_c/V0)             per cube
//      volume pass  (volumetric)         π_c·¼(e_y×e_z, e_z×e_x, e_x×e_y)          per cube
//   2. force pass   (plastic, aniso, fluid) F_eff[n]                              per node
//   3. the core step (node_update.h)
//   4. kick pass    F = F_eff[n] + Σ_cubes π_c·∂V_c/∂x_n:  v_n += dt·F/m_n, and with symplectic
//                   Euler u_n += dt²·F/m_n                 (moving nodes)          per node
//   5. update pass  (plastic, fluid)      rest offsets creep/recover, fluid flows  per node/cube
//   6. tear pass    (tearing)             over-strained links are cleared          per node
//      (node masking: 6a marks nodes whose largest spring tension exceeds the limit, 6b clears
//      every link with a marked end, so both ends of a spring agree)
// Passes 1–2 read the state the core step reads, and the kick adds their force to what the core
// step wrote exactly as if it had been in the core's force: the step is symplectic (or explicit)
// Euler of the total force at (u_n, v_n). (Kicking the velocity *before* the core step instead
// lets the core's spring damping act on the kicked velocity within the same step: its fixed
// point is then not the static equilibrium, off by the damping of dt·F_eff/m, ~1% on the
// volumetric term of a soft damped block.) The kick applies the velocity limit to the whole
// update again (the core step limited its own part), so no node outruns the safety net; the
// kinetic damping acts in the core step only. Passes 2 and 4
// are separate so that no pass writes what a neighbour reads (the force pass reads neighbours'
// velocities for the anisotropic damping). Each pass writes only its own node's (or cube's)
// entries, so the result does not depend on execution order.
//
// Linear springs (spring d of node n, rest length L, stiffness ks, damping kd of node_force.h):
//   plastic: rest length L + δ, δ stored once per spring at its lower end (plastic_offset[axis]);
//            the animation's rest offset (blend of two keyframes' offsets) adds to δ:
//            F_n −= (1 + a_d)·ks·δ/L·dir  (the change of the core force for that rest length);
//            after the step: ε = (l − L − δ)/L; if |ε| > ε_y: δ += min(creep·dt, 1)·(|ε| −
//            ε_y)·L·sgn ε; then δ ← δ·exp(−recovery·dt) (visco-elastic recovery, exact decay).
//   aniso:   F_n += a_d·(ks·x + kd·ẋ)·x̂ with a_d = (factor − 1)·axis_d², i.e. the spring is
//            (1 + a_d) times stiffer and more damped. Heterogeneous lattices blend a_d per node
//            from each material's own axis and factor; a spring takes the mean of its two ends
//            (so both ends see the same spring: action = reaction).
// Cubes (lower corner node c, corners c + {0,1}³, all alive): edge vectors averaged over the 4
// parallel edges, e_x = h_x·x̂ + ¼Σ(u_{1bc} − u_{0bc}) (likewise y, z), V = e_x·(e_y × e_z)
// (exact for parallelepipeds, V0 = h_x·h_y·h_z at rest exactly). Corner (a,b,c) gets
//   F = p·∂V/∂x = p·¼·(s_a·e_y×e_z + s_b·e_z×e_x + s_c·e_x×e_y),  s = −1 low end, +1 high end,
// the gradient of the energy ½K·(ΔV/V0 − content)²·V0. Fluid flow (Darcy-like, on the cube
// lattice): content_i += α·Σ_nb (p_nb − p_i)/K with α = (1 − exp(−6·rate·dt))/6, which is
// rate·dt for small steps and stays below 1/6 (the explicit diffusion limit) for any step.
// The volumetric term (materials with a Poisson ratio) lives in volume_term.h: its own cubes
// (intact: 8 live corners and 12 linked edges), an energy k·V0·φ(J) with k = λ and its
// Kelvin–Voigt damping.
#pragma once

#include <cstdint>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/crms/crms_math.h"
#include "tsf/crms/lattice_geometry.h"
#include "tsf/crms/node_force.h"
#include "tsf/crms/node_state_view.h"
#include "tsf/crms/node_update.h"
#include "tsf/crms/spring_constants.h"
#include "tsf/crms/stencil.h"
#include "tsf/crms/volume_term.h"

namespace tsf::crms {

namespace effect_bits {
constexpr unsigned kPlasticity = 1u << 0;
constexpr unsigned kAnisotropy = 1u << 1;
constexpr unsigned kFluid = 1u << 2;
constexpr unsigned kTearing = 1u << 3;
/// Rest-shape keyframes (animation); material tracks and cut triggers run on the host.
constexpr unsigned kRestAnimation = 1u << 4;
/// Tearing by node: overloaded nodes lose all their springs.
constexpr unsigned kNodeMasking = 1u << 5;
/// The volumetric (Poisson) term of materials with ν > 0 (volume_term.h): its cube pass, and its
/// force in the kick (no effect-force array).
constexpr unsigned kVolumetric = 1u << 6;
/// Effects that add a force (passes 2 and 3).
constexpr unsigned kForceEffects = kPlasticity | kAnisotropy | kFluid | kRestAnimation;
/// Effects whose force goes through the linear springs' rest lengths or stiffness.
constexpr unsigned kSpringEffects = kPlasticity | kAnisotropy | kRestAnimation;
}  // namespace effect_bits

/// Effect arrays (device memory on CUDA); null when their effect is off.
struct EffectArrays {
  float* plastic_offset[3] = {nullptr, nullptr, nullptr};  ///< #nodes each, mm, spring n → n+axis
  float* fluid_content = nullptr;                          ///< #nodes (cube at lower corner), 1
  float* fluid_pressure = nullptr;                         ///< #nodes (cube at lower corner), Pa
  float* force[3] = {nullptr, nullptr, nullptr};           ///< #nodes each, µN (pass 2 → 3)
  /// Animation: rest offsets of the keyframes around the current time, mm (#nodes each).
  const float* rest_from[3] = {nullptr, nullptr, nullptr};
  const float* rest_to[3] = {nullptr, nullptr, nullptr};
  std::uint8_t* node_mask = nullptr;  ///< #nodes: 1 = overloaded this step (node masking)
  /// Volumetric term: each cube's π·face terms (9 arrays of #nodes, cube at its lower corner:
  /// [3a + component], volume_term.h).
  float* volume_terms[9] = {nullptr, nullptr, nullptr, nullptr, nullptr,
                            nullptr, nullptr, nullptr, nullptr};
};

/// Scalars of the effect passes, by value to kernels.
struct EffectParameters {
  unsigned enabled = 0;    ///< effect_bits
  float dt = 0;            ///< s
  bool symplectic = true;  ///< the kick also moves positions (symplectic Euler; not explicit Euler)
  float velocity_limit = 0;  ///< mm/s, the core step's (0: none)
  bool heterogeneous = false;
  MaterialPalette palette;
  float yield_strain = 0;
  float creep_step = 0;              ///< min(creep_rate·dt, 1)
  float recovery_decay = 1;          ///< exp(−recovery_rate·dt)
  float aniso_extra[3] = {0, 0, 0};  ///< a_axis = (factor − 1)·axis_axis²
  float bulk_modulus = 0;            ///< K, Pa = µN/mm²
  float diffusion_step = 0;          ///< α
  float tear_strain = 0;
  int rest_from_key = 0;  ///< animation: keyframes around the current time (engine side)
  int rest_to_key = 0;
  float rest_blend = 0;        ///< animation: offset = (1 − s)·rest_from + s·rest_to
  float node_force_limit = 0;  ///< µN, node masking
  /// Heterogeneous lattices: per palette entry a_axis and tear strain (see header).
  float material_aniso_extra[3][kMaxMaterials] = {};
  float material_tear_strain[kMaxMaterials] = {};
  VolumeParameters volume;  ///< per palette entry λ and λ·τ (volumetric term)
};

/// Anisotropic extra stiffness fraction a of node n's spring d (mean of both ends' blends on a
/// heterogeneous lattice).
template <class St>
TSF_HD_INLINE float spring_aniso_extra(const St& st, const EffectParameters& p, int d) {
  const int ax = direction_axis(d);
  if (!p.heterogeneous) return axis_value(p.aniso_extra, ax);
  const float* table = ax == 0 ? p.material_aniso_extra[0]
                               : (ax == 1 ? p.material_aniso_extra[1] : p.material_aniso_extra[2]);
  return 0.5f *
         (blend_table(table, st.material(0)) + blend_table(table, st.material(face_slot(d))));
}

/// Tear strain of node n's spring d (the weaker end's on a heterogeneous lattice).
template <class St>
TSF_HD_INLINE float spring_tear_strain(const St& st, const EffectParameters& p, int d) {
  if (!p.heterogeneous) return p.tear_strain;
  return crms_min(blend_table(p.material_tear_strain, st.material(0)),
                  blend_table(p.material_tear_strain, st.material(face_slot(d))));
}

/// Rest-length offset of the spring whose lower end is `owner`, along `ax`: plastic + animation.
TSF_HD_INLINE float rest_offset(const EffectArrays& a, const EffectParameters& p, int ax,
                                std::int64_t owner) {
  float delta = 0.0f;
  if ((p.enabled & effect_bits::kPlasticity) != 0) delta += a.plastic_offset[ax][owner];
  if ((p.enabled & effect_bits::kRestAnimation) != 0)
    delta +=
        a.rest_from[ax][owner] + p.rest_blend * (a.rest_to[ax][owner] - a.rest_from[ax][owner]);
  return delta;
}

/// Linear spring constants of node n's spring d (series across a material interface, as in
/// node_spring_terms()).
template <class St>
TSF_HD_INLINE void linear_constants(const St& st, const EffectParameters& p, int d, float& ks,
                                    float& kd) {
  const int ax = direction_axis(d);
  if (!p.heterogeneous) {
    ks = axis_value(p.palette.entry[0].ks_linear, ax);
    kd = axis_value(p.palette.entry[0].kd_linear, ax);
    return;
  }
  blend_linear(p.palette, st.material(0), ax, ks, kd);
  float other_ks = 0.0f, other_kd = 0.0f;
  blend_linear(p.palette, st.material(face_slot(d)), ax, other_ks, other_kd);
  ks = series_stiffness(ks, other_ks);
  kd = series_stiffness(kd, other_kd);
}

/// True when the cube with lower corner (i, j, k) lies inside the lattice with 8 live corners.
TSF_HD_INLINE bool cube_exists(const LatticeView& lat, int i, int j, int k) {
  if (i < 0 || j < 0 || k < 0 || i + 1 >= lat.dims.x || j + 1 >= lat.dims.y || k + 1 >= lat.dims.z)
    return false;
  const std::int64_t c = i + j * lat.stride_y + k * lat.stride_z;
  bool alive = true;
  for (int q = 0; q < 8; ++q) {
    const std::int64_t m = c + (q & 1) + ((q >> 1) & 1) * lat.stride_y + (q >> 2) * lat.stride_z;
    alive = alive && (lat.flags[m] & kAliveBit) != 0;
  }
  return alive;
}

/// Averaged edge vectors of an existing cube, mm.
struct CubeEdges {
  Vec3f e[3];
  TSF_HD_INLINE float volume() const { return dot(e[0], cross(e[1], e[2])); }
};
TSF_HD_INLINE CubeEdges cube_edges(const LatticeView& lat, const ConstStateView& s, int i, int j,
                                   int k) {
  const std::int64_t c = i + j * lat.stride_y + k * lat.stride_z;
  Vec3f corner[8];
  for (int q = 0; q < 8; ++q) {
    const std::int64_t m = c + (q & 1) + ((q >> 1) & 1) * lat.stride_y + (q >> 2) * lat.stride_z;
    corner[q] = {s.u[0][m], s.u[1][m], s.u[2][m]};
  }
  CubeEdges edges;
  for (int a = 0; a < 3; ++a) {
    Vec3f du{0.0f, 0.0f, 0.0f};
    for (int q = 0; q < 8; ++q)
      if (((q >> a) & 1) == 0) du += corner[q | (1 << a)] - corner[q];
    Vec3f e{0.0f, 0.0f, 0.0f};
    e[a] = lat.rest_length[a];
    edges.e[a] = e + du * 0.25f;
  }
  return edges;
}

/// Pass 1: pressure of the cube with lower corner n = (i, j, k), Pa (0 when it does not exist).
TSF_HD_INLINE float cube_pressure(const LatticeView& lat, const ConstStateView& s,
                                  const EffectArrays& arrays, const EffectParameters& p,
                                  std::int64_t n, int i, int j, int k) {
  if (!cube_exists(lat, i, j, k)) return 0.0f;
  const float v0 = lat.rest_length[0] * lat.rest_length[1] * lat.rest_length[2];
  const float volumetric_strain = (cube_edges(lat, s, i, j, k).volume() - v0) / v0;
  return p.bulk_modulus * (arrays.fluid_content[n] - volumetric_strain);
}

/// Pass 2: the effects' force on node n = (i, j, k), µN.
TSF_HD_INLINE Vec3f effect_force(const LatticeView& lat, const ConstStateView& s,
                                 const EffectArrays& arrays, const EffectParameters& p,
                                 std::int64_t n, int i, int j, int k) {
  Vec3f force{0.0f, 0.0f, 0.0f};
  const unsigned flags = lat.flags[n];
  if ((flags & kAliveBit) == 0) return force;
  const IndexedStencil st{lat, s, n, i, j, k};
  if ((p.enabled & effect_bits::kSpringEffects) != 0) {
    const unsigned links = flags & kLinkBits;
    const Vec3f u0 = st.u(0), v0 = st.v(0);
    for (int d = 0; d < 6; ++d) {
      if (((links >> d) & 1u) == 0) continue;
      const int ax = direction_axis(d);
      const float rest = axis_value(lat.rest_length, ax);
      const Arm<float> arm = arm_of(st, links, u0, v0, lat.rest_length, d);
      float ks = 0, kd = 0;
      linear_constants(st, p, d, ks, kd);
      const float extra =
          (p.enabled & effect_bits::kAnisotropy) != 0 ? spring_aniso_extra(st, p, d) : 0.0f;
      force += linear_spring_force(arm, ks, kd, rest) * extra;
      if ((p.enabled & (effect_bits::kPlasticity | effect_bits::kRestAnimation)) != 0) {
        // The spring's offset lives at its lower end: n for +axis, the neighbour for −axis.
        const std::int64_t owner = direction_sign(d) > 0 ? n : st.slot_index(face_slot(d));
        const float delta = rest_offset(arrays, p, ax, owner);
        force -= arm.dir * ((1.0f + extra) * ks * delta / rest);
      }
    }
  }
  if ((p.enabled & effect_bits::kFluid) != 0) {
    for (int q = 0; q < 8; ++q) {  // the 8 cubes with n as corner (a, b, c) = high end bits
      const int a = q & 1, b = (q >> 1) & 1, c = q >> 2;
      const int ci = i - a, cj = j - b, ck = k - c;
      if (!cube_exists(lat, ci, cj, ck)) continue;
      const std::int64_t cube = ci + cj * lat.stride_y + ck * lat.stride_z;
      const CubeEdges e = cube_edges(lat, s, ci, cj, ck);
      const Vec3f grad =
          (cross(e.e[1], e.e[2]) * (a ? 1.0f : -1.0f) + cross(e.e[2], e.e[0]) * (b ? 1.0f : -1.0f) +
           cross(e.e[0], e.e[1]) * (c ? 1.0f : -1.0f)) *
          0.25f;
      force += grad * arrays.fluid_pressure[cube];
    }
  }
  return force;
}

/// Pass 4, after the core step: node n = (i, j, k) of the state the core step wrote receives the
/// force of passes 1–2 (the force pass's effect force and the volumetric term's cube forces):
/// v += dt·F/m, and with symplectic Euler u += dt²·F/m (the position update the core step made
/// with its own part of v). Fixed and dead nodes are left as they are.
TSF_HD_INLINE void kick_node(const LatticeView& lat, const StateView& s, const EffectArrays& arrays,
                             const EffectParameters& p, std::int64_t n, int i, int j, int k) {
  const bool moving = (lat.flags[n] & (kAliveBit | kFixedBit)) == kAliveBit;
  if (!moving) return;
  Vec3f f{0.0f, 0.0f, 0.0f};
  if ((p.enabled & effect_bits::kForceEffects) != 0)
    f = {arrays.force[0][n], arrays.force[1][n], arrays.force[2][n]};
  if ((p.enabled & effect_bits::kVolumetric) != 0)
    f += volume_force(lat, arrays.volume_terms, n, i, j, k);
  Vec3f u{s.u[0][n], s.u[1][n], s.u[2][n]}, v{s.v[0][n], s.v[1][n], s.v[2][n]};
  kick_after_step(u, v, f, lat.inv_mass[n], p.dt, p.velocity_limit, p.symplectic);
  for (int a = 0; a < 3; ++a) {
    s.u[a][n] = u[a];
    s.v[a][n] = v[a];
  }
}

/// Pass 5, plasticity: node n's 3 springs towards +axis (their offsets live at n).
TSF_HD_INLINE void update_plastic_offsets(const LatticeView& lat, const ConstStateView& s,
                                          const EffectArrays& arrays, const EffectParameters& p,
                                          std::int64_t n, int i, int j, int k) {
  const IndexedStencil st{lat, s, n, i, j, k};
  const unsigned links = lat.flags[n] & kLinkBits;
  const Vec3f u0 = st.u(0), v0 = st.v(0);
  for (int ax = 0; ax < 3; ++ax) {
    const int d = make_direction(ax, 1);
    float delta = arrays.plastic_offset[ax][n];
    if (((links >> d) & 1u) != 0) {
      const float rest = axis_value(lat.rest_length, ax);
      const Arm<float> arm = arm_of(st, links, u0, v0, lat.rest_length, d);
      // Elastic strain against the current rest length (plastic and animated offsets).
      const float strain = (arm.stretch - rest_offset(arrays, p, ax, n)) / rest;
      const float excess = crms_abs(strain) - p.yield_strain;
      if (excess > 0.0f) delta += p.creep_step * excess * rest * (strain > 0.0f ? 1.0f : -1.0f);
    }
    arrays.plastic_offset[ax][n] = delta * p.recovery_decay;
  }
}

/// Pass 5, fluid: flow into the cube with lower corner n from its face-neighbour cubes.
TSF_HD_INLINE void update_fluid_content(const LatticeView& lat, const EffectArrays& arrays,
                                        const EffectParameters& p, std::int64_t n, int i, int j,
                                        int k) {
  if (!cube_exists(lat, i, j, k)) return;
  const float own = arrays.fluid_pressure[n];
  float flow = 0.0f;
  for (int d = 0; d < 6; ++d) {
    const Int3 o = direction_offset(d);
    if (!cube_exists(lat, i + o.x, j + o.y, k + o.z)) continue;
    const std::int64_t m = n + o.x + o.y * lat.stride_y + o.z * lat.stride_z;
    flow += arrays.fluid_pressure[m] - own;
  }
  arrays.fluid_content[n] += p.diffusion_step * flow / p.bulk_modulus;
}

/// Pass 6: node n's flags with every link whose strain exceeds the threshold cleared. Both ends
/// of a spring compute bit-identical strains (arm_of negates exactly), so they agree.
TSF_HD_INLINE std::uint8_t torn_flags(const LatticeView& lat, const ConstStateView& s,
                                      const EffectParameters& p, std::int64_t n, int i, int j,
                                      int k) {
  const unsigned flags = lat.flags[n];
  const unsigned links = flags & kLinkBits;
  if (links == 0) return static_cast<std::uint8_t>(flags);
  const IndexedStencil st{lat, s, n, i, j, k};
  const Vec3f u0 = st.u(0), v0 = st.v(0);
  unsigned keep = flags;
  for (int d = 0; d < 6; ++d) {
    if (((links >> d) & 1u) == 0) continue;
    const Arm<float> arm = arm_of(st, links, u0, v0, lat.rest_length, d);
    if (arm.stretch > spring_tear_strain(st, p, d) * axis_value(lat.rest_length, direction_axis(d)))
      keep &= ~(1u << d);
  }
  return static_cast<std::uint8_t>(keep);
}

/// Pass 6a, node masking: 1 when the largest tension among node n's linear springs exceeds the
/// limit (ks·(l − L)/L, µN; compression does not count).
TSF_HD_INLINE std::uint8_t node_overloaded(const LatticeView& lat, const ConstStateView& s,
                                           const EffectParameters& p, std::int64_t n, int i, int j,
                                           int k) {
  const unsigned links = lat.flags[n] & kLinkBits;
  if (links == 0 || (lat.flags[n] & kAliveBit) == 0) return 0;
  const IndexedStencil st{lat, s, n, i, j, k};
  const Vec3f u0 = st.u(0), v0 = st.v(0);
  float largest = 0.0f;
  for (int d = 0; d < 6; ++d) {
    if (((links >> d) & 1u) == 0) continue;
    const Arm<float> arm = arm_of(st, links, u0, v0, lat.rest_length, d);
    float ks = 0, kd = 0;
    linear_constants(st, p, d, ks, kd);
    largest = crms_max(largest, ks * arm.stretch / axis_value(lat.rest_length, direction_axis(d)));
  }
  return largest > p.node_force_limit ? 1 : 0;
}

/// Pass 6b, node masking: node n's flags without the links that have a masked end.
/// (A link bit implies the neighbour is inside the lattice.)
TSF_HD_INLINE std::uint8_t unmasked_flags(const LatticeView& lat, const EffectArrays& arrays,
                                          std::int64_t n) {
  const unsigned flags = lat.flags[n];
  const unsigned links = flags & kLinkBits;
  if (links == 0) return static_cast<std::uint8_t>(flags);
  if (arrays.node_mask[n] != 0) return static_cast<std::uint8_t>(flags & ~kLinkBits);
  unsigned keep = flags;
  for (int d = 0; d < 6; ++d) {
    if (((links >> d) & 1u) == 0) continue;
    const Int3 o = direction_offset(d);
    const std::int64_t m = n + o.x + o.y * lat.stride_y + o.z * lat.stride_z;
    if (arrays.node_mask[m] != 0) keep &= ~(1u << d);
  }
  return static_cast<std::uint8_t>(keep);
}

}  // namespace tsf::crms
