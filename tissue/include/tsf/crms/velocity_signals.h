// The stability monitor's velocity signals (stability_monitor.h) as the backends sum them.
#pragma once

namespace tsf::crms {

/// The stability monitor's velocity sums over the moving nodes (add_velocity_signals in
/// node_energy.h): how many move, how many are at the velocity limit, the kinetic drag's power
/// Σ m·k_sys·|v1|³ (nJ/s), and the mass-weighted products Σ m·v0·v1, Σ m·|v0|², Σ m·|v1|² of the
/// velocities v0 before and v1 after a call's last step (period-2 score −v0v1/√(v0v0·v1v1)).
struct VelocitySignals {
  double moving = 0, at_limit = 0, drag_power = 0;
  double v0v1 = 0, v0v0 = 0, v1v1 = 0;
};

}  // namespace tsf::crms
