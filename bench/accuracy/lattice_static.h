// Static equilibrium of a CRMS lattice for the accuracy report: Newton's method on
//   f_springs(u) + f_loads + m·g = 0
// over the free nodes, with the exact tangent stiffness K = ∂f/∂u from the product's own force
// function (node_force.h evaluated with dual numbers, as the implicit integrator does), solved by
//   * Eigen SimplicialLDLT on −K (symmetric reactions: K is symmetric, −K positive definite near
//     rest), or conjugate gradients with incomplete Cholesky above `direct_max_unknowns`;
//   * Eigen SparseLU for the gather form (its K is not symmetric).
// Why not Solver::step with implicit Euler and a huge dt (what the CRMS tests do)? Same answer,
// but its SparseLU with COLAMD ordering on the 19-node stencil takes minutes beyond a few thousand
// nodes; this solver reaches the 17k-node block in seconds, so the report can show convergence.
// The state stays in double here (the kernels' state is float), so the answer is the lattice's
// equilibrium without the float round-off of a time-stepped relaxation. Materials with ν > 0 add
// the volumetric term of volume_term.h (the same per-cube function, with dual numbers).
#pragma once

#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/solver.h"

namespace tsf::accuracy {

struct LatticeStaticOptions {
  int max_newton_iterations = 12;
  double tolerance = 1e-10;  ///< relative force residual at which Newton stops
  /// A residual below this that no longer falls (by 4× per iteration) is converged: the
  /// float force function's round-off floor.
  double stall_tolerance = 1e-6;
  std::int64_t direct_max_unknowns = 60000;
};

struct LatticeStaticResult {
  std::vector<Vec3d> displacements;  ///< #nodes, mm
  int newton_iterations = 0;
  double relative_residual = 0;  ///< |f + f_loads + m·g| / |f_loads + m·g| over free nodes
  double seconds = 0;
  bool iterative = false;  ///< CG was used
};

/// Equilibrium of `solver`'s lattice under its gravity and `loads_un` at `load_nodes`, with the
/// solver's formulation (angular form, reactions, materials). The solver's state is not changed.
LatticeStaticResult solve_lattice_static(const crms::Solver& solver,
                                         const std::vector<std::int64_t>& load_nodes = {},
                                         const std::vector<Vec3f>& loads_un = {},
                                         const LatticeStaticOptions& options = {});

}  // namespace tsf::accuracy
