// The animation timeline of a scene (effects.animation, effects_config.h): rest-shape keyframes
// turned into per-spring rest-length offsets, palette-weight tracks and cut triggers.
//
// The timeline owns the animation's state (keyframe times, the host copy of the rest offsets,
// each track's origin blends and progress, which triggers have fired); the solver owns the
// lattice and the backend and passes them in. Material changes go through `MaterialUpdate`, which
// the solver points at its backend. See docs/effects.md, "The effects" (animation), and
// docs/design.md, "Solver as a driver".
//
//   rest offset of spring n → n+a at a keyframe:  |h_a·e_a + Δr_{n+a} − Δr_n| − h_a
//   between keyframes k and k+1:                   offset = (1 − s)·offset_k + s·offset_{k+1},
//                                                  s = (t − t_k)/(t_{k+1} − t_k)
//   track blend at time t:                         s = min(1, (t − start)/(end − start)):
//                                                  255·s on the target entry, (1 − s)·origin
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "tsf/crms/effects_config.h"
#include "tsf/crms/lattice.h"

namespace tsf::crms {

struct EffectParameters;  // effect_physics.h

/// Rest offsets of one animation keyframe: per axis, #nodes floats (mm), the spring n → n+axis.
using RestOffsets = std::array<std::vector<float>, 3>;

/// Sends new material blends of some nodes to where the kernels read them.
using MaterialUpdate = std::function<void(const std::vector<std::int64_t>& nodes,
                                          const std::vector<MaterialBlend>& blends)>;

class AnimationTimeline {
 public:
  /// No animation: every query is empty and every call does nothing.
  AnimationTimeline() = default;
  /// Validates tracks and triggers against the lattice and the `materials` configured (tsf::Error
  /// naming the field) and turns the rest keyframes into rest offsets. `palette_count`: palette
  /// entries in use (tracks and triggers need at least 2).
  AnimationTimeline(const AnimationConfig& config, const Lattice& lattice, int materials,
                    int palette_count);

  /// Rest offsets per keyframe (with a leading rest-shape keyframe when the first one starts
  /// after 0); empty without rest keyframes.
  const std::vector<RestOffsets>& rest_offsets() const { return rest_offsets_; }
  /// Sets the keyframes around `time_s` and the blend between them in `p` (nothing without rest
  /// keyframes; the first is held before it starts, the last after it ends).
  void set_time(EffectParameters& p, double time_s) const;

  bool has_material_tracks() const { return !tracks_.empty(); }
  /// Moves the blends of the tracks' nodes to where they are at `time_s`, in `lattice` and
  /// through `update`.
  void apply_material_tracks(double time_s, Lattice& lattice, const MaterialUpdate& update);

  bool has_cut_triggers() const { return !trigger_nodes_.empty(); }
  /// Fires the cut triggers that watch one of `edited` (nodes deleted or that lost a spring):
  /// their nodes switch to the trigger's entry, in `lattice` and through `update`. Triggers that
  /// watch an event are left alone.
  void fire_cut_triggers(const std::vector<std::int64_t>& edited, Lattice& lattice,
                         const MaterialUpdate& update);
  /// Fires the triggers that watch `event` (CutTrigger::event). Returns how many fired.
  std::size_t fire_event_triggers(const std::string& event, Lattice& lattice,
                                  const MaterialUpdate& update);
  /// Names of the triggers that have fired, in firing order.
  const std::vector<std::string>& fired_triggers() const { return fired_triggers_; }

  /// `lattice` with every track and trigger node at its target entry (what the stable step must
  /// also hold for: blends in between are no stiffer than both ends).
  static Lattice at_targets(const AnimationConfig& config, const Lattice& lattice);

 private:
  std::vector<MaterialTrack> tracks_;
  std::vector<CutTrigger> triggers_;
  std::vector<double> rest_times_;
  std::vector<RestOffsets> rest_offsets_;
  std::vector<std::vector<MaterialBlend>> track_origin_;
  std::vector<bool> track_done_;
  std::vector<std::vector<std::int64_t>> trigger_nodes_;  // sorted
  std::vector<bool> trigger_fired_;
  void fire(std::size_t trigger, Lattice& lattice, const MaterialUpdate& update);
  std::vector<std::string> fired_triggers_;
};

}  // namespace tsf::crms
