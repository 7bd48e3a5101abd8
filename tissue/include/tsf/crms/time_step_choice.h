// The time step a run uses: the one it was given, or a safety factor times the stable estimate
// (docs/design.md "Time step"). One rule for every caller: the tissue model and lattice-only
// runs.
#pragma once

namespace tsf::crms {

/// `given_s` > 0: that step; 0 = automatic: `safety` × `stable_s`. Seconds.
inline double chosen_time_step(double given_s, double safety, double stable_s) {
  return given_s > 0.0 ? given_s : safety * stable_s;
}

}  // namespace tsf::crms
