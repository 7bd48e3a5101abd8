// `tsf run SCENE`: the main job. import → segment → surface → lattice → scripted interaction →
// outputs, each stage timed, then a report (Markdown with PNG plots, and JSON) of what happened
// and what it cost: time per stage, simulation rate, energy over time, tool force, the kernel
// features (effects) that were active.
//
// The scene is an interaction scene (app/scene/scene.h, tools and a script) plus an optional
// `pipeline:` section (run_spec.h) naming the CT, the segmentation preset, the library material
// and the outputs. Without `pipeline:` the scene's own lattice source is used (box or a
// segmented volume file).
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace tsf::app {

struct RunOptions {
  std::filesystem::path scene;          ///< scene file
  std::filesystem::path output_folder;  ///< overrides pipeline.outputs.folder
  std::optional<double> duration_s;     ///< overrides script.duration (short CI runs)
  std::optional<double> voxel_mm;       ///< overrides pipeline.segmentation.voxel_mm
  /// Another patient's CT for this run (`--ct`): replaces pipeline.source.ct and its series
  /// (pipeline.source.series is dropped unless `series` is given too).
  std::filesystem::path ct;
  std::string series;   ///< `--series UID`: replaces pipeline.source.series
  std::string backend;  ///< cpu | cuda | auto (empty: the scene's)
  /// `--states-every N`: save a state every N frames (outputs.states, else states.tsfmesh); the
  /// export stage turns the saved states into an animated GLB.
  std::optional<std::int64_t> states_every;
  bool force = false;  ///< replace an earlier run's files in the output folder
  bool quiet = false;
};

/// Runs the pipeline and writes everything under the output folder; returns the JSON report (also
/// written, with run-report.md). Cheap checks (scene keys, backend, the CT's series and geometry
/// against every instance's crop and the tools' paths, output folder) come before the long
/// stages. Throws tsf::Error naming the stage, file or key on bad input or failure; an
/// unstable or interrupted run throws after its report is written.
nlohmann::json run_pipeline(const RunOptions& options);

/// The bundled default scene: scenes/sinus.yaml (repo_paths.h).
std::filesystem::path default_scene_path();

}  // namespace tsf::app
