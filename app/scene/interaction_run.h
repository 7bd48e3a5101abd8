// Running a scene's interactive part (`tsf simulate` when the scene has tissue, tools or a
// script): build the tissue model (voxels, surface, lattice, coupler), play the script frame by
// frame — trajectories sampled at the frame rate, events as one-off strokes — and write the
// outputs: the rest and final deformed, cut meshes (binary PLY), the saved states (.tsfmesh mesh
// sequence for `tsf export`) and a JSON report.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "scene/scene.h"
#include "tsf/crms/lattice.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::app {

struct InteractionRunOptions {
  std::optional<double> duration_s;  ///< overrides script.duration
  std::filesystem::path report;      ///< overrides outputs.report
  std::filesystem::path mesh;        ///< overrides outputs.mesh
  std::filesystem::path states;      ///< overrides outputs.states
  bool quiet = false;
  /// Called after every frame's advance with the time at its end (tsf run records energy here).
  std::function<void(double time_s, const interaction::TissueModel& model)> on_frame;
};

/// Anchors of the scene on a lattice (box, plane, labels).
void apply_scene_anchors(crms::Lattice& lattice, const Scene& scene);

/// The voxel volume a scene's tissue is made of: the box voxelised at lattice.spacing /
/// tissue.voxels_per_node (density ramp over half a voxel, so the iso-surface is the box), or the
/// density volume file (needs ITK), cropped to lattice.crop.
VoxelVolume scene_tissue_volume(const Scene& scene);

/// The tissue model a scene asks for: surface (iso, merging), lattice (spacing, occupancy, mass
/// floor), solver and materials, time step, coupler, removal by tools, contact passes, and the
/// scene's anchors (from a copy of the scene the options own). One mapping for `tsf simulate`,
/// `tsf view` and `tsf haptics`.
interaction::TissueModelOptions tissue_model_options(const Scene& scene);

/// Plays the script and writes the outputs; returns the report (also written when asked).
/// Throws tsf::Error on bad input or an unstable simulation (after writing what it has).
nlohmann::json run_interaction_scene(const Scene& scene, const InteractionRunOptions& options);

}  // namespace tsf::app
