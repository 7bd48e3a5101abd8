// Implicit (backward) Euler for the CRMS lattice on the CPU: the accurate/stiff reference.
//
// Unknown: the new velocity v of every alive, unfixed node. Backward Euler
//   M·(v − v0) = dt·( f(u0 + dt·v, v) + f_ext + M·g )
// is solved by Newton's method on g(v) = M(v − v0) − dt·(f + f_ext + M·g) with the Jacobian
//   J = M − dt·∂f/∂v − dt²·∂f/∂u,
// both derivatives exact: the force of node_force.h evaluated with dual numbers (dual.h), one
// seeded neighbour at a time, for the linear and the angular springs alike, in the same
// formulation (gather or symmetric, exact or cosine) as the explicit kernels. The gather form's
// Jacobian is not symmetric, so the linear systems are solved with Eigen's SparseLU. Then
// u = u0 + dt·v. One Newton iteration is the linearised backward Euler of Baraff & Witkin (1998);
// iterating makes it the fully implicit step. Newton stops when the relative residual is below the
// tolerance, or the residual has dropped by the tolerance from the step's first, or the last
// update moved no node by more than tolerance × the smallest spacing (the resolution of the float
// state, where the residual sits at its round-off floor).
//
// The volumetric term (materials with ν > 0) adds per intact cube its corner forces π·∂V/∂x_q
// (volume_term.h), differentiated with dual numbers seeded on the 8 corners' u and v.
//
// After the solve the stability controls (kinetic damping, velocity limit) filter v as in the
// explicit schemes (node_update.h), and u = u0 + dt·v uses the filtered v.
#pragma once

#include <cstdint>

#include "tsf/crms/node_state_view.h"
#include "tsf/crms/volume_term.h"

namespace tsf::crms {

struct ImplicitStepStats {
  int newton_iterations = 0;
  double relative_residual = 0;  ///< |g| / (|M·(v−v0)| + dt·|f| + tiny) after the last update
  bool converged = false;
  std::int64_t first_non_finite_node = -1;  ///< ≥ 0: the step was rejected, state unchanged
};

/// One backward-Euler step in place on host arrays. `features` as the kernels' (effects.h);
/// `volume`: the volumetric term of materials with ν > 0 (volume_term.h), its forces and exact
/// Jacobian per cube with dual numbers too (nullptr: none).
ImplicitStepStats implicit_euler_step(const LatticeView& lattice, const StateView& state,
                                      const StepParameters& parameters, unsigned features,
                                      int max_newton_iterations, double tolerance,
                                      const VolumeParameters* volume = nullptr);

}  // namespace tsf::crms
