// The passes of the optional effects (effect_physics.h) where the backend keeps its arrays: host
// memory for the CPU backend, device memory for the CUDA backend. The order of the passes is the
// one table below (docs/effects.md, "The effects"); a backend only says how one pass runs. Private
// to tissue/src/crms: the solver creates an engine only when the scene enables an effect, and the
// engine allocates only the arrays of the enabled effects.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "tsf/crms/animation_timeline.h"
#include "tsf/crms/effect_physics.h"
#include "tsf/crms/effects_config.h"
#include "tsf/crms/lattice_geometry.h"
#include "tsf/crms/node_state_view.h"

namespace tsf::crms {

/// The effect passes of a step (effect_physics.h, passes 1–6; pass 4 is the core step).
enum class EffectPass : int {
  kCubePressure,    ///< 1. fluid: each cube's pressure from its volume change
  kVolumeTerms,     ///< 1. volumetric: each cube's pressure times its face vectors
  kEffectForce,     ///< 2. each node's effect force
  kKick,            ///< 4. after the core step: v += dt·F/m (and u += dt²·F/m, symplectic)
  kUpdateStores,    ///< 5. plastic offsets creep and recover, fluid flows
  kTear,            ///< 6. over-strained links are cleared
  kMarkOverloaded,  ///< 6a. node masking: nodes whose largest tension exceeds the limit
  kUnlinkMasked,    ///< 6b. node masking: every link with a marked end is cleared
};

/// A pass and the effects that need it (it runs when any of `when_any` is enabled).
struct EffectPassEntry {
  EffectPass pass;
  unsigned when_any;
};

/// The order of the passes, written once for every backend: before the core step (on the state
/// it reads) and after it (on the state it wrote: the kick adds the force passes 1–2 computed).
inline constexpr EffectPassEntry kPassesBeforeStep[] = {
    {EffectPass::kCubePressure, effect_bits::kFluid},
    {EffectPass::kVolumeTerms, effect_bits::kVolumetric},
    {EffectPass::kEffectForce, effect_bits::kForceEffects},
};
inline constexpr EffectPassEntry kPassesAfterStep[] = {
    {EffectPass::kKick, effect_bits::kForceEffects | effect_bits::kVolumetric},
    {EffectPass::kUpdateStores, effect_bits::kPlasticity | effect_bits::kFluid},
    {EffectPass::kTear, effect_bits::kTearing},
    {EffectPass::kMarkOverloaded, effect_bits::kNodeMasking},
    {EffectPass::kUnlinkMasked, effect_bits::kNodeMasking},
};

/// Runs the pass lists above; a backend supplies one pass over all nodes (run_pass) and the
/// arrays. `enabled`: effect_bits; `keyframes`: how many rest keyframes the engine keeps.
class EffectsEngine {
 public:
  EffectsEngine(unsigned enabled, std::size_t keyframes)
      : enabled_(enabled), keyframes_(keyframes) {}
  virtual ~EffectsEngine() = default;
  EffectsEngine(const EffectsEngine&) = delete;
  EffectsEngine& operator=(const EffectsEngine&) = delete;

  unsigned enabled() const { return enabled_; }
  /// Passes 1–2 on the state the next core step reads.
  void before_step(const LatticeView& lattice, const StateView& state, const EffectParameters& p) {
    run(kPassesBeforeStep, lattice, state, p);
  }
  /// Passes 4–6 on the state the core step wrote (tearing clears link bits in `lattice.flags`).
  void after_step(const LatticeView& lattice, const StateView& state, const EffectParameters& p) {
    run(kPassesAfterStep, lattice, state, p);
  }
  /// Copies the effect arrays to the host (waits for queued work).
  virtual EffectsState read() const = 0;
  /// Copies the lattice flags (#nodes) from where the backend keeps them.
  virtual std::vector<std::uint8_t> read_flags(const LatticeView& lattice) const = 0;
  /// The volumetric term's energy (nJ) summed where the state lives, or nothing when this engine
  /// does not sum it there (the CPU's: its host sum is as cheap). Waits for queued work.
  virtual std::optional<double> volume_energy_here(const LatticeView& lattice,
                                                   const ConstStateView& state,
                                                   const EffectParameters& p) const {
    (void)lattice, (void)state, (void)p;
    return std::nullopt;
  }
  /// volume_energy_here without the wait: queues the sum on the stream the backend steps on and
  /// returns true, or false where this engine has no such sum. The value is read by
  /// queued_volume_energy() once the caller has waited for that stream (the solver's one wait
  /// per monitored call, SolverBackend::step_signals).
  virtual bool queue_volume_energy(const LatticeView& lattice, const ConstStateView& state,
                                   const EffectParameters& p) const {
    (void)lattice, (void)state, (void)p;
    return false;
  }
  virtual double queued_volume_energy() const { return 0.0; }
  /// The volumetric term's cube-pass arrays (9, #nodes each, where the backend keeps its state)
  /// for a backend that folds the term into its launch (SolverBackend::step_folded); null
  /// without the term or where no backend folds it (the CPU).
  virtual float* const* volume_term_arrays() { return nullptr; }
  /// Bytes kept per node by the enabled effects.
  double bytes_per_node() const {
    double b = 0;
    if (enabled_ & effect_bits::kPlasticity) b += 3 * sizeof(float);
    if (enabled_ & effect_bits::kFluid) b += 2 * sizeof(float);
    if (enabled_ & effect_bits::kForceEffects) b += 3 * sizeof(float);
    if (enabled_ & effect_bits::kRestAnimation)
      b += 3 * sizeof(float) * static_cast<double>(keyframes_);
    if (enabled_ & effect_bits::kNodeMasking) b += 1;
    if (enabled_ & effect_bits::kVolumetric) b += 9 * sizeof(float);
    return b;
  }

 protected:
  /// One pass over every node (or cube), where the backend keeps its arrays. Tearing and node
  /// masking write the backend's own flags array (`lattice.flags`).
  virtual void run_pass(EffectPass pass, const LatticeView& lattice, const StateView& state,
                        const EffectParameters& p) = 0;

 private:
  template <std::size_t N>
  void run(const EffectPassEntry (&passes)[N], const LatticeView& lattice, const StateView& state,
           const EffectParameters& p) {
    for (const EffectPassEntry& e : passes)
      if (enabled_ & e.when_any) run_pass(e.pass, lattice, state, p);
  }

  unsigned enabled_;
  std::size_t keyframes_;
};

/// `enabled`: effect_bits; `keyframes`: the animation's rest offsets (kRestAnimation).
std::unique_ptr<EffectsEngine> make_cpu_effects(const LatticeGeometry& geometry, unsigned enabled,
                                                const std::vector<RestOffsets>& keyframes);
/// `stream`: the CUDA backend's stream (cudaStream_t), so the passes order with its steps.
/// Throws tsf::Error without CUDA.
std::unique_ptr<EffectsEngine> make_cuda_effects(const LatticeGeometry& geometry, unsigned enabled,
                                                 const std::vector<RestOffsets>& keyframes,
                                                 void* stream);

}  // namespace tsf::crms
