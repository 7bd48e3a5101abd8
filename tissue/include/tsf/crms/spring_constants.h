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

#include "tsf/common/hd.h"

namespace tsf::crms {

struct SpringConstants {
  float ks_linear[3] = {0, 0, 0};  ///< µN per unit strain, per axis
  float kd_linear[3] = {0, 0, 0};  ///< µN·s per unit strain rate, per axis
  float k_angular[3] = {0, 0, 0};  ///< µN·mm/rad, per plane (normal axis)
  float c_angular[3] = {0, 0, 0};  ///< µN·mm·s/rad, per plane
};

/// Up to 16 materials indexed per node (features::kHeterogeneous); entry 0 is the default. Small
/// enough to travel as a kernel argument (constant memory on CUDA).
constexpr int kMaxMaterials = 16;
struct MaterialPalette {
  SpringConstants entry[kMaxMaterials];
  int count = 1;
};

/// Thesis angular constant ks2 (µN per rad, force at the vertex) for a plane whose arms have rest
/// lengths hu and hv, from the torsional stiffness kθ.
inline double thesis_ks2_from_torsional(double k_theta, double hu, double hv) {
  return k_theta * std::sqrt(1.0 / (hu * hu) + 1.0 / (hv * hv));
}
inline double torsional_from_thesis_ks2(double ks2, double hu, double hv) {
  return ks2 / std::sqrt(1.0 / (hu * hu) + 1.0 / (hv * hv));
}

}  // namespace tsf::crms
