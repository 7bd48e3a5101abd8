// The stable time step of a scene with its effects (docs/crms.md, "Stable time step";
// docs/effects.md, "The effects"): the core estimate of stable_time_step.h, lowered for what the
// scene's effects and animation add.
//
//   volumetric term (materials with ν > 0): per node and axis in the core estimate itself
//              (stable_time_step.h): its cubes' k·h_b·h_c/(2·h_a) and damping, at the node;
//   animation: tracks and triggers may move nodes to stiffer palette entries, so the estimate is
//              also taken with every track and trigger node at its target (blends in between are
//              no stiffer than both ends) and the smaller one is kept;
//   stiffening s = s_aniso·s_fluid ≥ 1 scales the top mode's stiffness, so ω → ω·√s and
//              dt → dt/√s:
//     anisotropy  s_aniso = max(1, factor) (the linear springs are up to `factor` stiffer;
//                 heterogeneous palettes: the largest of the scene's and every material's);
//     fluid       s_fluid = 1 + 3·K/E_min (the checkerboard along all three axes adds 12·K·h to
//                 the linear springs' 4·E·h per axis, effect_physics.h).
#pragma once

#include "tsf/crms/lattice.h"
#include "tsf/crms/solver_config.h"
#include "tsf/crms/spring_constants.h"
#include "tsf/crms/stable_time_step.h"

namespace tsf::crms {

/// The stable step of `lattice` with the palette calibrated from `config`, its effects and
/// animation included. The animation's tracks and triggers must have been validated
/// (AnimationTimeline) when it is enabled.
StableTimeStep stable_time_step_with_effects(const Lattice& lattice, const MaterialPalette& palette,
                                             const SolverConfig& config);

}  // namespace tsf::crms
