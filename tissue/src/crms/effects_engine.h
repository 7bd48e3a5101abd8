// The passes of the optional effects (effect_physics.h) where the backend keeps its arrays: host
// memory for the CPU backend, device memory on the CPU backend's CUDA twin. Private to
// tissue/src/crms: the solver creates an engine only when the scene enables an effect, and the
// engine allocates only the arrays of the enabled effects.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "tsf/crms/effect_physics.h"
#include "tsf/crms/effects_config.h"
#include "tsf/crms/lattice_geometry.h"
#include "tsf/crms/node_state_view.h"

namespace tsf::crms {

class EffectsEngine {
 public:
  virtual ~EffectsEngine() = default;
  /// Passes 1–3 on the state the next core step reads (its velocities are kicked in place).
  virtual void before_step(const LatticeView& lattice, const StateView& state,
                           const EffectParameters& p) = 0;
  /// Passes 5–6 on the state the core step wrote (tearing clears link bits in `lattice.flags`).
  virtual void after_step(const LatticeView& lattice, const StateView& state,
                          const EffectParameters& p) = 0;
  /// Copies the effect arrays to the host (waits for queued work).
  virtual EffectsState read() const = 0;
  /// Copies the lattice flags (#nodes) from where the backend keeps them.
  virtual std::vector<std::uint8_t> read_flags(const LatticeView& lattice) const = 0;
  /// Bytes kept per node by the enabled effects.
  virtual double bytes_per_node() const = 0;
};

/// Rest offsets of one animation keyframe: per axis, #nodes floats (mm), the spring n → n+axis.
using RestOffsets = std::array<std::vector<float>, 3>;

/// `enabled`: effect_bits; `keyframes`: the animation's rest offsets (kRestAnimation).
std::unique_ptr<EffectsEngine> make_cpu_effects(const LatticeGeometry& geometry, unsigned enabled,
                                                const std::vector<RestOffsets>& keyframes);
/// `stream`: the CUDA backend's stream (cudaStream_t), so the passes order with its steps.
/// Throws tsf::Error without CUDA.
std::unique_ptr<EffectsEngine> make_cuda_effects(const LatticeGeometry& geometry, unsigned enabled,
                                                 const std::vector<RestOffsets>& keyframes,
                                                 void* stream);

}  // namespace tsf::crms
