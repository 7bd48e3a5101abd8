// What the CRMS effects (tsf/crms/effects_config.h, and the volumetric term of materials with a
// Poisson ratio: "off" runs them with ν = 0) cost on a scene's own lattice: after the
// scripted run, `tsf run` steps copies of the final lattice and state with every effect off, with
// every effect off again (the noise reference: two identical configurations), with the scene's
// effects, and with each of the scene's effects alone, in interleaved repetitions so that drift
// of the machine's load hits every configuration alike. A disabled effect launches no pass and
// allocates no array, so "off" and "off again" differ only by noise; the noise band printed with
// the figures is that difference and the spread of the repetitions.
//
//   nlohmann::json cost = measure_effect_cost(model.solver(), model.dt(), {});
//   cost["configurations"][k]["median_us_per_step"], ["ratio_to_off"], ["bytes_per_node"]
#pragma once

#include <nlohmann/json.hpp>

#include "tsf/crms/solver.h"

namespace tsf::app {

struct EffectCostOptions {
  int repetitions = 7;  ///< interleaved repetitions per configuration, ≥ 3
  /// Wall time one repetition aims at, s: the steps per repetition come from a timed warm-up
  /// (clamped to [2, 200]), so small and large lattices cost about the same.
  double seconds_per_repetition = 0.05;
};

/// Step time per configuration (µs per step: median, min, max over the repetitions), its ratio
/// to "off" (of the medians, and of the minima), bytes per node, and the noise band. `dt` is the
/// run's step (s). Uses the solver's backend; the solver itself is not stepped.
nlohmann::json measure_effect_cost(const crms::Solver& solver, double dt,
                                   const EffectCostOptions& options);

}  // namespace tsf::app
