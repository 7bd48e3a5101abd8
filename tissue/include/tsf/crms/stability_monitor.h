// The stability verdict of a run (docs/stability.md): stable, settling or unstable, decided from
// signals measured while the solver steps, so that a diverging explicit integrator held down by
// the velocity limit cannot pass as fine.
//
//   StabilityMonitor monitor;
//   for (...) {
//     tools edit the solver...                       // counted as work, see below
//     StepReport r = monitor.step(solver, n, dt);    // instead of solver.step(n, dt)
//   }
//   StabilitySummary s = monitor.summary(solver);    // s.headline(): the report's first line
//
// Signals (docs/stability.md "Signals"), each sampled once per monitored step call:
//   energy balance  E = kinetic + elastic (effects included) + gravitational + load potential.
//                   Whatever changes E between two monitored calls (tools pressing, cutting,
//                   constraints, set_state) is the work put in, W. The integrator with damping
//                   may only lose energy: the unexplained gain G = E − E0 − W must stay below a
//                   fraction of the run's energy scale (the largest |terms| seen plus Σ|W|).
//   velocity limit  the fraction of moving nodes at |v| = v_max after the call, and for how many
//                   consecutive steps; the limit removes energy, so a diverging mode it holds down
//                   shows here and not in G.
//   period 2        the last step of a call is taken alone: the mass-weighted correlation of the
//                   velocities before and after it is −1 for a mode flipping sign every step (the
//                   signature of dt beyond the stable bound), +1 for smooth motion.
//   k_sys drag      its power Σ m·k_sys·|v|³ at each sample, integrated over the run: what the
//                   drag took out (an estimate; docs/stability.md says where it departs from the
//                   thesis).
//   NaN guard       the solver's Instability.
// Verdict: unstable on a non-finite state, on G above the threshold, or on nodes held at the
// limit while flipping every step; settling when not unstable but, over the last quarter of the
// run, energy is still leaving the lattice or its elastic energy still changing while it steps
// (the tissue still deforming), or nodes sit at the limit at its end; else stable.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "tsf/crms/solver.h"

namespace tsf::crms {

enum class StabilityVerdict { kStable, kSettling, kUnstable };
const char* to_string(StabilityVerdict verdict);

/// The thresholds of the verdict (docs/stability.md "Thresholds" says why these values).
struct StabilityThresholds {
  /// Unexplained energy gain G as a fraction of the run's energy scale.
  double energy_gain = 0.05;
  /// Fraction of moving nodes at the velocity limit that counts as "held at the limit".
  double limit_fraction = 0.01;
  /// Period-2 score (−velocity correlation over one step) that counts as flipping every step.
  double period2 = 0.9;
  /// Consecutive samples held at the limit while flipping that make a run unstable.
  int held_samples = 3;
  /// Energy leaving the lattice, or the elastic energy changing inside the steps (the tissue still
  /// deforming), over the last quarter of the samples, as a fraction of the scale, above which a
  /// stable run is still "settling".
  double settling_change = 0.02;
  /// The velocity signals (limit, period 2, drag) are measured on every this-many-th call (the
  /// first included): each costs two velocity read-backs and a separately launched last step, which
  /// on a GPU cost more than the steps of a frame. The energy balance is sampled on every call.
  int velocity_every = 4;
};

/// One monitored step call.
struct StabilitySample {
  std::int64_t step = 0;        ///< solver steps done after the call
  double time_s = 0;            ///< solver time after the call
  double energy_nj = 0;         ///< E after the call
  double work_nj = 0;           ///< Σ work put in by edits up to the call
  double elastic_drift_nj = 0;  ///< Σ of the elastic energy's changes inside the calls so far
  double limit_fraction = 0;
  double period2 = 0;  ///< −correlation of v over the call's last step (0: not measured)
  bool velocities_measured = false;  ///< the call measured the velocity signals (velocity_every)
};

struct StabilitySummary {
  StabilityVerdict verdict = StabilityVerdict::kStable;
  std::string reason;    ///< why, in one sentence with the figures
  std::string advice;    ///< what to try (empty when stable)
  bool allowed = false;  ///< unstable but stability.allow_unstable: the exit status stays 0
  // energy balance, nJ
  double energy_start_nj = 0, energy_end_nj = 0;
  double work_in_nj = 0;       ///< Σ energy changes made between steps (tools, edits)
  double dissipated_nj = 0;    ///< E0 + W − E_end: what damping, drag and the limit removed
  double max_gain_nj = 0;      ///< largest unexplained gain G
  double energy_scale_nj = 0;  ///< what G is compared with
  double gain_fraction = 0;    ///< max_gain / scale
  double kinetic_drag_nj = 0;  ///< what k_sys removed (sampled estimate)
  // velocity limit
  double velocity_limit_mm_s = 0;  ///< at the last step (0: none)
  double max_limit_fraction = 0;
  double end_limit_fraction = 0;
  std::int64_t steps_at_limit = 0;    ///< steps of the calls that ended with nodes held at it
  std::int64_t longest_at_limit = 0;  ///< longest consecutive run of those, steps
  // period 2
  double max_period2 = 0, end_period2 = 0;
  std::int64_t held_flipping_samples = 0;  ///< longest run of samples at the limit and flipping
  // what was watched
  std::int64_t samples = 0, steps = 0;
  double dt_max_over_stable = 0;          ///< largest dt used / the stable estimate
  std::optional<std::string> non_finite;  ///< the NaN guard's message
  bool energy_balance_checked = true;     ///< false when the animation does unmeasured work
  /// "stable: …" / "settling: …" / "unstable: …; try …": the first line of every report.
  std::string headline() const;
};

class StabilityMonitor {
 public:
  explicit StabilityMonitor(StabilityThresholds thresholds = {});

  /// Steps the solver n steps of dt (Solver::step) and samples the signals around it.
  StepReport step(Solver& solver, int n, double dt);
  /// The verdict so far.
  StabilitySummary summary(const Solver& solver) const;
  /// The samples, oldest first; past kMaxSamples every other one is dropped (the verdict reads
  /// only the last quarter's ends and running totals).
  const std::vector<StabilitySample>& samples() const { return samples_; }
  static constexpr std::size_t kMaxSamples = 8192;
  const StabilityThresholds& thresholds() const { return thresholds_; }

 private:
  StabilityThresholds thresholds_;
  std::vector<StabilitySample> samples_;
  bool started_ = false;
  std::uint64_t edits_seen_ = 0;  // Solver::edits() after the last call
  EnergyReport last_;             // the energy after the last call
  double energy_start_ = 0, energy_last_ = 0;
  double work_ = 0, work_abs_ = 0;
  double scale_ = 0;
  double max_gain_ = 0;
  double drag_nj_ = 0, drag_power_last_ = 0;
  double drag_time_s_ = 0;  // simulated time since the last velocity sample
  std::int64_t calls_ = 0;  // monitored calls that stepped
  bool held_last_ = false;  // the last velocity sample was held at the limit
  double limit_fraction_last_ = 0, period2_last_ = 0;  // of the last velocity sample
  double elastic_drift_ = 0;
  double velocity_limit_ = 0;
  std::int64_t steps_ = 0, steps_at_limit_ = 0, run_at_limit_ = 0, longest_at_limit_ = 0;
  std::int64_t run_held_flipping_ = 0, longest_held_flipping_ = 0;
  double max_limit_fraction_ = 0, max_period2_ = 0;
  double dt_ratio_max_ = 0;
  std::optional<std::string> non_finite_;
};

}  // namespace tsf::crms
