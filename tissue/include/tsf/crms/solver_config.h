// How a CRMS solver runs: integrator, backend, formulation knobs, gravity, stability controls and
// the materials. Every numeric field has a documented range; validate_solver_config() rejects a
// value outside it with a message naming the field (`solver.dt`, `material.youngs_modulus`, …).
#pragma once

#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/calibration.h"
#include "tsf/crms/effects_config.h"
#include "tsf/crms/spring_constants.h"

namespace tsf::crms {

enum class Integrator {
  kExplicitEuler,    ///< thesis Eq. 11; needs damping (dt < η/E), cheapest
  kSymplecticEuler,  ///< same cost, conserves energy in the undamped limit: the default
  kImplicitEuler,    ///< backward Euler with Newton on the exact Jacobian (CPU, Eigen): the
                     ///< accurate/stiff reference, unconditionally stable, numerically damped
};
enum class Backend { kAuto, kCpu, kCuda };
enum class AngularForm {
  kExact,   ///< ψ = θ0 − acos(cos θ): the thesis deflection
  kCosine,  ///< ψ = cos θ: cheaper, same stiffness at rest, softer at large deflection
};
enum class AngularReactions {
  /// Vertex terms only (the thesis): 7-node stencil, ~2.5× cheaper. Not conservative: its
  /// stiffness matrix is not symmetric and short-wavelength modes flutter (grow) unless the
  /// material damping outruns them (test_stable_time_step.cpp, docs/crms.md).
  kGather,
  /// Plus the arm reactions: forces derive from one potential (conservative, momentum
  /// preserving), 19-node stencil. The default.
  kSymmetric,
};

/// How the kernels evaluate the symmetric form each step (same physics; a cost knob).
enum class ForceEvaluation {
  /// Every spring and angle once per step, its reactions shared with the nodes they act on: two
  /// passes over a 7-node stencil (node_force.h). The default.
  kShared,
  /// Every node evaluates its whole 19-node stencil (each angle three times): the original
  /// kernels, kept as the reference the shared evaluation is tested and benchmarked against.
  kPerNode,
};
/// How the CUDA backend launches the steps of one Solver::step call (same physics; the symmetric
/// form with the shared evaluation uses them, other forms use graphs).
enum class CudaLaunch {
  /// For lattices of up to 2^18 nodes of which up to 2^17 are alive (where a step is bounded by
  /// latency, not arithmetic): kBricks where every brick gets a resident thread block, else
  /// kNodes; graphs above.
  kAuto,
  /// CUDA graphs of cuda_steps_per_graph launches, one kernel per step over tiles of the lattice.
  kGraphs,
  /// One cooperative launch runs all the steps over the same tiles, a grid barrier between steps.
  kPersistent,
  /// One cooperative launch runs all the steps, each alive node's angles spread over three
  /// threads (one per angle plane), two grid barriers per step (docs/crms.md "Small lattices").
  kNodes,
  /// One cooperative launch runs all the steps; each thread block steps bricks of 4 × 4 × 4 nodes
  /// from a shared-memory copy of the brick and the layer around it, computing the reactions of
  /// that layer itself: one grid barrier per step (docs/crms.md "Small lattices").
  kBricks,
};
/// Which kernel runs the tiles of the shared evaluation in the graphs launch (same physics; a
/// benchmark knob that keeps the previous kernel selectable).
enum class CudaTileKernel {
  /// Each plane's state (u, v, 1/m, flags) of the tile and its one-node ring staged in shared
  /// memory, the halo's reactions split over two threads (docs/crms.md "The default kernel
  /// against the roofline"). The default.
  kStaged,
  /// Neighbour state read from global memory through L1/L2 (the earlier kernel).
  kDirect,
};
/// Instruction set of the CPU kernels. kAuto takes the widest the processor has; naming one the
/// processor lacks is an error.
enum class CpuInstructionSet { kAuto, kBaseline, kAvx2, kAvx512 };

const char* to_string(Integrator integrator);
const char* to_string(Backend backend);
const char* to_string(AngularForm form);
const char* to_string(AngularReactions reactions);
const char* to_string(ForceEvaluation evaluation);
const char* to_string(CpuInstructionSet isa);
const char* to_string(CudaLaunch launch);
const char* to_string(CudaTileKernel kernel);

struct StabilityControls {
  /// k_sys, 1/mm: speed-dependent drag a = −k_sys·|v|·v (node_update.h). Range [0, 1e3].
  double kinetic_damping = 0.0;
  /// |v| limit, mm/s. 0 = none; < 0 = automatic: |velocity_limit_auto_fraction| of the smallest
  /// spacing per step (v_max = f·h_min/dt), so no node crosses more than that per step.
  double velocity_limit = -1.0;
  /// Fraction used by the automatic limit; range (0, 10].
  double velocity_limit_auto_fraction = 0.25;
  /// A given dt above the explicit integrator's stable estimate is refused (time_step_choice.h)
  /// unless this is set; the run is then watched like any other and reported unstable if it is.
  bool allow_unsafe_dt = false;
  /// An unstable verdict (stability_monitor.h) makes the commands exit non-zero unless this is
  /// set; the report still says unstable.
  bool allow_unstable = false;
};

struct SolverConfig {
  Integrator integrator = Integrator::kSymplecticEuler;
  Backend backend = Backend::kAuto;
  AngularForm angular_form = AngularForm::kExact;
  AngularReactions angular_reactions = AngularReactions::kSymmetric;
  Vec3d gravity{0.0, 0.0, 0.0};  ///< mm/s² (Earth: 9810); |g| ≤ 1e7
  StabilityControls stability;
  /// Materials indexed by the lattice's per-node material (≥ 1, ≤ kMaxMaterials). Calibrated with
  /// calibrate_springs() for this lattice's spacing and angular_reactions.
  std::vector<Material> materials =
      std::vector<Material>(1);  // (not {Material{}}: GCC 12 warns on the initializer_list copy)
  ForceEvaluation force_evaluation = ForceEvaluation::kShared;
  CpuInstructionSet cpu_instruction_set = CpuInstructionSet::kAuto;
  /// CPU, shared evaluation: lattice rows per tile (0 = sized so that a thread's ring of terms,
  /// 3 planes × 84 bytes × (rows + 2) × nx, stays in its core's cache; else 1..65536). A tuning
  /// and testing knob; results do not depend on it.
  int cpu_tile_rows = 0;
  /// Optional effects (effects_config.h); all off by default. Explicit integrators only.
  EffectsConfig effects;
  /// CUDA: steps captured per CUDA graph launch (even, 2..4096).
  int cuda_steps_per_graph = 64;
  /// CUDA, shared evaluation: lattice planes each thread block marches through (0 = chosen from
  /// the lattice size and the device; else 1..4096) and rows of its 32-wide tile (0 = chosen;
  /// else 4 or 8). Tuning knobs for benchmarks; results do not depend on them.
  int cuda_planes_per_block = 0;
  int cuda_tile_rows = 0;
  /// CUDA: how the steps of a call are launched (see CudaLaunch). A tuning and benchmark knob.
  CudaLaunch cuda_launch = CudaLaunch::kAuto;
  /// CUDA: which tile kernel the graphs launch runs (see CudaTileKernel). A benchmark knob.
  CudaTileKernel cuda_tile_kernel = CudaTileKernel::kStaged;
  /// CUDA: fold the volumetric term into the brick and node-parallel launches (one launch for a
  /// call's steps, the term's cube pass and kick inside each step) when it is the only active
  /// effect; false runs the effect passes around one-step launches. A benchmark and test knob; the
  /// results agree to float rounding.
  bool cuda_fold_volume_term = true;
  /// Implicit Euler: Newton iterations per step (1 = linearised backward Euler) and the relative
  /// residual at which they stop early. Ranges [1, 50] and [0, 1).
  int implicit_newton_iterations = 8;
  double implicit_tolerance = 1e-7;
};

/// Throws tsf::Error naming the first out-of-range field.
void validate_solver_config(const SolverConfig& config);

/// Validates a time step, s: finite, > 0, ≤ 1.
void validate_time_step(double dt);

}  // namespace tsf::crms
