// The CRMS solver: a lattice, its state and a backend (CPU/OpenMP or CUDA) that steps it.
//
//   BoxLatticeOptions box;
//   box.size_mm = {40, 10, 10};
//   box.spacing_mm = 2.5;
//   Lattice lattice = build_box_lattice(box);
//   fix_nodes_in_box(lattice, {-1, -1, -1}, {1.5, 11, 11});
//   SolverConfig config;
//   config.gravity = {0, 0, -9810};
//   config.materials[0].youngs_modulus_pa = 50e3;
//   config.materials[0].viscosity_pa_s = 10;
//   Solver solver(std::move(lattice), config);
//   const double dt = 0.5 * solver.stable_dt();
//   StepReport r = solver.step(1000, dt);          // or step_async + synchronize
//   if (r.instability) std::cerr << r.instability->describe();
//   std::vector<Vec3f> p = solver.positions();      // mm, tissue space
//
// Units: mm, g, s; force µN, energy nJ. State is kept as displacement from rest (node_state_view.h)
// and on CUDA stays on the device: queries synchronise and copy; snapshots() never stall.
// Not thread-safe: one thread owns the solver; readers use snapshots() from any thread.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/animation_timeline.h"
#include "tsf/crms/lattice.h"
#include "tsf/crms/node_state_view.h"
#include "tsf/crms/snapshot_buffer.h"
#include "tsf/crms/solver_config.h"
#include "tsf/crms/stable_time_step.h"
#include "tsf/crms/velocity_signals.h"
#include "tsf/crms/volume_term.h"

namespace tsf::crms {

class SolverBackend;
class EffectsEngine;
struct EffectParameters;

/// The first node whose update was not finite (NaN or Inf); the solver halts on that step.
struct Instability {
  std::int64_t step = 0;  ///< index of the failing step since construction (0-based)
  std::int64_t node = 0;  ///< lowest node index that failed in that step
  Int3 coordinates;
  Vec3d rest_position_mm;
  Vec3d position_mm;    ///< its last finite position (kept)
  Vec3d velocity_mm_s;  ///< its velocity as kept: 0 (the failing update is discarded)
  std::string describe() const;
};

struct StepReport {
  std::int64_t steps_run = 0;  ///< steps this call advanced (fewer when it halted)
  std::optional<Instability> instability;
};

struct EnergyReport {
  double kinetic_nj = 0;        ///< Σ ½·m·|v|²
  double elastic_nj = 0;        ///< Σ springs ½(ks/L)(l−L)² + Σ angles ½kθψ²
  double gravitational_nj = 0;  ///< −Σ m·g·u (0 at rest)
  double load_nj = 0;           ///< −Σ F·u of the constant external forces (0 without loads)
  double total_nj() const { return kinetic_nj + elastic_nj + gravitational_nj + load_nj; }
};

/// What StabilityMonitor samples around a step call (stability_monitor.h).
struct StepSignals {
  EnergyReport energy;       ///< after the call
  bool velocities = false;   ///< the velocity signals were measured
  VelocitySignals velocity;  ///< v0 = the state before the call's last step, v1 after it
};

/// A spring by one end: node and face direction d (0..5 = −x,+x,−y,+y,−z,+z).
struct SpringRef {
  std::int64_t node = 0;
  int direction = 0;
};

class Solver {
 public:
  /// Validates lattice and config (tsf::Error naming the field), calibrates the springs for the
  /// lattice spacing, and creates the backend (kAuto: CUDA when a device is usable, else CPU;
  /// kCuda without a device throws with cuda_status().reason). Implicit Euler runs on the CPU.
  Solver(Lattice lattice, const SolverConfig& config);
  ~Solver();
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  const Lattice& lattice() const { return lattice_; }
  const SolverConfig& config() const { return config_; }
  const MaterialPalette& palette() const { return palette_; }
  /// "cpu (OpenMP, N threads)" or "cuda (device name)".
  std::string backend_name() const;
  bool on_cuda() const { return on_cuda_; }
  /// The compile-time feature set the kernels run with (effects.h).
  unsigned features() const;

  // ---- time step ----
  const StableTimeStep& stable_time_step() const { return stable_; }
  /// Stable dt estimate of the configured integrator, s (implicit Euler: the symplectic bound,
  /// as a scale for accuracy rather than a limit).
  double stable_dt() const;
  /// The |v| limit the kernels apply at step dt, mm/s (0: none; stability.velocity_limit).
  double velocity_limit_mm_s(double dt) const;

  // ---- stepping ----
  /// Advances n steps of dt seconds and waits for them; reports an instability if one occurred
  /// (the solver then halts: later calls advance nothing until clear_instability()).
  StepReport step(int n, double dt);
  /// Enqueues n steps without waiting (CUDA); on the CPU the same as step(). Instabilities are
  /// reported by the next synchronize().
  void step_async(int n, double dt);
  /// step(n, dt), then the energy after it and, with `velocities`, the velocity signals. On CUDA
  /// without effects one pass on the device measures them from the two state buffers and a few
  /// numbers come back (the n steps stay one launch); elsewhere the call's last step is taken
  /// alone and the velocities are copied to the host before and after it.
  StepReport step_measured(int n, double dt, bool with_velocities, StepSignals& signals);
  StepReport synchronize();
  std::int64_t steps_done() const { return steps_done_; }
  const std::optional<Instability>& instability() const { return instability_; }
  void clear_instability();

  // ---- loads, anchors, constraints ----
  void set_gravity(const Vec3d& gravity_mm_s2);
  /// Per-node external force, µN (allocates the force arrays on first use).
  void set_external_forces(const std::vector<std::int64_t>& nodes,
                           const std::vector<Vec3f>& forces_un);
  void clear_external_forces();
  /// Holds nodes at target positions (mm, tissue space) with zero velocity until released.
  void constrain_nodes(const std::vector<std::int64_t>& nodes,
                       const std::vector<Vec3d>& targets_mm);
  /// Frees constrained nodes (they keep their current position and start at rest).
  void release_nodes(const std::vector<std::int64_t>& nodes);
  /// release_nodes(release), then constrain_nodes(hold, targets_mm), as one edit of the backend
  /// (a tool contact's hold step): on CUDA one upload of the flags and the held states, one wait.
  void release_and_constrain(const std::vector<std::int64_t>& release,
                             const std::vector<std::int64_t>& hold,
                             const std::vector<Vec3d>& targets_mm);
  /// Overwrites positions and velocities of some nodes (tools moving nodes to a surface).
  void set_node_states(const std::vector<std::int64_t>& nodes,
                       const std::vector<Vec3d>& positions_mm,
                       const std::vector<Vec3f>& velocities_mm_s);
  /// Overwrites the whole state: displacements from rest (mm) and velocities (mm/s), #nodes each.
  void set_state(const std::vector<Vec3f>& displacements_mm,
                 const std::vector<Vec3f>& velocities_mm_s);

  // ---- topology edits (cutting, docs/deform-cut.md) ----
  /// Deletes nodes during the run: they stop moving and their springs vanish on both ends.
  void delete_nodes(const std::vector<std::int64_t>& nodes);
  /// Breaks springs on both ends.
  void break_springs(const std::vector<SpringRef>& springs);

  // ---- queries (synchronise with the device) ----
  std::vector<Vec3f> positions() const;      ///< #nodes, mm, rest + displacement
  std::vector<Vec3f> displacements() const;  ///< #nodes, mm
  std::vector<Vec3f> velocities() const;     ///< #nodes, mm/s
  EnergyReport energy() const;
  /// Spring force on every node at the current state, µN (#nodes; gravity and external loads
  /// excluded). At a constrained node, minus this is the reaction the constraint supplies.
  std::vector<Vec3f> spring_forces() const;

  // ---- views for other modules (coupler, collisions) ----
  /// Lattice arrays where the backend keeps them (device memory on CUDA).
  LatticeView lattice_view() const;
  /// The current state buffer (device memory on CUDA); valid until the next step.
  StateView state_view() const;

  // ---- snapshots for readers on other threads ----
  /// Starts a copy of the current positions into the snapshot buffer without waiting; dropped
  /// when the previous copy is still in flight.
  void request_snapshot();
  /// Publishes copies that have completed (called by step/request_snapshot too).
  void poll_snapshot();
  const SnapshotBuffer& snapshots() const;

  /// Bytes the backend keeps per node for the lattice and state, effects included (reported by
  /// benchmarks).
  double bytes_per_node() const;

  // ---- optional effects (effects_config.h) ----
  /// Names of the enabled effects, e.g. {"plasticity", "fluid"}; empty when none is on.
  /// "volumetric" when a material has ν > 0 (its volumetric term, volume_term.h).
  std::vector<std::string> active_effects() const;
  /// True when the volumetric term is the only active effect and runs inside the backend's step
  /// launch (CUDA's brick and node-parallel launches, SolverConfig::cuda_fold_volume_term): one
  /// launch per call instead of the effect passes around one-step launches.
  bool volume_term_folded() const;
  /// Host copies of the effects' arrays (synchronises; empty for effects that are off).
  EffectsState effects_state() const;
  /// Springs broken by tearing since construction (synchronises).
  std::int64_t torn_springs() const;
  /// Tearing: brings the links that tearing (and node masking) cleared on the backend to the host
  /// lattice — the cut triggers of their nodes fire, as for a cut — and returns the springs torn
  /// since the last call, each once from its lower node (+x, +y, +z direction). Synchronises
  /// (on CUDA: one copy of the flags, a byte per node); empty and free without tearing.
  std::vector<SpringRef> take_torn_springs();
  /// Fires the animation's triggers that watch `event` (CutTrigger::event, e.g.
  /// "exposure:vessel"). Returns how many fired (each trigger fires once).
  std::size_t raise_event(const std::string& event);
  /// Names of the animation's cut triggers that have fired, in firing order.
  const std::vector<std::string>& fired_triggers() const { return timeline_.fired_triggers(); }
  /// Simulated time since construction, s (Σ n·dt over the steps).
  double time_s() const { return time_s_; }
  /// Calls since construction that changed the state, loads or topology outside step() (loads,
  /// gravity, constraints, node states, deletions, broken springs): a reader that saw the same
  /// count knows the state is what the last step left.
  std::uint64_t edits() const { return edits_; }

 private:
  StepParameters step_parameters(double dt) const;
  /// −Σ F·u of the constant external loads, nJ (0 without loads; reads the state back).
  double load_energy_nj() const;
  /// Adds the velocity signals of every node (host copies of the velocities).
  void measure_velocities(const std::vector<Vec3f>& v0, const std::vector<Vec3f>& v1, double dt,
                          VelocitySignals& s) const;
  /// Uploads the packed flags of `nodes` and their face neighbours.
  void refresh_flags(const std::vector<std::int64_t>& nodes);
  /// The list refresh_flags uploads: `nodes` and their face neighbours, each once, ascending,
  /// with their packed flags.
  void flag_update(const std::vector<std::int64_t>& nodes, std::vector<std::int64_t>& list,
                   std::vector<std::uint8_t>& flags);
  void step_implicit(int n, double dt, StepReport& report);
  Instability make_instability(std::int64_t node, std::int64_t step) const;
  EffectParameters effect_parameters(double dt) const;
  /// λ and λ·τ per palette entry (the volumetric term of materials with ν > 0).
  VolumeParameters volume_parameters() const;
  void step_with_effects(int n, double dt);
  /// Clears on the host lattice the links that tearing removed on the backend.
  void sync_torn_links();
  /// Elastic energy the effects add to the core's (effect_energy.h), nJ.
  double effects_energy_nj() const;
  /// True when the effects' energy is summed where the state lives (the volumetric term alone on
  /// CUDA), so measuring it copies nothing to the host.
  bool effects_energy_on_device() const;
  /// Where the timeline sends material changes: the host lattice is edited by the timeline, the
  /// backend's copy here.
  MaterialUpdate backend_material_update();

  Lattice lattice_;
  SolverConfig config_;
  MaterialPalette palette_;
  StableTimeStep stable_;
  std::unique_ptr<SolverBackend> backend_;
  bool on_cuda_ = false;
  bool external_forces_ = false;
  std::vector<Vec3f> external_host_;      // host copy of the external forces (load energy)
  std::vector<std::uint8_t> flag_marks_;  // refresh_flags' scratch: #nodes, all 0 between calls
  std::int64_t steps_done_ = 0;
  std::optional<Instability> instability_;
  unsigned effect_bits_ = 0;
  std::unique_ptr<EffectsEngine> effects_;
  std::int64_t torn_synced_ = 0;  // springs already cleared on the host lattice by sync_torn_links
  std::vector<SpringRef> torn_pending_;  // synced, not yet taken by take_torn_springs
  double time_s_ = 0.0;
  std::uint64_t edits_ = 0;
  AnimationTimeline timeline_;  // effects.animation (empty when off)
};

}  // namespace tsf::crms
