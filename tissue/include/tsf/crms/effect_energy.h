// Elastic energy the optional effects add to the core's (docs/effects.md, "The effects";
// effect_physics.h for the forces these energies are the potentials of), nJ:
//   linear spring d of node n, with rest offset δ (plastic offset + the animation's blended rest
//   offset) and anisotropic extra a_d:
//     ΔU = ½·(ks/L)·((1 + a_d)·(x − δ)² − x²)      x = l − L (the core counts ½·(ks/L)·x²)
//   fluid cube c (all 8 corners alive), volumetric strain ε = (V − V0)/V0, content φ_c:
//     U = ½·K·(ε − φ_c)²·V0
//   volumetric term, intact cube c with stiffness k_c (volume_term.h): U = k_c·V0·φ(V/V0)
// Evaluated on the host from host copies of the state and the effect arrays (a query, not a
// step).
#pragma once

#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/animation_timeline.h"
#include "tsf/crms/effect_physics.h"
#include "tsf/crms/effects_config.h"
#include "tsf/crms/lattice_geometry.h"
#include "tsf/crms/spring_constants.h"

namespace tsf::crms {

/// Host copies of what the effect energies read.
struct EffectEnergyInputs {
  std::vector<Vec3f> displacement_mm;   ///< #nodes
  std::vector<std::uint8_t> flags;      ///< #nodes, packed (links as the kernels see them)
  std::vector<MaterialBlend> material;  ///< #nodes
  EffectsState effects;                 ///< plastic offsets, fluid content (empty when off)
};

/// The volumetric term's energy Σ_c k_c·V0·φ(J_c), nJ, of a host lattice view and state.
double volume_energy_nj(const LatticeView& lattice, const ConstStateView& state,
                        const VolumeParameters& parameters);

/// The effects' extra elastic energy (see header); `p.enabled` says which effects are on,
/// `rest_offsets` are the animation's keyframes (AnimationTimeline::rest_offsets, may be empty).
double effects_elastic_energy_nj(const LatticeGeometry& geometry, const EffectEnergyInputs& in,
                                 const EffectParameters& p,
                                 const std::vector<RestOffsets>& rest_offsets,
                                 double bulk_modulus_pa);

}  // namespace tsf::crms
