#include "tsf/crms/solver_config.h"

#include <cmath>
#include <string>

#include "tsf/common/error.h"

namespace tsf::crms {

const char* to_string(Integrator integrator) {
  switch (integrator) {
    case Integrator::kExplicitEuler:
      return "explicit-euler";
    case Integrator::kSymplecticEuler:
      return "symplectic-euler";
    case Integrator::kImplicitEuler:
      return "implicit-euler";
  }
  return "?";
}
const char* to_string(Backend backend) {
  switch (backend) {
    case Backend::kAuto:
      return "auto";
    case Backend::kCpu:
      return "cpu";
    case Backend::kCuda:
      return "cuda";
  }
  return "?";
}
const char* to_string(AngularForm form) {
  return form == AngularForm::kExact ? "exact" : "cosine";
}
const char* to_string(AngularReactions reactions) {
  return reactions == AngularReactions::kGather ? "gather" : "symmetric";
}

const char* to_string(ForceEvaluation evaluation) {
  return evaluation == ForceEvaluation::kShared ? "shared" : "per-node";
}
const char* to_string(CpuInstructionSet isa) {
  switch (isa) {
    case CpuInstructionSet::kAuto:
      return "auto";
    case CpuInstructionSet::kBaseline:
      return "baseline";
    case CpuInstructionSet::kAvx2:
      return "avx2";
    case CpuInstructionSet::kAvx512:
      return "avx512";
  }
  return "?";
}

const char* to_string(CudaLaunch launch) {
  switch (launch) {
    case CudaLaunch::kAuto:
      return "auto";
    case CudaLaunch::kGraphs:
      return "graphs";
    case CudaLaunch::kPersistent:
      return "persistent";
    case CudaLaunch::kNodes:
      return "nodes";
    case CudaLaunch::kBricks:
      return "bricks";
  }
  return "?";
}

const char* to_string(CudaTileKernel kernel) {
  switch (kernel) {
    case CudaTileKernel::kStaged:
      return "staged";
    case CudaTileKernel::kDirect:
      return "direct";
  }
  return "?";
}

void validate_solver_config(const SolverConfig& c) {
  const double g = std::sqrt(length_squared(c.gravity));
  require(std::isfinite(g) && g <= 1e7,
          "gravity magnitude = " + std::to_string(g) + " mm/s² is out of range [0, 1e7]");
  const double k = c.stability.kinetic_damping;
  require(std::isfinite(k) && k >= 0.0 && k <= 1e3,
          "stability.kinetic_damping = " + std::to_string(k) + " 1/mm is out of range [0, 1e3]");
  const double vl = c.stability.velocity_limit;
  require(std::isfinite(vl) && vl <= 1e9,
          "stability.velocity_limit = " + std::to_string(vl) +
              " mm/s is out of range (< 0 automatic, 0 off, up to 1e9)");
  const double f = c.stability.velocity_limit_auto_fraction;
  require(
      std::isfinite(f) && f > 0.0 && f <= 10.0,
      "stability.velocity_limit_auto_fraction = " + std::to_string(f) + " is out of range (0, 10]");
  require(!c.materials.empty() && c.materials.size() <= kMaxMaterials,
          "materials: " + std::to_string(c.materials.size()) + " given, expected 1.." +
              std::to_string(kMaxMaterials));
  for (std::size_t m = 0; m < c.materials.size(); ++m)
    validate_material(c.materials[m], ("materials[" + std::to_string(m) + "]").c_str());
  require(c.cuda_steps_per_graph >= 2 && c.cuda_steps_per_graph <= 4096 &&
              c.cuda_steps_per_graph % 2 == 0,
          "cuda_steps_per_graph = " + std::to_string(c.cuda_steps_per_graph) +
              ", expected an even number in [2, 4096]");
  require(c.cpu_tile_rows >= 0 && c.cpu_tile_rows <= 65536,
          "cpu_tile_rows = " + std::to_string(c.cpu_tile_rows) +
              " is out of range (0 = automatic, else 1..65536)");
  require(c.cuda_planes_per_block >= 0 && c.cuda_planes_per_block <= 4096,
          "cuda_planes_per_block = " + std::to_string(c.cuda_planes_per_block) +
              " is out of range (0 = automatic, else 1..4096)");
  require(
      c.cuda_tile_rows == 0 || c.cuda_tile_rows == 4 || c.cuda_tile_rows == 8,
      "cuda_tile_rows = " + std::to_string(c.cuda_tile_rows) + ", expected 0 (automatic), 4 or 8");
  require(c.implicit_newton_iterations >= 1 && c.implicit_newton_iterations <= 50,
          "implicit_newton_iterations = " + std::to_string(c.implicit_newton_iterations) +
              " is out of range [1, 50]");
  require(
      std::isfinite(c.implicit_tolerance) && c.implicit_tolerance >= 0.0 &&
          c.implicit_tolerance < 1.0,
      "implicit_tolerance = " + std::to_string(c.implicit_tolerance) + " is out of range [0, 1)");
  validate_effects_config(c.effects);
  require(!(c.integrator == Integrator::kImplicitEuler && c.effects.any()),
          "effects (plasticity, anisotropy, fluid, tearing) run with the explicit integrators "
          "only: use integrator symplectic-euler or explicit-euler");
  require(!(c.integrator == Integrator::kImplicitEuler && c.backend == Backend::kCuda),
          "integrator implicit-euler runs on the CPU only: use backend cpu or auto");
}

void validate_time_step(double dt) {
  require(std::isfinite(dt) && dt > 0.0 && dt <= 1.0,
          "time step dt = " + std::to_string(dt) + " s is out of range (0, 1]");
}

}  // namespace tsf::crms
