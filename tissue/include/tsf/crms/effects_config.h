// Optional CRMS effects (docs/effects.md): which extra physics a scene switches on, and its
// parameters.
//
// Effects run as separate passes around the core step (effect_physics.h): a "kick" pass before it
// adds the effects' forces to the velocity (v += dt·F_effects/m, exactly the symplectic Euler
// update of those forces), and an "update" pass after it advances the effects' own state
// (plastic rest offsets, fluid content, torn links). An effect that is off launches no pass and
// allocates no array: the core kernels and their compiled feature sets (effects.h) are the same
// with or without effects, so adding an effect adds no kernel instantiations.
//
// Units: mm, g, s; stiffness as Pa (like Young's modulus), rates in 1/s, strains dimensionless.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"

namespace tsf::crms {

/// Plasticity / visco-elasticity of the linear springs: a spring strained past the yield strain
/// creeps (its rest length moves towards the current length) at `creep_rate`; with a recovery
/// rate the plastic offset decays back, δ(t) = δ0·exp(−recovery_rate·t) (visco-elastic).
/// Per-spring rest offsets (3 floats per node) exist only while this is on.
struct PlasticityConfig {
  bool enabled = false;
  double yield_strain = 0.05;  ///< |elastic strain| beyond which the spring creeps, (0, 10]
  double creep_rate = 200;     ///< 1/s: δ̇ = creep_rate·(|ε| − yield)·L·sign(ε), [0, 1e6]
  double recovery_rate = 0;    ///< 1/s: δ̇ = −recovery_rate·δ, [0, 1e6]
};

/// Anisotropy: the linear springs along `axis` are `stiffness_factor` times stiffer (stiffness
/// and damping); a spring of rest direction e is scaled by 1 + (factor − 1)·(axis·e)².
struct AnisotropyConfig {
  bool enabled = false;
  Vec3d axis{1, 0, 0};          ///< any non-zero vector (normalised)
  double stiffness_factor = 2;  ///< [0.01, 100]
};

/// Fluid dispersion: each lattice cube holds fluid content c (excess fluid volume / cube volume).
/// Pressure p = K·(c − ΔV/V0) pushes the cube's corners along ∂V/∂x (the gradient of
/// ½K·(ΔV/V0 − c)²·V0: conservative), and fluid flows to face-neighbour cubes,
/// ċ_i = rate·Σ_nb (p_nb − p_i)/K, so pressure spreads and Σc is conserved (sealed block).
/// Two floats per node (content and pressure) exist only while this is on.
struct FluidConfig {
  bool enabled = false;
  double bulk_modulus_pa = 5e3;  ///< K, [1, 1e11]
  double diffusion_rate = 0;     ///< 1/s, [0, 1e6]
};

/// Tearing: a linear spring whose strain (l − L)/L exceeds the threshold breaks (both ends'
/// link bits cleared, so its angles vanish too); no per-node array. On a heterogeneous lattice a
/// material's own `tear_strain` (calibration.h) replaces the threshold for its springs.
/// Node masking (node_force_threshold_un > 0): a node whose largest linear spring tension
/// exceeds the threshold is masked: all its springs break at once, it goes on as a free node
/// (one uint8 per node while on).
struct TearingConfig {
  bool enabled = false;
  double strain_threshold = 0.5;       ///< (0, 100]
  double node_force_threshold_un = 0;  ///< µN; 0 = no node masking, else (0, 1e12]
};

/// A rest shape of the animation: at time_s the lattice's rest shape is its regular rest grid
/// displaced by rest_displacement_mm (#nodes). The linear springs' rest lengths follow the
/// blended shape (plastic-offset mechanism: |h·e + Δr| − h per spring); rest angles stay right.
struct RestKeyframe {
  double time_s = 0;                        ///< ≥ 0, strictly increasing over keyframes
  std::vector<Vec3f> rest_displacement_mm;  ///< #nodes, mm
};

/// Palette-weight animation: from start_s to end_s the blends of `nodes` move linearly from what
/// they were at start_s to palette entry `entry` alone.
struct MaterialTrack {
  double start_s = 0;
  double end_s = 0;  ///< ≥ start_s (equal: a switch)
  std::vector<std::int64_t> nodes;
  int entry = 0;
};

/// When one of `nodes` is deleted or loses a spring through the solver's topology edits (a cut,
/// an ablation, a tear), all its nodes switch to palette entry `entry`: a severed artery goes
/// flaccid. A trigger with an `event` watches that event instead (Solver::raise_event, e.g.
/// "exposure:vessel" when an edit removes tissue near a vessel, docs/deform-cut.md) and ignores
/// edits.
struct CutTrigger {
  std::string name;  ///< for reports
  std::vector<std::int64_t> nodes;
  int entry = 0;
  std::string event;  ///< empty: fires on edits of `nodes`; else on Solver::raise_event(event)
};

/// Animation: rest-shape keyframes blended over time (linear between keyframes; the grid's own
/// rest shape before the first keyframe when it starts after 0; the last one held after it),
/// palette-weight tracks and cut triggers. Tracks and triggers need a heterogeneous palette
/// (≥ 2 materials). Rest offsets take 3 floats per node per keyframe, only while on.
struct AnimationConfig {
  bool enabled = false;
  std::vector<RestKeyframe> rest_keyframes;
  std::vector<MaterialTrack> material_tracks;
  std::vector<CutTrigger> cut_triggers;
};

struct EffectsConfig {
  PlasticityConfig plasticity;
  AnisotropyConfig anisotropy;
  FluidConfig fluid;
  TearingConfig tearing;
  AnimationConfig animation;

  bool any() const {
    return plasticity.enabled || anisotropy.enabled || fluid.enabled || tearing.enabled ||
           animation.enabled;
  }
  /// Names of the enabled effects ("plasticity", "anisotropy", "fluid", "tearing",
  /// "node-masking", "animation").
  std::vector<std::string> active() const;
};

/// Host copies of the effects' arrays (Solver::effects_state(); empty when the effect is off).
struct EffectsState {
  std::vector<Vec3f> plastic_offset;  ///< #nodes, mm: rest-length offset of the springs n → n+x,y,z
  std::vector<float> fluid_content;   ///< #nodes (cube at lower corner), 1
  std::vector<float> fluid_pressure;  ///< #nodes (cube at lower corner), Pa, as of the last step
};

/// Throws tsf::Error naming the field ("effects.fluid.bulk_modulus_pa ...") and the range.
void validate_effects_config(const EffectsConfig& effects);

}  // namespace tsf::crms
