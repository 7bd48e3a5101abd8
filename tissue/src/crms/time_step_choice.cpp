#include "tsf/crms/time_step_choice.h"

#include <algorithm>
#include <string>

#include "tsf/common/error.h"
#include "tsf/common/text_format.h"
#include "tsf/crms/solver.h"

namespace tsf::crms {
namespace {

/// How the estimate was made: the integrator's bound at the highest mode and the node setting it.
std::string estimate_description(const Solver& solver) {
  const StableTimeStep& s = solver.stable_time_step();
  std::string text = std::string("the ") + to_string(solver.config().integrator) +
                     " stable estimate " + format_text("%.3g s", solver.stable_dt());
  text += format_text(" (highest mode ω = %.4g rad/s, damping ratio ζ = %.3g", s.omega_max,
                      s.zeta_at_omega_max);
  if (s.critical_node >= 0 && s.critical_node < solver.lattice().node_count()) {
    const Int3 c = solver.lattice().geometry().coordinates(s.critical_node);
    text += ", at node (" + std::to_string(c.x) + "," + std::to_string(c.y) + "," +
            std::to_string(c.z) + ")";
  }
  text +=
      "; every palette entry and stiffening effect included, docs/crms.md \"Stable time "
      "step\")";
  return text;
}

}  // namespace

TimeStepChoice choose_time_step(double given_s, double safety, const Solver& solver) {
  TimeStepChoice c;
  c.stable_s = solver.stable_dt();
  c.safety = safety;
  c.automatic = !(given_s > 0.0);
  c.limited = solver.config().integrator != Integrator::kImplicitEuler;
  const std::string integrator = to_string(solver.config().integrator);
  if (c.automatic) {
    require(c.stable_s > 0.0, "solver.dt: the stable step of " + integrator +
                                  " is 0 for this material (explicit Euler needs viscosity > 0); "
                                  "set solver.dt or choose symplectic-euler");
    c.dt_s = std::min(safety * c.stable_s, 1.0);
    c.how = "dt: auto = " + format_text("%.3g", safety) + " × " + estimate_description(solver);
    if (!c.limited)
      c.how += "; implicit Euler has no stability limit, the estimate sets the accuracy scale";
    return c;
  }
  c.dt_s = std::min(given_s, 1.0);
  if (c.limited && c.dt_s > c.stable_s) {
    const std::string over =
        c.stable_s > 0 ? format_text("%.3g× ", c.dt_s / c.stable_s) : std::string("above ");
    require(solver.config().stability.allow_unsafe_dt,
            "solver.dt = " + format_text("%.4g", c.dt_s) + " s is " + over +
                estimate_description(solver) +
                ": an explicit step above it diverges. Use dt: auto (" +
                format_text("%.3g", safety) +
                " × the estimate), a smaller dt or integrator: implicit-euler; to run it anyway "
                "set stability.allow_unsafe_dt: true (the run is then reported unstable if it "
                "is)");
    c.how = "solver.dt = " + format_text("%.4g", c.dt_s) + " s given, " + over +
            estimate_description(solver) + ", allowed by stability.allow_unsafe_dt";
    return c;
  }
  c.how = "solver.dt = " + format_text("%.4g", c.dt_s) + " s given";
  if (c.stable_s > 0)
    c.how += ", " + format_text("%.3g×", c.dt_s / c.stable_s) + " " + estimate_description(solver);
  return c;
}

}  // namespace tsf::crms
