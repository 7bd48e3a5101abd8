// From a scene to running models: the one place where a scene (scene.h) becomes lattices,
// solvers and tissue models, for every command (`tsf simulate`, `tsf run`, `tsf view`,
// `tsf haptics`). A command never maps scene keys itself: it asks this file, so a key means the
// same thing everywhere, and a key a command cannot honour is refused here, by name
// (check_scene_for_command). docs/design.md, "From a scene file to a kernel", walks a key
// through it.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "scene/scene.h"
#include "tsf/crms/lattice.h"
#include "tsf/crms/solver.h"
#include "tsf/crms/stability_monitor.h"
#include "tsf/crms/time_step_choice.h"
#include "tsf/interaction/body_field.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::app {

/// The commands that run a scene.
enum class SceneCommand { kSimulate, kRun, kView, kHaptics, kLink };
const char* to_string(SceneCommand command);

/// Throws tsf::Error "FILE: key: tsf <command> …" for the first key of `scene` that `command`
/// cannot honour (what it does instead and which command does honour it). The table of keys ×
/// commands is in docs/scenes.md ("Which command honours which key").
void check_scene_for_command(const Scene& scene, SceneCommand command);

/// `cpu`, `cuda` or `auto`; throws naming `option` otherwise.
crms::Backend parse_backend(const std::string& text, const std::string& option = "--backend");

/// Replaces the scene's backend (command line) and re-validates every instance's configuration.
void override_backend(Scene& scene, const std::string& text);

/// The solver configuration of instance `index`: the scene-wide settings with the instance's
/// material (palette entry 0), effects and integrator.
crms::SolverConfig instance_solver_config(const Scene& scene, std::size_t index);

/// The voxel volume instance `index` is made of: the box voxelised at the lattice spacing /
/// tissue.voxels_per_node (so that the lattice built from it has the box lattice's nodes plus an
/// empty rim), or the density volume file, cropped to lattice.crop and reduced to lattice.labels.
/// `patient_frame` (optional) receives the geometry of the whole volume before the crop: the frame
/// that maps the tissue's coordinates to the patient (a crop keeps the tissue coordinates).
VoxelVolume instance_tissue_volume(const Scene& scene, std::size_t index,
                                   VolumeGeometry* patient_frame = nullptr);

/// The tissue model options of instance `index`: surface, lattice, solver, time step, coupler,
/// removal, contacts, anchors and effect regions (the options own what their callbacks need).
/// The lattice's node spacing in voxels of `volume`: lattice.node_spacing_mm / the finest voxel
/// spacing, rounded (at least 1), when the scene gives millimetres; else node_spacing_voxels (or
/// tissue.voxels_per_node for a box).
int lattice_node_spacing_voxels(const SceneInstance& inst, const VolumeGeometry& volume);
interaction::TissueModelOptions instance_model_options(const Scene& scene, std::size_t index,
                                                       const VolumeGeometry& volume);

/// Applies the scene's loads (a constant force per node in a box) and initial state (a scaled
/// copy of the rest shape) to a solver. Returns the number of loaded nodes.
std::size_t apply_loads_and_initial_state(const Scene& scene, crms::Solver& solver);

/// The Poisson ratio instance `index` runs with (every command's report, `poisson_ratio`): the
/// material's ν, what it runs with under solver.poisson_ratio_cap, the cap, λ of the volumetric
/// term (docs/effects.md), and per palette entry beyond the first the same.
nlohmann::json poisson_json(const Scene& scene, std::size_t index, const crms::Solver& solver);
/// One line for the terminal summaries from poisson_json: "Poisson ratio: ν = 0.45 (material
/// 0.49, capped by solver.poisson_ratio_cap), volumetric term λ = 120 kPa" or "… the springs
/// alone".
std::string poisson_line(const nlohmann::json& poisson);

/// One interactive instance, built: the tissue model with loads and initial state applied.
struct TissueInstance {
  std::size_t index = 0;  ///< into scene.instances
  std::string name;
  std::unique_ptr<interaction::TissueModel> model;
  VolumeGeometry volume_geometry;  ///< of the voxels the model was built from (tissue mm)
  VolumeGeometry patient_frame;    ///< the uncropped volume's: tissue mm → patient (LPS) mm
  double setup_s = 0;
  /// What the scene made of this instance, measured on the built model (every command writes it
  /// into its report as `session`): nodes alive, anchored and loaded, the elastic energy of the
  /// initial state, time step, integrator, backend, gravity and the effects that run.
  nlohmann::json summary;
};

/// Builds instance `index` of an interactive scene. Errors name the instance.
TissueInstance build_tissue_instance(const Scene& scene, std::size_t index);

/// The tool slot (hand) of scene tool `name` in every TissueModel: its index in scene.tools, so
/// tools act at once, each in its own hand (TissueModel::apply_tool(slot, …)). Throws for an
/// unknown name or more tools than TissueModel::kMaxToolSlots.
int scene_tool_slot(const Scene& scene, const std::string& name);

/// Which instances push which (`tissues[i].contact.pushed_by`), built on the instances' models.
struct InstanceContacts {
  struct Pusher {
    std::size_t instance = 0;  ///< the pushing instance
    std::shared_ptr<interaction::BodyField> field;
  };
  /// Per instance, the bodies pushing it (their fields are set as its pushers).
  std::vector<std::vector<Pusher>> pushers;
  /// The order to advance the instances in: every pusher before what it pushes.
  std::vector<std::size_t> order;
};
/// The advance order of `scene`'s instances (pushers first); throws naming the instances when
/// pushing goes round in a circle.
std::vector<std::size_t> instance_push_order(const Scene& scene);
/// Builds the pushing bodies' distance grids on the built models (one per instance, in scene
/// order), records each pushed lattice's rest overlap and sets them as its pushers.
InstanceContacts build_instance_contacts(const Scene& scene,
                                         const std::vector<interaction::TissueModel*>& models);

/// A lattice-only scene (no tissue, tools or script), built: the lattice with its anchors, a
/// solver with the effects' regions, loads and initial state, and the time step.
struct LatticeRun {
  std::unique_ptr<crms::Solver> solver;
  std::int64_t fixed_nodes = 0;
  double dt_s = 0;
  crms::TimeStepChoice dt_choice;
  double setup_s = 0;
};
LatticeRun build_lattice_run(const Scene& scene);

/// How the time step was chosen, as the `time_step` section of the session summary.
nlohmann::json time_step_json(const crms::TimeStepChoice& choice);
/// The stability verdict as every report's `stability` section (headline first).
nlohmann::json stability_json(const crms::StabilitySummary& summary);
/// Throws tsf::Error "unstable: …" for an unstable verdict the scene does not allow
/// (stability.allow_unstable): the commands exit non-zero after writing their reports.
void require_stable_enough(const crms::StabilitySummary& summary, const std::string& who);

}  // namespace tsf::app
