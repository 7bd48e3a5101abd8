// Exposure of overlay structures (tissue_labels.h: vessels, nerves, labels 64..127) by an edit
// (docs/deform-cut.md, "Exposure events"; thesis §10.1.4, volumetric overlays).
//
// An edit removes tissue where it takes a voxel from solid (density ≥ iso) to below the iso-level:
// the surface passed through it. Such a voxel within `distance_mm` of a voxel of a watched label
// (centre to centre, in millimetres of the voxel grid) exposes that label; an overlay voxel that
// loses density itself counts at distance 0 (the tool reached the structure). For each watched
// label the edit reports its smallest distance and where (the label's voxel nearest the removed
// tissue, tissue space). Costs one pass over the edit's box grown by the distance when no watched
// label is near, which is the common case; nothing when the option is off.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/interaction/lattice_topology_edit.h"
#include "tsf/volume/voxel_box.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::interaction {

struct ExposureOptions {
  double distance_mm = 0.0;          ///< 0: off; else (0, 100]
  std::vector<std::uint8_t> labels;  ///< watched labels; empty: every overlay label (64..127)
  bool enabled() const { return distance_mm > 0.0; }
  /// Per label value: watched.
  std::array<bool, 256> watched() const;
};

/// One watched label the edit came near.
struct ExposureHit {
  std::uint8_t label = 0;
  double distance_mm = 0.0;  ///< smallest distance from removed tissue to the label
  Vec3d label_mm{0, 0, 0};   ///< the label's voxel nearest the removed tissue (tissue space)
};

/// An exposure event of the tissue model: an edit brought removed tissue nearer a watched label
/// than any edit before it (the first within the distance, then each closer approach).
struct ExposureEvent {
  double time_s = 0.0;  ///< the model's simulated time at the edit
  ExposureHit hit;
  bool first = false;  ///< the label's first event (its exposure triggers fire)
};

/// The animation event an exposure of `label` raises (crms::Solver::raise_event): "exposure:64".
std::string exposure_event_name(std::uint8_t label);

/// One line for reports and the viewer: "vessel exposed: wand removed tissue 0.80 mm from it at
/// t = 0.0123 s", or "vessel reached: wand removed vessel tissue at t = …" at distance 0.
std::string describe_exposure(const ExposureHit& hit, const std::string& tool, double time_s);

/// The watched labels within `options.distance_mm` of the tissue an edit removed (`volume` after
/// the edit, `before` its densities over at least `changed`), one hit per label, ascending label.
std::vector<ExposureHit> find_exposures(const VoxelVolume& volume, const DensitySnapshot& before,
                                        const VoxelBox& changed, float iso,
                                        const ExposureOptions& options);

}  // namespace tsf::interaction
