// Playing a scene's script on its tissue (`tsf simulate` on an interactive scene, and the
// interaction stage of `tsf run`): every instance is built by scene_session.h, the script plays
// frame by frame — trajectories sampled at the frame rate, events as one-off strokes — on every
// instance, each advancing with its own time step, and the outputs are written: the rest and
// final deformed, cut meshes (binary PLY), the saved states (.tsfmesh for `tsf export`) and a
// JSON report. The run returns typed results (InteractionResult); JSON is made only at the edge
// (interaction_report_json).
//
// With several instances each writes its own files (X.ext becomes X-<instance>.ext) and the
// report lists them under `instances`; the tool force is the sum over instances.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "scene/scene.h"
#include "scene/scene_outputs.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/imt/surface_mesh.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::app {

struct EditRecord {
  double time_s = 0;
  std::string tool;
  interaction::EditReport report;
};

struct InteractionRunOptions {
  std::optional<double> duration_s;  ///< overrides script.duration
  InteractionOutputs outputs;        ///< with several instances each path gets the instance's name
  bool quiet = false;
  /// Called after every frame's advance, per instance (index into scene.instances), with the time
  /// at its end (tsf run records energy here).
  std::function<void(double time_s, std::size_t instance, const interaction::TissueModel& model)>
      on_frame;
  /// Called once per instance after the script (not after an instability or an interrupt),
  /// before the model is released; what it returns joins that instance's report under
  /// `extra_key` (tsf run measures the effects' cost here).
  std::function<nlohmann::json(std::size_t instance, interaction::TissueModel& model)> after_script;
  std::string extra_key = "extra";
  /// Called before every frame's advance, per instance, after the script moved its tools, with
  /// the frame's start time and the instance's patient frame (`tsf link`: the tools a live link
  /// drives). The edits it returns join the instance's report.
  std::function<std::vector<EditRecord>(double time_s, std::size_t instance,
                                        interaction::TissueModel& model,
                                        const VolumeGeometry& patient_frame)>
      before_advance;
  /// A progress bar on a terminal (a live session, which ends when stopped, shows none).
  bool progress = true;
};

/// `X.ext` → `X-<instance>.ext` (several instances); unchanged for a single-instance scene.
std::filesystem::path instance_output_path(const std::filesystem::path& path, const Scene& scene,
                                           std::size_t instance);

/// One tool's share of a frame's contact (several tools press at once).
struct ToolShare {
  std::string tool;
  Vec3d force_un{0, 0, 0};
  std::int64_t nodes_held = 0;
};

/// An exposure event (interaction/exposure.h) with the tool whose edit raised it.
struct ExposureRecord {
  double time_s = 0;
  std::string tool;
  interaction::ExposureEvent event;
};

/// What tearing did during one frame (TissueModel::advance), at the frame's end.
struct TearRecord {
  double time_s = 0;
  interaction::TearReport report;
};

struct ContactSample {
  double time_s = 0;
  Vec3d force_un, torque_un_mm;
  std::int64_t nodes_held = 0;
  std::vector<ToolShare> tools;  ///< each pressing tool's share (empty: none pressed)
};

/// What one instance did during the script.
struct InstanceResult {
  std::size_t index = 0;
  std::string name;
  std::string backend, integrator;
  std::vector<std::string> effects_active, triggers_fired, kernel_features;
  double bytes_per_node = 0;
  VolumeGeometry volume;         ///< of the voxels the instance was built from (tissue mm)
  VolumeGeometry patient_frame;  ///< tissue mm → patient (LPS) mm (the uncropped volume's)
  Int3 lattice_dims{0, 0, 0};
  Vec3d lattice_spacing_mm;
  std::int64_t alive_start = 0, alive_end = 0, fixed_nodes = 0;
  std::size_t components_start = 0, components_end = 0, free_components_end = 0;
  std::vector<std::int64_t> component_sizes_end;
  imt::MeshTopology topology_start, topology_end;
  imt::SurfaceMesh final_mesh;  ///< the deformed, cut surface at the end (patient mm)
  double dt_s = 0;
  std::int64_t steps = 0;
  interaction::InteractionTotals totals;
  std::vector<EditRecord> edits;
  std::vector<TearRecord> tears;
  std::vector<ExposureRecord> exposures;
  std::vector<ContactSample> contact;
  /// What the pushing instances exert on this one (tissues[i].contact), per frame.
  std::vector<ContactSample> body_contact;
  std::size_t nodes_overlapping_pushers_at_rest = 0;
  std::vector<double> edit_latencies_us;
  double max_tool_force_un = 0;
  double setup_s = 0, stepping_s = 0, contacts_s = 0, coupling_s = 0;
  collision::ContactForce::Phases contact_phases_us;  ///< contacts_s by step, µs
  InteractionOutputs outputs;                         ///< this instance's files, as written
  std::size_t states_saved = 0;
  std::optional<std::string> instability;
  crms::StabilitySummary stability;  ///< the instance's verdict (TissueModel::stability)
  nlohmann::json session;            ///< TissueInstance::summary
  nlohmann::json extra;              ///< after_script's result
};

struct InteractionResult {
  std::vector<InstanceResult> instances;
  double frame_rate_hz = 0;
  std::int64_t frames = 0;             ///< frames played
  std::int64_t frames_planned = 0;     ///< frames the script asked for
  double script_s = 0;                 ///< wall time of the script
  std::vector<ContactSample> contact;  ///< the tool's force: the sum over instances
  double max_tool_force_un = 0;
  std::optional<std::string> instability;  ///< "instance: what" of the first one
  bool interrupted = false;                ///< SIGINT/SIGTERM stopped the script
  std::string extra_key = "extra";         ///< InteractionRunOptions::extra_key
  /// The instance with the worst stability verdict (unstable > settling > stable; the first of
  /// equals), null when there is none.
  const InstanceResult* least_stable() const;
};

/// Builds every instance, plays the script and writes the outputs (the report too, when asked).
/// An instability or an interrupt stops the script; the result says so and the outputs hold what
/// was reached. Throws tsf::Error on bad input.
InteractionResult run_interaction_scene(const Scene& scene, const InteractionRunOptions& options);

/// The report: one instance's at the top level for a single-instance scene; for several,
/// `instances` (one report each) with the scene-wide frames, timings and tool force.
nlohmann::json interaction_report_json(const Scene& scene, const InteractionResult& result);

/// One instance's report (interaction_report_json's entries).
nlohmann::json instance_report_json(const Scene& scene, const InteractionResult& result,
                                    const InstanceResult& instance);

}  // namespace tsf::app
