// What a CRMS backend does for the solver: keep the lattice arrays and the ping-pong state where
// the kernels run, step them with the per-node function of node_update.h, and move data in and
// out. Private to tissue/src/crms: users talk to crms::Solver.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/lattice_geometry.h"
#include "tsf/crms/node_energy.h"
#include "tsf/crms/node_state_view.h"
#include "tsf/crms/snapshot_buffer.h"
#include "tsf/crms/solver_config.h"
#include "tsf/crms/volume_term.h"

namespace tsf::crms {

/// The first non-finite node update: lowest node index within the first failing step.
struct GuardHit {
  std::int64_t node = 0;
  std::int64_t step = 0;  ///< backend step index (steps started since creation)
};

struct EnergySums {
  double kinetic = 0, elastic = 0, gravitational = 0;
};

/// The volumetric term (volume_term.h) folded into the steps of one call: in every step the cube
/// pass on the state the step reads, and after the core update each moving node's kick by its
/// cubes' forces (kick_after_step) — what the effect passes kVolumeTerms and kKick do around a
/// one-step call (effects_engine.h), for all n steps in one launch.
struct FoldedVolumeTerm {
  VolumeParameters parameters;
  /// The cube pass's arrays (#nodes each, where the backend keeps its state): the effects
  /// engine's, for a launch that exchanges the cubes' terms through memory.
  float* terms[9] = {};
};

class SolverBackend {
 public:
  virtual ~SolverBackend() = default;
  virtual std::string name() const = 0;

  /// Copies the lattice arrays (#nodes each); `material` may be empty (homogeneous).
  virtual void upload_lattice(const std::vector<std::uint8_t>& flags,
                              const std::vector<float>& inv_mass,
                              const std::vector<MaterialBlend>& material) = 0;
  /// Overwrites the material blends of some nodes (heterogeneous lattices only).
  virtual void update_materials(const std::vector<std::int64_t>& nodes,
                                const std::vector<MaterialBlend>& blends) = 0;
  /// Overwrites the flags of some nodes (topology edits, anchors).
  virtual void update_flags(const std::vector<std::int64_t>& nodes,
                            const std::vector<std::uint8_t>& flags) = 0;
  /// Allocates zeroed per-node external forces (features::kExternalForces).
  virtual void enable_external_forces() = 0;
  virtual void set_external_forces(const std::vector<std::int64_t>& nodes,
                                   const std::vector<Vec3f>& forces) = 0;
  virtual void clear_external_forces() = 0;

  /// Scatters displacement and velocity of some nodes into the current state.
  virtual void write_nodes(const std::vector<std::int64_t>& nodes, const std::vector<Vec3f>& u,
                           const std::vector<Vec3f>& v) = 0;
  virtual void write_state(const std::vector<Vec3f>& u, const std::vector<Vec3f>& v) = 0;
  /// update_flags(flag_nodes, flags), then write_nodes(nodes, u, v): one edit (CUDA queues both
  /// on its stream and waits once).
  virtual void update_flags_and_write_nodes(const std::vector<std::int64_t>& flag_nodes,
                                            const std::vector<std::uint8_t>& flags,
                                            const std::vector<std::int64_t>& nodes,
                                            const std::vector<Vec3f>& u,
                                            const std::vector<Vec3f>& v) {
    update_flags(flag_nodes, flags);
    write_nodes(nodes, u, v);
  }
  /// Waits for queued work and copies the current state (either pointer may be null).
  virtual void read_state(std::vector<Vec3f>* u, std::vector<Vec3f>* v) = 0;

  /// Runs n steps (asynchronously where the backend can). After a guard hit every later step
  /// leaves the state unchanged until reset_guard().
  virtual void step(int n, const StepParameters& parameters, unsigned features) = 0;
  /// True when step_folded() can run n steps with the volumetric term folded in, for these
  /// features (the CUDA backend's brick and node-parallel launches).
  virtual bool folds_volume_term(unsigned features) const {
    (void)features;
    return false;
  }
  /// step() with the volumetric term folded in (only where folds_volume_term()).
  virtual void step_folded(int n, const StepParameters& parameters, unsigned features,
                           const FoldedVolumeTerm& volume) {
    (void)n, (void)parameters, (void)features, (void)volume;
  }
  /// Waits for queued steps; returns the guard hit if one happened since the last reset.
  virtual std::optional<GuardHit> synchronize() = 0;
  virtual void reset_guard() = 0;

  virtual EnergySums energy(const StepParameters& parameters, unsigned features) = 0;
  /// The energy sums and, with `velocities`, the velocity signals of the moving nodes
  /// (node_energy.h), v0 being the state before the last step (the other ping-pong buffer): in
  /// one pass where the state lives, read back as a few numbers. Valid right after step() with
  /// nothing written in between. Returns false where the backend has no such pass (the solver
  /// then measures through read_state). With `guard`, it also reads the guard as synchronize()
  /// does, in the same wait: a monitored call right after step_async() waits once, not for the
  /// steps and then again for the sums.
  virtual bool step_signals(const StepParameters& parameters, unsigned features, bool velocities,
                            double kinetic_damping, EnergySums& energy, VelocitySignals& v,
                            std::optional<GuardHit>* guard = nullptr) {
    (void)parameters, (void)features, (void)velocities, (void)kinetic_damping, (void)energy,
        (void)v, (void)guard;
    return false;
  }
  /// Whether step_signals() has its pass here (it may then be called with `guard` right after
  /// step_async() instead of synchronize()).
  virtual bool has_step_signals() const { return false; }
  /// Spring force on every node at the current state, µN (external loads and gravity excluded).
  virtual void spring_forces(const StepParameters& parameters, unsigned features,
                             std::vector<Vec3f>& forces) = 0;

  virtual LatticeView lattice_view() const = 0;
  virtual StateView state_view() const = 0;

  virtual void request_snapshot(std::int64_t step) = 0;
  virtual void poll_snapshot() = 0;
  virtual const SnapshotBuffer& snapshots() const = 0;

  virtual double bytes_per_node() const = 0;
  /// The stream the backend's work is ordered on (cudaStream_t; null on the CPU).
  virtual void* native_stream() const { return nullptr; }
};

/// The SolverConfig fields a backend needs (validated by validate_solver_config).
struct BackendOptions {
  ForceEvaluation evaluation = ForceEvaluation::kShared;
  CpuInstructionSet cpu_instruction_set = CpuInstructionSet::kAuto;
  int cpu_tile_rows = 0;
  int cuda_steps_per_graph = 64;
  int cuda_planes_per_block = 0;
  int cuda_tile_rows = 0;
  CudaLaunch cuda_launch = CudaLaunch::kAuto;
  CudaTileKernel cuda_tile_kernel = CudaTileKernel::kStaged;
  bool cuda_fold_volume_term = true;
};
BackendOptions backend_options(const SolverConfig& config);

/// Throws tsf::Error when the configured instruction set is not available on this processor.
std::unique_ptr<SolverBackend> make_cpu_backend(const LatticeGeometry& geometry,
                                                const BackendOptions& options);
/// Throws tsf::Error (with cuda_status().reason) when CUDA is not built or has no device.
std::unique_ptr<SolverBackend> make_cuda_backend(const LatticeGeometry& geometry,
                                                 const BackendOptions& options);

}  // namespace tsf::crms
