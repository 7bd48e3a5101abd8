// The tsf scene model and its strict YAML reader. A scene says what tissue to build, how to
// simulate it, what tools do to it and what is written. scene_session.h turns it into running
// models, the same way for every command (docs/design.md, "From a scene file to a kernel").
//
// Every key is checked: an unknown key, a wrong type or an out-of-range value is an error naming
// the file and the key path (`beam.yaml: lattice.spacing: expected a number > 0, got -1`).
// Schema and examples: docs/scenes.md (tissue instances, pipeline), docs/crms.md ("Scenes"),
// docs/deform-cut.md (tissue, tools, script, outputs), scenes/*.yaml.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "run/run_spec.h"
#include "scene/scene_effects.h"
#include "tsf/common/vec3.h"
#include "tsf/coupler/couple_vertex.h"
#include "tsf/crms/solver_config.h"
#include "tsf/interaction/tool.h"
#include "tsf/interaction/trajectory.h"
#include "tsf/volume/tool_shapes.h"

namespace tsf::app {

/// A position given relative to the patient's anatomy (`{landmark: nose-tip, offset_mm: {anterior:
/// 5, left: 2}}`), found by the segmentation of `tsf run` and resolved into tissue space right
/// after it (anatomy_placement.h, docs/patients.md). `landmark` empty: an absolute position.
struct AnatomyPosition {
  std::string landmark;  ///< a landmark or a region's centroid (anatomy_placement.h lists them)
  /// The offset in patient directions, mm: +x left, +y anterior, +z superior (right, posterior
  /// and inferior are negative).
  Vec3d offset_mm{0, 0, 0};
  std::string key;  ///< the key path, for messages
  bool given() const { return !landmark.empty(); }
  /// `rotation: {axis: anterior, angle_deg: 90}` with the pose: the axis is a patient direction
  /// (right-hand rule in the patient frame), turned into tissue space with the detected frame.
  /// Empty: the pose's rotation is given in tissue space ([x, y, z] or a quaternion).
  std::string rotation_axis;
  double rotation_angle_rad = 0.0;
  std::string rotation_key;
  bool rotation_given() const { return !rotation_axis.empty(); }
};

/// `lattice.paint[i]`: sets the tissue label of the voxels holding tissue inside a shape (a vessel
/// or nerve the CT does not show, or tissue classes in a box scene); densities stay.
struct ScenePaint {
  std::uint8_t label = 0;
  bool capsule = false;
  Vec3d min_mm, max_mm;    ///< box (tissue space)
  Vec3d from_mm, to_mm;    ///< capsule axis (tissue space)
  double radius_mm = 0.0;  ///< capsule
};

struct SceneLattice {
  enum class Source { kBox, kVolume };
  Source source = Source::kBox;
  // box
  Vec3d size_mm{10, 10, 10};
  double spacing_mm = 1.0;
  Vec3d min_corner_mm{0, 0, 0};
  // volume (PREFIX-density.nrrd written by tsf segment / import)
  std::filesystem::path volume;
  int node_spacing_voxels = 2;
  /// `node_spacing_mm`: the node spacing in millimetres, whatever the CT's voxel size; > 0
  /// replaces node_spacing_voxels by the nearest whole number of voxels (at least 1) once the
  /// segmented volume's spacing is known (lattice_node_spacing_voxels, scene_session.h).
  double node_spacing_mm = 0.0;
  double occupancy_threshold = 0.125;
  double mass_floor = 0.5;
  /// volume: region of interest, tissue-space mm (the voxels whose centres lie in the box).
  bool cropped = false;
  Vec3d crop_min_mm, crop_max_mm;
  /// `crop: {region: nasal-cavity, include: [nose-tip], margin_mm: 10}`: the region's box, grown to
  /// hold the included landmarks and then by the margin, set in
  /// crop_min_mm/crop_max_mm (and `cropped`) after segmentation. Empty: an absolute crop or none.
  std::string crop_region;
  std::vector<std::string> crop_include;  ///< landmarks the box is grown to hold (`include:`)
  double crop_margin_mm = 0.0;
  /// `crop: {center: {landmark: nose-tip, offset_mm: {...}}, size_mm: [lr, ap, si]}`: a box of
  /// the given extent along the patient's left-right, anterior-posterior and superior-inferior
  /// directions around a point placed by anatomy (its tissue-space bounding box is the crop).
  AnatomyPosition crop_center;
  Vec3d crop_size_mm{0, 0, 0};
  std::string crop_key;
  bool crop_by_anatomy() const { return !crop_region.empty() || crop_center.given(); }
  /// Set by the placement of a center + size_mm crop: the patient-aligned box in tissue space
  /// (centre, unit axes, half extents). When it is tilted against the voxel grid (an oblique CT,
  /// a turned head) the voxels of crop_min/max_mm outside it are emptied, so the same anatomy is
  /// simulated whatever the storage grid.
  bool crop_oriented = false;
  Vec3d crop_box_centre;
  std::array<Vec3d, 3> crop_box_axes;
  Vec3d crop_box_half;
  /// volume: the segment labels this lattice takes (tissue_labels.h); voxels of other labels are
  /// emptied (density 0, label outside) before the surface and lattice are built. Empty = all.
  std::vector<std::uint8_t> labels;
  /// Labels painted into the voxels, in order, after the crop and the label selection.
  std::vector<ScenePaint> paint;
};

/// The interactive tissue (R1 voxels, R2 surface, coupler) that tools edit (`tissue:`).
struct SceneTissue {
  int voxels_per_node = 2;  ///< box lattices: voxels per node spacing (the voxel size)
  double iso = 0.5;
  double merge_epsilon = 0.1;
  coupler::CouplerMode coupler = coupler::CouplerMode::kTrilinear;
  double deletion_threshold = 0.125;
  double min_blade_thickness_voxels = 2.0;
  double removal_strength = 1.0;
  double falloff_mm = -1.0;  ///< < 0: one voxel
  int contact_passes = 2;
  /// `removal.rates`: per tissue label the ablation and the cut rate, [0, 1] (a label not named:
  /// 1); by value, or `rates: library` (the material library's removal_rates).
  std::array<float, 256> ablation_rates = uniform_rates();
  std::array<float, 256> cut_rates = uniform_rates();
  std::string rates_source;  ///< "" (every label 1), "scene", or the library file
  /// `removal.feather_force_mn`: force-dependent ablation (TissueModelOptions::feather_force_un);
  /// 0: off.
  double feather_force_mn = 0.0;
  /// `exposure`: events when an edit removes tissue within distance_mm of a watched label
  /// (interaction/exposure.h); 0: off. Labels empty: every overlay label.
  double exposure_distance_mm = 0.0;
  std::vector<std::uint8_t> exposure_labels;

  static std::array<float, 256> uniform_rates() {
    std::array<float, 256> r;
    r.fill(1.0f);
    return r;
  }
};

struct SceneTool {
  std::string name;
  interaction::Tool tool;  ///< a mesh tool holds its surface and grid (tool.mesh)
};

/// A tool's keyframed motion (interaction/trajectory.h).
struct SceneTrajectory {
  std::string tool;
  std::vector<interaction::Keyframe> keyframes;
  /// Per keyframe: its position relative to the anatomy (not given: absolute).
  std::vector<AnatomyPosition> anatomy;
};

/// A one-off stroke at `time_s`: the tool moves from `from` to `to` in `mode`, then lifts.
struct SceneEvent {
  double time_s = 0;
  std::string tool;
  interaction::ToolMode mode = interaction::ToolMode::kCut;
  ToolPose from, to;
  AnatomyPosition from_anatomy, to_anatomy;  ///< positions relative to the anatomy, if given
};

struct SceneScript {
  double frame_rate_hz = 60.0;  ///< display frames per second: one advance() per frame
  double duration_s = -1.0;     ///< < 0: 0.1 s after the last keyframe or event
  std::vector<SceneTrajectory> trajectories;
  std::vector<SceneEvent> events;

  /// Seconds the script plays: `duration`, else 0.1 s after its last keyframe or event.
  double played_s() const {
    if (duration_s >= 0) return duration_s;
    double end = 0.0;
    for (const SceneTrajectory& t : trajectories)
      if (!t.keyframes.empty()) end = std::max(end, t.keyframes.back().time_s);
    for (const SceneEvent& e : events) end = std::max(end, e.time_s);
    return end + 0.1;
  }
};

/// Files an interaction run writes: names inside the command's output folder (`--out`; relative
/// paths only, no `..`: a scene never writes outside the folder its command was given).
struct SceneOutputs {
  std::filesystem::path mesh;       ///< final deformed, cut surface (binary PLY)
  std::filesystem::path rest_mesh;  ///< the surface before the script (binary PLY)
  std::filesystem::path report;     ///< JSON report
  /// Saved states (.tsfmesh mesh sequence, tsf/io/mesh_sequence.h; `tsf export` reads it): the
  /// rest surface, then the deformed, cut surface every `states_every` frames and at the end.
  std::filesystem::path states;
  std::int64_t states_every = 10;  ///< frames between saved states
};

struct SceneAnchor {
  enum class Kind { kBox, kPlane, kLabels };
  Kind kind = Kind::kBox;
  Vec3d min_mm, max_mm;           ///< box
  Vec3d point_mm, normal;         ///< plane: nodes with (p − point)·normal ≤ 0 are anchored
  AnatomyPosition point_anatomy;  ///< plane: the point relative to the anatomy, if given
  std::string normal_direction;   ///< plane: a patient direction (`anterior`, …) for the normal
  std::string normal_key;
  std::vector<std::uint8_t> labels;
};

/// A constant force on every alive node whose rest position lies in a box.
struct SceneLoad {
  Vec3d min_mm, max_mm;
  Vec3d force_un{0, 0, 0};  ///< µN per node
};

/// Start from a scaled copy of the rest shape: p0 = about + scale ⊙ (p − about).
struct SceneInitialState {
  bool scaled = false;
  Vec3d scale{1, 1, 1};
  Vec3d about_mm{0, 0, 0};
};

/// How an instance's time is integrated (`solver.integrator`, `solver.dt`, … scene-wide, or
/// `tissues[i].solver` per instance): a stiff instance (bone) may step implicitly at a frame-sized
/// dt while soft tissue steps explicitly.
struct SceneIntegration {
  crms::Integrator integrator = crms::Integrator::kSymplecticEuler;
  double dt_s = 0.0;  ///< 0 = automatic: dt_safety × the stable estimate (effects included)
  double dt_safety = 0.9;
  int newton_iterations = 8;
  double newton_tolerance = 1e-7;
};

/// One tissue instance: its own lattice (source, spacing, crop, labels), material, anchors,
/// tissue/coupler options, effects and integration. Tools, the script, loads and the initial
/// state act on every instance; each has its own surface, lattice, solver and outputs.
struct SceneInstance {
  std::string name;  ///< unique in the scene; names the instance's output files
  SceneLattice lattice;
  crms::Material material;
  std::string material_id;  ///< library id when the material came from the library, else empty
  std::vector<SceneAnchor> anchors;
  SceneTissue tissue;
  crms::EffectsConfig effects;
  SceneIntegration integration;
  /// `contact: {pushed_by: [bone], grid_mm: 0.5}`: the instances whose surfaces push this one, one
  /// way (interaction/body_field.h), and the spacing of their distance grids (0: each pusher's
  /// finest voxel spacing).
  std::vector<std::string> pushed_by;
  double contact_grid_mm = 0.0;
};

/// A scene: settings every instance shares, and the list of instances. A one-tissue scene (the
/// top-level `lattice`, `material`, `anchors`, `tissue` form) is one instance named after the
/// scene; a `tissues:` scene lists them. Nothing is stored twice: what an instance says is in its
/// SceneInstance only, what the scene says once is here only (docs/design.md, "The scene model").
struct Scene {
  std::filesystem::path file;
  std::string name;
  /// Scene-wide solver settings (backend, angular form and reactions, gravity, stability,
  /// CUDA graph size) and the palette's entries 1.. (`effects.palette`). Entry 0 of `materials`,
  /// `effects` and the integrator are each instance's: instance_solver_config() (scene_session.h)
  /// completes a copy per instance.
  crms::SolverConfig solver;
  /// effects.palette and effects.animation regions (scene_effects.h): applied to each lattice.
  SceneEffects effect_regions;
  /// Lattice-only scenes (no tissue, tools or script): steps to run and the energy sampling.
  std::int64_t steps = 1000;
  std::int64_t report_every = 100;
  bool steps_given = false;  ///< `solver.steps` or `solver.report_every` was written
  std::vector<SceneLoad> loads;
  SceneInitialState initial;
  std::vector<SceneTool> tools;
  SceneScript script;
  bool script_given = false;  ///< the scene has a `script:` section
  SceneOutputs outputs;
  bool outputs_given = false;  ///< the scene has an `outputs:` section
  RunSpec pipeline;            ///< `pipeline:` (tsf run: import, segment, library material)
  std::vector<SceneInstance> instances;  ///< at least one
  bool multi_instance = false;           ///< the scene used the `tissues:` list
  /// The scene is played interactively (voxels, surface, lattice, coupler, tools, script):
  /// it has a `tissue`, `tools`, `script` or `tissues` section. Otherwise only its lattice steps.
  bool interactive = false;
  /// The first key that places something relative to the anatomy (empty: none); such a scene
  /// needs a pipeline section (the anatomy is found by its segmentation) or a volume written by
  /// tsf segment (its PREFIX-report.json holds the anatomy).
  std::string anatomy_key;
  /// What placing by anatomy warned about (landmarks of low confidence, the finder's own
  /// warnings) when the scene was placed as it was read (a scene on a tsf segment output; tsf run
  /// places after its segmentation and keeps its warnings in the run report).
  std::vector<std::string> placement_warnings;

  const SceneTool* find_tool(const std::string& tool_name) const {
    for (const SceneTool& t : tools)
      if (t.name == tool_name) return &t;
    return nullptr;
  }
  /// "scene.yaml: " or "scene.yaml: tissues[1] (bone): " — the prefix of an instance's errors.
  std::string instance_prefix(std::size_t index) const;
};

/// Reads and validates a scene; relative input paths inside it are resolved against its folder.
/// Throws tsf::Error "FILE: key.path: what is wrong".
Scene read_scene(const std::filesystem::path& file);

}  // namespace tsf::app
