#include "tsf/crms/stability_monitor.h"

#include <algorithm>
#include <cmath>

#include "tsf/common/text_format.h"

namespace tsf::crms {
namespace {

/// The size of a state's energy terms, whatever their signs, nJ.
double magnitude(const EnergyReport& e) {
  return std::fabs(e.kinetic_nj) + std::fabs(e.elastic_nj) + std::fabs(e.gravitational_nj) +
         std::fabs(e.load_nj);
}

}  // namespace

const char* to_string(StabilityVerdict verdict) {
  switch (verdict) {
    case StabilityVerdict::kStable:
      return "stable";
    case StabilityVerdict::kSettling:
      return "settling";
    case StabilityVerdict::kUnstable:
      return "unstable";
  }
  return "?";
}

StabilityMonitor::StabilityMonitor(StabilityThresholds thresholds) : thresholds_(thresholds) {}

StepReport StabilityMonitor::step(Solver& solver, int n, double dt) {
  // Nothing edited since the last call: the state is what it left (one energy pass saved).
  const EnergyReport before = started_ && solver.edits() == edits_seen_ ? last_ : solver.energy();
  if (!started_) {
    started_ = true;
    energy_start_ = before.total_nj();
    scale_ = magnitude(before);
  } else {  // what the edits since the last call put in (or took out)
    const double w = before.total_nj() - energy_last_;
    work_ += w;
    work_abs_ += std::fabs(w);
  }
  StepReport report;
  if (n <= 0 || solver.instability()) {
    report.instability = solver.instability();
    energy_last_ = before.total_nj();
    last_ = before;
    edits_seen_ = solver.edits();
    return report;
  }
  const bool measure_v = calls_++ % std::max(1, thresholds_.velocity_every) == 0;
  // The velocities on both sides of the call's last step give the period-2 score; the solver
  // measures them where the state lives (on CUDA, without breaking the call's launch).
  StepSignals signals;
  report = solver.step_measured(n, dt, measure_v, signals);
  const EnergyReport after = signals.energy;
  velocity_limit_ = solver.velocity_limit_mm_s(dt);
  const VelocitySignals& sums = signals.velocity;
  const double vv = signals.velocity.v0v1, v00 = signals.velocity.v0v0, v11 = signals.velocity.v1v1;

  StabilitySample s;
  s.step = solver.steps_done();
  s.time_s = solver.time_s();
  s.energy_nj = after.total_nj();
  s.work_nj = work_;
  elastic_drift_ += after.elastic_nj - before.elastic_nj;
  s.elastic_drift_nj = elastic_drift_;
  s.velocities_measured = measure_v;
  if (measure_v) {
    s.limit_fraction = sums.moving > 0 ? sums.at_limit / sums.moving : 0.0;
    // Kinetic energy too small to carry a mode (round-off motion) gives no score.
    const double kinetic_floor = 1e-12 * std::max(scale_, 1e-30);
    if (v00 > kinetic_floor && v11 > kinetic_floor) s.period2 = -vv / std::sqrt(v00 * v11);
    limit_fraction_last_ = s.limit_fraction;
    period2_last_ = s.period2;
  } else {  // between velocity samples: the last measured state stands
    s.limit_fraction = limit_fraction_last_;
    s.period2 = period2_last_;
  }
  samples_.push_back(s);
  if (samples_.size() >= kMaxSamples) {  // long sessions: keep every other sample, in order
    std::size_t kept = 0;
    for (std::size_t i = 0; i < samples_.size(); i += 2) samples_[kept++] = samples_[i];
    samples_.resize(kept);
  }

  // The drag's power is measured at velocity samples; between them it is taken as the mean of
  // the two ends (trapezoid rule over the simulated time).
  drag_time_s_ += static_cast<double>(report.steps_run) * dt;
  if (measure_v) {
    drag_nj_ += 0.5 * (drag_power_last_ + sums.drag_power) * drag_time_s_;
    drag_power_last_ = sums.drag_power;
    drag_time_s_ = 0;
  }
  scale_ = std::max(scale_, magnitude(after));
  max_gain_ = std::max(max_gain_, after.total_nj() - energy_start_ - work_);
  energy_last_ = after.total_nj();
  last_ = after;
  edits_seen_ = solver.edits();
  steps_ += report.steps_run;
  if (solver.stable_dt() > 0) dt_ratio_max_ = std::max(dt_ratio_max_, dt / solver.stable_dt());
  max_limit_fraction_ = std::max(max_limit_fraction_, s.limit_fraction);
  max_period2_ = std::max(max_period2_, s.period2);
  // Held at the limit: measured at velocity samples, assumed to last until the next one.
  const bool held = measure_v ? s.limit_fraction > thresholds_.limit_fraction : held_last_;
  held_last_ = held;
  run_at_limit_ = held ? run_at_limit_ + report.steps_run : 0;
  steps_at_limit_ += held ? report.steps_run : 0;
  longest_at_limit_ = std::max(longest_at_limit_, run_at_limit_);
  if (measure_v) {  // consecutive velocity samples held at the limit while flipping
    run_held_flipping_ = held && s.period2 > thresholds_.period2 ? run_held_flipping_ + 1 : 0;
    longest_held_flipping_ = std::max(longest_held_flipping_, run_held_flipping_);
  }
  if (report.instability && !non_finite_) non_finite_ = report.instability->describe();
  return report;
}

StabilitySummary StabilityMonitor::summary(const Solver& solver) const {
  StabilitySummary r;
  const StabilityThresholds& t = thresholds_;
  r.energy_start_nj = energy_start_;
  r.energy_end_nj = started_ ? energy_last_ : 0.0;
  r.work_in_nj = work_;
  r.dissipated_nj = energy_start_ + work_ - r.energy_end_nj;
  r.max_gain_nj = std::max(max_gain_, 0.0);
  r.energy_scale_nj = scale_ + work_abs_;
  r.gain_fraction = r.energy_scale_nj > 0 ? r.max_gain_nj / r.energy_scale_nj : 0.0;
  r.kinetic_drag_nj = drag_nj_;
  r.velocity_limit_mm_s = velocity_limit_;
  r.max_limit_fraction = max_limit_fraction_;
  r.end_limit_fraction = samples_.empty() ? 0.0 : samples_.back().limit_fraction;
  r.steps_at_limit = steps_at_limit_;
  r.longest_at_limit = longest_at_limit_;
  r.max_period2 = max_period2_;
  r.end_period2 = samples_.empty() ? 0.0 : samples_.back().period2;
  r.held_flipping_samples = longest_held_flipping_;
  r.samples = static_cast<std::int64_t>(samples_.size());
  r.steps = steps_;
  r.dt_max_over_stable = dt_ratio_max_;
  r.non_finite = non_finite_;
  // The animation's rest keyframes move the springs' rest lengths inside the steps: work the
  // monitor cannot separate from the integrator's.
  r.energy_balance_checked = !solver.config().effects.animation.enabled;

  std::vector<std::string> unstable;
  if (non_finite_) unstable.push_back("the NaN guard halted the solver: " + *non_finite_);
  if (r.energy_balance_checked && r.gain_fraction > t.energy_gain)
    unstable.push_back(format_text(
        "energy grew %.3g nJ beyond what tools, loads and gravity put in (%.0f%% of the run's "
        "energy scale %.3g nJ; threshold %.0f%%)",
        r.max_gain_nj, 100 * r.gain_fraction, r.energy_scale_nj, 100 * t.energy_gain));
  if (longest_held_flipping_ >= t.held_samples)
    unstable.push_back(format_text(
        "up to %.1f%% of the moving nodes sat at the velocity limit (%.3g mm/s) reversing every "
        "step (period-2 score up to %.2f) for %lld samples in a row: a diverging mode held down "
        "by the limit",
        100 * max_limit_fraction_, velocity_limit_, max_period2_,
        static_cast<long long>(longest_held_flipping_)));
  if (!unstable.empty()) {
    r.verdict = StabilityVerdict::kUnstable;
    for (const std::string& u : unstable) r.reason += (r.reason.empty() ? "" : "; ") + u;
    const double stable = solver.stable_dt();
    r.advice = dt_ratio_max_ > 1.0
                   ? format_text(
                         "a smaller solver.dt (up to %.2f× the stable estimate %.3g s was "
                         "used; dt: auto takes 0.9×), integrator: implicit-euler, or more "
                         "damping (material viscosity, stability.kinetic_damping)",
                         dt_ratio_max_, stable)
                   : std::string(
                         "integrator: implicit-euler, more damping (material viscosity, "
                         "stability.kinetic_damping) or a smaller solver.dt");
    r.allowed = solver.config().stability.allow_unstable;
    return r;
  }
  // Settling, over the last quarter of the samples (the work done meanwhile set aside): energy
  // still leaving the lattice, or its elastic energy still changing while it steps; or nodes at
  // the velocity limit at the end.
  double leaving = 0, deforming = 0;
  if (samples_.size() >= 4) {
    const StabilitySample& q = samples_[(samples_.size() - 1) * 3 / 4];
    const StabilitySample& e = samples_.back();
    leaving = (q.energy_nj - q.work_nj) - (e.energy_nj - e.work_nj);
    deforming = std::fabs(e.elastic_drift_nj - q.elastic_drift_nj);
  }
  const double scale = r.energy_scale_nj > 0 ? r.energy_scale_nj : 1.0;
  if (leaving / scale > t.settling_change) {
    r.verdict = StabilityVerdict::kSettling;
    r.reason = format_text(
        "energy is still leaving the lattice: %.3g nJ (%.1f%% of the energy scale) over the last "
        "quarter of the run, no gain beyond the work put in",
        leaving, 100 * leaving / scale);
  } else if (deforming / scale > t.settling_change) {
    r.verdict = StabilityVerdict::kSettling;
    r.reason = format_text(
        "the tissue is still deforming: its elastic energy changed %.3g nJ (%.1f%% of the energy "
        "scale) while it stepped over the last quarter of the run, no gain beyond the work put in",
        deforming, 100 * deforming / scale);
  } else if (r.end_limit_fraction > t.limit_fraction) {
    r.verdict = StabilityVerdict::kSettling;
    r.reason = format_text(
        "%.1f%% of the moving nodes are at the velocity limit (%.3g mm/s) at the end without "
        "reversing every step (fast or falling pieces held by the safety net)",
        100 * r.end_limit_fraction, velocity_limit_);
  }
  if (r.verdict == StabilityVerdict::kSettling) {
    r.advice = "a longer run, or more damping (material viscosity) to settle sooner";
    return r;
  }
  r.reason = format_text(
      "energy balanced (largest gain beyond the work put in %.2g%% of the energy scale, "
      "threshold %.0f%%), %.1f%% of the nodes at most at the velocity limit, period-2 score at "
      "most %.2f",
      100 * r.gain_fraction, 100 * t.energy_gain, 100 * max_limit_fraction_, max_period2_);
  if (!r.energy_balance_checked)
    r.reason += " (energy balance not checked: the animation's rest keyframes do work)";
  return r;
}

std::string StabilitySummary::headline() const {
  std::string h = std::string(to_string(verdict)) + ": " + reason;
  if (!advice.empty()) h += "; try " + advice;
  if (verdict == StabilityVerdict::kUnstable && allowed)
    h += " (stability.allow_unstable: true keeps the exit status 0)";
  return h;
}

}  // namespace tsf::crms
