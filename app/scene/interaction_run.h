// Running a scene's interactive part (`tsf simulate` when the scene has tissue, tools or a
// script): build the tissue model (voxels, surface, lattice, coupler), play the script frame by
// frame — trajectories sampled at the frame rate, events as one-off strokes — and write the
// outputs: the rest and final deformed, cut meshes (binary PLY), the saved states (.tsfmesh mesh
// sequence for `tsf export`) and a JSON report.
//
// A scene with several tissue instances (`tissues:`, scene.h) builds one tissue model per
// instance; every tool event and trajectory acts on each of them, each advances with its own
// time step, and each writes its own outputs (a file X.ext becomes X-<instance>.ext) and report
// (the report's `instances` list; the tool force is the sum over instances).
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
  /// Called after every frame's advance, per instance (index into scene.instances), with the time
  /// at its end (tsf run records energy here).
  std::function<void(double time_s, std::size_t instance, const interaction::TissueModel& model)>
      on_frame;
  /// Called once per instance after the script, before the model is released; what it returns
  /// joins that instance's report under `extra_key` (tsf run measures the effects' cost here).
  std::function<nlohmann::json(std::size_t instance, interaction::TissueModel& model)> after_script;
  std::string extra_key = "extra";
};

/// `X.ext` → `X-<instance>.ext` (several instances); unchanged for a single-instance scene.
std::filesystem::path instance_output_path(const std::filesystem::path& path, const Scene& scene,
                                           std::size_t instance);

/// Anchors of the scene on a lattice (box, plane, labels).
void apply_scene_anchors(crms::Lattice& lattice, const Scene& scene);

/// The voxel volume a scene's tissue is made of: the box voxelised at lattice.spacing /
/// tissue.voxels_per_node (density ramp over half a voxel, so the iso-surface is the box), or the
/// density volume file (needs ITK), cropped to lattice.crop and reduced to lattice.labels (other
/// voxels emptied). Several instances: pass scene_for_instance(scene, i).
VoxelVolume scene_tissue_volume(const Scene& scene);

/// The tissue model a scene asks for: surface (iso, merging), lattice (spacing, occupancy, mass
/// floor), solver and materials, time step, coupler, removal by tools, contact passes, and the
/// scene's anchors (from a copy of the scene the options own). One mapping for `tsf simulate`,
/// `tsf view` and `tsf haptics`.
interaction::TissueModelOptions tissue_model_options(const Scene& scene);

/// Plays the script on every instance and writes the outputs; returns the report (also written
/// when asked): one instance's report at the top level for a single-instance scene; for several,
/// `instances` (one report each) with the scene-wide frames, timings and tool force.
/// Throws tsf::Error on bad input or an unstable simulation (after writing what it has).
nlohmann::json run_interaction_scene(const Scene& scene, const InteractionRunOptions& options);

}  // namespace tsf::app
