// Spring constants of one CRMS material, in the units the kernels use (mm, g, s; force µN).
//
// Linear springs (thesis Eq. 7–10): the force on node B from the spring to neighbour A is
//   F = (ks·x + kd·ẋ)·x̂,   x = (|AB| − L)/L (strain),  x̂ = AB/|AB|
// so ks is a force per unit strain (µN) and kd a force per unit strain rate (µN·s), one value per
// axis (a spring along x has rest length hx).
//
// Angular springs: each right angle at a vertex stores U = ½·kθ·ψ² with ψ the deflection
// (ψ = θ0 − θ, or cos θ in the cheaper form) and dissipates with ½·cθ·ψ̇²; kθ is a torsional
// stiffness (µN·mm/rad), cθ its damping (µN·mm·s/rad), one value per axis plane (normal axis
// 0 = yz, 1 = zx, 2 = xy). The thesis writes the vertex force as ks2·δ·d̂; at rest
// ks2 = kθ·|∇_B θ| = kθ·sqrt(1/hu² + 1/hv²) (thesis_ks2_from_torsional below).
//
// calibration.h derives these from Young's modulus, shear modulus, viscosity and the spacing.
#pragma once

#include <cmath>
#include <cstdint>

#include "tsf/common/hd.h"

namespace tsf::crms {

struct SpringConstants {
  float ks_linear[3] = {0, 0, 0};  ///< µN per unit strain, per axis
  float kd_linear[3] = {0, 0, 0};  ///< µN·s per unit strain rate, per axis
  float k_angular[3] = {0, 0, 0};  ///< µN·mm/rad, per plane (normal axis)
  float c_angular[3] = {0, 0, 0};  ///< µN·mm·s/rad, per plane
};

/// Up to 16 materials (features::kHeterogeneous); entry 0 is the default. Small enough to travel
/// as a kernel argument (constant memory on CUDA): only the blend below is stored per node.
constexpr int kMaxMaterials = 16;
struct MaterialPalette {
  SpringConstants entry[kMaxMaterials];
  int count = 1;
};

/// A node's material as a blend of up to 4 palette entries (8 bytes per node, two 32-bit words so
/// that the CPU row loops keep 32-bit lanes): byte c of `index` is the palette entry of component
/// c, byte c of `weight` its weight in 1/255 (the 4 weights sum to 255). Segment's 4 material
/// channels averaged over the node's cell give the weights (lattice_builders.h); a node of one
/// material is {entry, 255}.
struct MaterialBlend {
  std::uint32_t index = 0;
  std::uint32_t weight = 255;
  TSF_HD_INLINE int entry(int c) const { return static_cast<int>((index >> (8 * c)) & 0xffu); }
  TSF_HD_INLINE unsigned weight_of(int c) const { return (weight >> (8 * c)) & 0xffu; }
  /// True when component 0 carries all the weight (the common case: one load, no blending).
  TSF_HD_INLINE bool pure() const { return (weight & 0xffu) == 255u; }
  TSF_HD_INLINE static MaterialBlend single(int entry) {
    MaterialBlend b;
    b.index = static_cast<std::uint32_t>(entry) & 0xffu;
    b.weight = 255u;
    return b;
  }
};

/// All constants of a blend: the weighted mean of its entries' (rule of mixtures, the Voigt
/// bound: stiff inclusions dominate a mixed cell).
TSF_HD_INLINE SpringConstants blend_constants(const MaterialPalette& palette, MaterialBlend b) {
  if (b.pure()) return palette.entry[b.entry(0)];
  SpringConstants r;
  for (int c = 0; c < 4; ++c) {
    const unsigned w = b.weight_of(c);
    if (w == 0u) continue;
    const float f = static_cast<float>(w) * (1.0f / 255.0f);
    const SpringConstants& e = palette.entry[b.entry(c)];
    for (int a = 0; a < 3; ++a) {
      r.ks_linear[a] += f * e.ks_linear[a];
      r.kd_linear[a] += f * e.kd_linear[a];
      r.k_angular[a] += f * e.k_angular[a];
      r.c_angular[a] += f * e.c_angular[a];
    }
  }
  return r;
}

/// Linear stiffness and damping of a blend along one axis.
TSF_HD_INLINE void blend_linear(const MaterialPalette& palette, MaterialBlend b, int axis,
                                float& ks, float& kd) {
  if (b.pure()) {
    const SpringConstants& e = palette.entry[b.entry(0)];
    ks = e.ks_linear[axis];
    kd = e.kd_linear[axis];
    return;
  }
  ks = 0.0f;
  kd = 0.0f;
  for (int c = 0; c < 4; ++c) {
    const unsigned w = b.weight_of(c);
    if (w == 0u) continue;
    const float f = static_cast<float>(w) * (1.0f / 255.0f);
    ks += f * palette.entry[b.entry(c)].ks_linear[axis];
    kd += f * palette.entry[b.entry(c)].kd_linear[axis];
  }
}

/// Thesis angular constant ks2 (µN per rad, force at the vertex) for a plane whose arms have rest
/// lengths hu and hv, from the torsional stiffness kθ.
inline double thesis_ks2_from_torsional(double k_theta, double hu, double hv) {
  return k_theta * std::sqrt(1.0 / (hu * hu) + 1.0 / (hv * hv));
}
inline double torsional_from_thesis_ks2(double ks2, double hu, double hv) {
  return ks2 / std::sqrt(1.0 / (hu * hu) + 1.0 / (hv * hv));
}

}  // namespace tsf::crms
