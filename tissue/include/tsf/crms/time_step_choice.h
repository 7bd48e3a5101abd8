// The time step a run uses (docs/design.md "Time step"; docs/stability.md "No unsafe step"): the
// one it was given, or a safety factor times the stable estimate. One rule for every caller: the
// tissue model and lattice-only runs.
//
// A given step above the explicit integrator's stable estimate (stable_time_step_with_effects:
// palette entries and stiffening effects included) is refused, naming the estimate and the scene
// key that allows it (`stability.allow_unsafe_dt`); implicit Euler has no stability limit and
// takes any step.
#pragma once

#include <string>

namespace tsf::crms {

class Solver;

struct TimeStepChoice {
  double dt_s = 0;        ///< the step the run uses, s
  double stable_s = 0;    ///< the integrator's stable estimate, s (implicit: accuracy scale)
  double safety = 0.9;    ///< the factor of an automatic step
  bool automatic = true;  ///< dt: auto (or 0)
  bool limited = true;    ///< the integrator has a stability limit (explicit schemes)
  std::string how;        ///< one sentence: how the step was chosen and the estimate made
  /// dt over the stable estimate (0 when there is no estimate).
  double ratio() const { return stable_s > 0 ? dt_s / stable_s : 0.0; }
};

/// `given_s` > 0: that step; 0 = automatic: `safety` × the solver's stable estimate; at most 1 s.
/// Throws tsf::Error naming `solver.dt` when the estimate is 0 and no step is given, or when a
/// given step exceeds the estimate of an explicit integrator and the solver's configuration does
/// not set stability.allow_unsafe_dt.
TimeStepChoice choose_time_step(double given_s, double safety, const Solver& solver);

}  // namespace tsf::crms
