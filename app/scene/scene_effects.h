// The parts of a scene's `effects:` section that need the built lattice: a heterogeneity palette
// fed by segment's material weights, and the animation's regions (rest-shape keyframes, material
// tracks, cut triggers). read_scene() reads them strictly; apply_scene_effects() turns regions
// into node lists and rest shapes once the lattice exists (TissueModelOptions::configure_effects).
//
//   effects:
//     palette:                       # entry 0 is the scene's material; more entries by name
//       materials:
//         - {name: bone, youngs_modulus: 2e6, density: 1.9e-3, tear_strain: 0.02}
//         - {name: flaccid, youngs_modulus: 1e3, viscosity: 2}
//       channels: [material, material, bone, bone]   # segment channel → entry (`material` = 0)
//     animation:
//       rest_keyframes:              # rest shape = scale about a point, in a region
//         - {time: 0.2, scale: [1, 1, 1.1], about: [0, 0, 0], region: {box: {min: [..], max:
//         [..]}}}
//       material_tracks:             # blends move to an entry over [start, end]
//         - {start: 0.1, end: 0.3, entry: bone, region: {labels: [mucosa]}}
//       cut_triggers:                # a cut or tear in the region switches it to an entry
//         - {name: artery, entry: flaccid, region: {box: {min: [..], max: [..]}}}
//       exposure_triggers:           # an edit exposing a label (tissue.exposure) does too
//         - {name: vessel-exposed, label: vessel, entry: flaccid, region: {labels: [vessel]}}
// Schema: docs/scenes.md, docs/effects.md.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/crms/calibration.h"
#include "tsf/crms/lattice.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/solver_config.h"

namespace tsf::app {

class YamlField;

/// A tissue label by name (tissue_labels.h, e.g. `mucosa`) or number 0–255.
std::uint8_t parse_label(const YamlField& field);

/// Which lattice nodes a palette/animation item applies to (by rest position or label).
struct SceneRegion {
  enum class Kind { kAll, kBox, kLabels };
  Kind kind = Kind::kAll;
  Vec3d min_mm, max_mm;
  std::vector<std::uint8_t> labels;
  bool contains(const crms::Lattice& lattice, std::int64_t node) const;
};

struct SceneRestKeyframe {
  double time_s = 0;
  Vec3d scale{1, 1, 1};  ///< rest displacement (scale − 1) ⊙ (p − about) inside the region
  Vec3d about_mm{0, 0, 0};
  SceneRegion region;
};

struct SceneMaterialTrack {
  double start_s = 0, end_s = 0;
  int entry = 0;
  SceneRegion region;
};

struct SceneCutTrigger {
  std::string name;
  int entry = 0;
  SceneRegion region;
  /// exposure_triggers: the watched label whose exposure fires it (0: a cut trigger).
  std::uint8_t exposure_label = 0;
  std::string key;  ///< its key path, for messages
};

struct SceneEffects {
  /// Palette entries 1.. (entry 0 is the scene's material) and their names.
  std::vector<crms::Material> palette_materials;
  std::vector<std::string> palette_names;
  bool channels_given = false;
  std::array<int, 4> channels{0, 0, 0, 0};  ///< segment channel → palette entry
  std::vector<SceneRestKeyframe> rest_keyframes;
  std::vector<SceneMaterialTrack> material_tracks;
  std::vector<SceneCutTrigger> cut_triggers;  ///< and exposure triggers (exposure_label ≠ 0)
  bool animation = false;                     ///< the animation section is present and enabled
};

/// Reads effects.palette and effects.animation (absent: nothing). Adds the palette's materials to
/// `solver.materials` and switches solver.effects.animation on when listed. Throws tsf::Error
/// naming the key path.
void read_scene_effects(const YamlField& effects, SceneEffects& out, crms::SolverConfig& solver);

/// Volume lattices: with effects.palette.channels, node blends from segment's material weights
/// (channel c → entry channels[c], density from that entry's material).
void configure_volume_lattice(const SceneEffects& effects, const crms::SolverConfig& solver,
                              crms::VolumeLatticeOptions& options);

/// Fills the animation's node lists and rest shapes for a built lattice into `solver`.
void apply_scene_effects(const SceneEffects& effects, const crms::Lattice& lattice,
                         crms::SolverConfig& solver);

}  // namespace tsf::app
