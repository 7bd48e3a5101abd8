// The interactive tissue: the four representations of docs/design.md "The pipeline" as one object,
// and the tools that press, ablate and cut it.
//
//   R1 VoxelVolume      what edits change (rest space)
//   R2 ImtSurface       its render surface, re-meshed where R1 changed (rest space)
//   R3 crms::Solver     the mass-spring lattice, one node per k³ voxels
//   Coupler             R2's vertices through R3's deformation: the deformed render buffer
//
//   TissueModel model(std::move(volume), options);
//   model.apply_tool(tool, pose, ToolMode::kPress);   // pose in the deformed world
//   model.advance(1.0 / 60);                          // one display frame of simulation
//   model.coupler().positions();                      // deformed vertices, by IMT slot
//   model.contact().force_un;                         // what the tool feels
//
// An edit (ablate, cut) runs through every layer at once: the tool pose is mapped into rest
// space through the lattice (rest_space_map.h); the voxels change (volume_edits.h,
// swept_ablation.h); the IMT surface re-meshes the changed cubes; lattice nodes whose cells fell
// below the deletion threshold are deleted and springs whose voxels were cut through are broken
// (lattice_topology_edit.h); the coupler re-binds the vertices that changed and those of cubes
// whose nodes changed, and couples them, so the render buffer is current when apply_tool returns.
// Pieces that no longer connect to an anchor fall under gravity.
//
// Several tools act at once, each in its own slot (one hand, one instrument: an endoscope pushing
// the mucosa aside in slot 0 while a wand ablates in slot 1): every pressing slot is resolved in
// one contact pass (collision/tool_contact.h), each ablating or cutting slot sweeps its own path.
// Bodies that push the tissue (another instance's surface, set_pushers) take part in every
// contact pass, whether a tool presses or not.
//
// Tearing (crms effects) runs through the same layers: after each advance() the springs the solver
// tore come back to the host (Solver::take_torn_springs), the voxels between their nodes are
// cleared (tear_separation.h), and the surface, lattice topology and coupler follow as for an
// edit (AdvanceReport::tear). An edit near a watched overlay label (vessels, nerves) raises an
// exposure event (exposure.h) and the animation triggers watching it.
//
// Threading: one thread owns the model (the simulation thread) and calls everything that is not
// marked otherwise. latest_contact() may be called from any thread (haptics) and never blocks the
// owner for longer than a copy of ContactForce; solver().snapshots() serves node positions to
// other threads (crms/snapshot_buffer.h). Render buffers are read by the owner between calls, or
// copied by it for a render thread (coupler's block versions say what changed).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tsf/collision/node_gatherer.h"
#include "tsf/collision/tool_contact.h"
#include "tsf/coupler/coupler.h"
#include "tsf/coupler/vertex_binder.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/solver.h"
#include "tsf/crms/stability_monitor.h"
#include "tsf/crms/time_step_choice.h"
#include "tsf/imt/imt_surface.h"
#include "tsf/interaction/exposure.h"
#include "tsf/interaction/rest_space_map.h"
#include "tsf/interaction/tool.h"
#include "tsf/interaction/tool_stroke.h"
#include "tsf/volume/volume_edits.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf::interaction {

struct TissueModelOptions {
  imt::SurfaceOptions surface;
  double surface_headroom = 0.5;  ///< spare IMT slots (ImtSurface)
  /// Lattice from the volume: node spacing k voxels, creation threshold, mass floor, density,
  /// labels to anchor.
  crms::VolumeLatticeOptions lattice;
  /// A node is deleted when its cell's occupancy drops below this, in (0, 1].
  float deletion_threshold = 0.125f;
  crms::SolverConfig solver;
  double dt_s = 0.0;  ///< solver step, s; 0 = dt_safety × the stable estimate
  double dt_safety = 0.9;
  coupler::CouplerMode coupler_mode = coupler::CouplerMode::kTrilinear;
  /// Strength and fall-off of ablation and cuts; `removal.rates`: the ablation rate per label.
  RemovalOptions removal;
  /// The cut rate per label: a blade pass removes rate × its weight (bone resists a scalpel).
  LabelRates cut_rates = LabelRates::uniform(1.0f);
  /// Force-dependent ablation (the thesis's coblation "feather pressure"): > 0 makes an ablating
  /// tool press the tissue as `press` does (contact constraints, a reaction force it feels) and
  /// remove at rate × (1 − exp(−F/F0)), F the contact force on the tool before the move, F0 this
  /// value in µN: nothing without contact, the full rate under firm pressure. 0 (the default):
  /// ablation removes at the full rate and exerts no force.
  double feather_force_un = 0.0;
  /// Exposure events of watched overlay labels (exposure.h); off while distance_mm is 0.
  ExposureOptions exposure;
  /// A blade thinner than this many voxels cuts this wide, ≥ 0. A one-voxel slab is not enough:
  /// its voxel keeps ~0.16 density, the BCC body centres beside it average to the iso-level and
  /// IMT reconnects the two sides through them; two voxels clear the slab.
  double min_blade_thickness_voxels = 2.0;
  /// Contact passes per advance() while pressing (the steps are split between them), ≥ 1.
  int contact_passes_per_advance = 2;
  collision::ContactOptions contact;
  /// Extra anchors applied to the lattice before the solver is made (scene anchors).
  std::function<void(crms::Lattice&)> anchor;
  /// Fills what the effects need from the built lattice (animation regions → node lists and
  /// rest shapes) into the solver configuration, after the anchors, before the solver is made.
  std::function<void(const crms::Lattice&, crms::SolverConfig&)> configure_effects;

  /// Throws tsf::Error naming the field when a value is out of range.
  void validate() const;
};

/// One apply_tool call: what changed and what each layer cost.
struct EditReport {
  ToolMode mode = ToolMode::kIdle;
  bool edited = false;       ///< voxels changed
  bool tissue_near = false;  ///< nodes were found near the tool (else nothing to edit)
  VoxelBox changed_voxels{};
  double removed_mm3 = 0;  ///< tissue removed (Σ density drop × voxel volume)
  /// removed_mm3 by the voxels' tissue labels (labels that lost nothing left out), ascending.
  std::vector<std::pair<std::uint8_t, double>> removed_by_label;
  /// Per label, what the tool reached: the tissue it would have removed at rate 1 (same strength
  /// and pressure), mm³. removed / reached is the label's effective rate.
  std::vector<std::pair<std::uint8_t, double>> reached_by_label;
  /// The factor on the removal strength: 1 − exp(−F/F0) for force-dependent ablation, else 1.
  double rate_scale = 1.0;
  /// Exposure events this edit raised (the first within the distance of a label, or nearer than
  /// any before).
  std::vector<ExposureEvent> exposures;
  std::size_t nodes_deleted = 0;
  std::size_t springs_broken = 0;
  std::size_t vertices_rebound = 0;
  std::size_t vertices_rebound_for_topology =
      0;  ///< of which only because their cube's nodes changed
  std::size_t vertices_added = 0, vertices_freed = 0, triangles_changed = 0;
  double map_us = 0;            ///< tool pose → rest space (gather + Newton)
  double edit_us = 0;           ///< voxel edit (with the density snapshot)
  bool edit_on_device = false;  ///< the blade sweep's weights came from the CUDA device
  double remesh_us = 0;         ///< IMT update + change list
  /// remesh_us by phase of ImtSurface::update (imt::kUpdatePhases names them)
  double remesh_phase_us[imt::SurfaceUpdateStats::kPhases] = {};
  /// of remesh_phase_us[0]: the part on the threads (imt::SurfaceUpdateStats); the region's
  /// chunks and how many of them were planned ahead there
  double remesh_classify_threads_us = 0;
  std::size_t remesh_chunks = 0, remesh_chunks_ahead = 0;
  double topology_us = 0;  ///< lattice deletions and broken springs
  /// the topology ran on a second thread while this one re-meshed (a re-mesh of one chunk, when
  /// OpenMP may use 4 threads or more): the edit's total is then less than the sum of its stages
  bool topology_beside_remesh = false;
  /// from the re-mesh's start to the end of both it and the topology (the wait for the topology
  /// included)
  double remesh_and_topology_us = 0;
  /// of topology_us: finding them (host), the solver breaking the springs (its flags and launch
  /// plans); the rest is the nodes' deletion there and the contacts forgetting them
  double topology_find_us = 0, topology_springs_us = 0;
  /// the contact pass after an ablation that presses as it ablates (force-dependent removal):
  /// the tool's contact with the edited tissue, part of total_us
  double contact_us = 0;
  double rebind_us = 0;  ///< coupler re-binding
  /// rebind_us by phase (coupler::RebindReport): the slots collected, their cells found and
  /// sorted, bound (threads), linked into the cube lists and frames (calling thread)
  double rebind_collect_us = 0, rebind_locate_us = 0, rebind_bind_us = 0, rebind_link_us = 0;
  double couple_us = 0;  ///< coupling the re-bound vertices
  /// couple_us by phase (coupler::Coupler::CoupleTiming): the frame list, the uploads, the
  /// coupling with its copy back, the output stamps
  double couple_prepare_us = 0, couple_upload_us = 0, couple_device_us = 0, couple_stamp_us = 0;
  double edit_sweep_us = 0;         ///< of edit_us, a blade's sweep (host threads or device)
  double total_us = 0;              ///< apply_tool end to end: edit → render buffer
  collision::ContactForce contact;  ///< press mode: the contact resolved at the new pose
};

/// What the springs the solver tore during one advance() did to the layers.
struct TearReport {
  std::size_t springs_torn = 0;  ///< springs the solver tore (tearing, node masking)
  std::size_t nodes_masked = 0;  ///< nodes the tear left without a spring; their cells cleared
  double cleared_mm3 = 0;        ///< tissue the separation cleared (Σ density × voxel volume)
  /// The separation through the layers: voxels changed, nodes deleted and springs broken because
  /// their cells or bridges emptied, vertices re-bound, timings (mode idle).
  EditReport layers;
  bool any() const { return springs_torn > 0; }
};

struct AdvanceReport {
  std::int64_t steps = 0;
  double simulated_s = 0;
  double step_us = 0, contact_us = 0, couple_us = 0;
  collision::ContactForce::Phases contact_phases_us;  ///< contact_us by step of the passes
  std::optional<crms::Instability> instability;
  TearReport tear;
};

/// Running totals since construction.
struct InteractionTotals {
  std::size_t edits = 0;
  double removed_mm3 = 0;
  std::size_t nodes_deleted = 0;
  std::size_t springs_broken = 0;
  std::size_t vertices_rebound = 0;
  std::int64_t steps = 0;
  double simulated_s = 0;
  /// removed_mm3 by tissue label, and what the tools reached (EditReport::reached_by_label).
  std::array<double, 256> removed_by_label_mm3{}, reached_by_label_mm3{};
  // Tearing (AdvanceReport::tear).
  std::size_t springs_torn = 0, nodes_masked = 0;
  std::size_t tear_nodes_deleted = 0, tear_springs_broken = 0;
  double tear_cleared_mm3 = 0;
};

namespace detail {
class EditWorker;
}

class TissueModel {
 public:
  /// Builds R2 (full surfacing), R3 (lattice from the volume, anchors, solver) and binds the
  /// coupler. Throws tsf::Error naming the option or the problem.
  TissueModel(VoxelVolume volume, TissueModelOptions options);
  ~TissueModel();
  TissueModel(const TissueModel&) = delete;
  TissueModel& operator=(const TissueModel&) = delete;

  const TissueModelOptions& options() const { return options_; }
  const VoxelVolume& volume() const { return volume_; }
  const imt::ImtSurface& surface() const { return surface_; }
  const crms::Solver& solver() const { return *solver_; }
  crms::Solver& solver() { return *solver_; }
  const coupler::Coupler& coupler() const { return *coupler_; }
  double dt() const { return dt_; }
  /// How dt was chosen (crms/time_step_choice.h): the estimate and the rule.
  const crms::TimeStepChoice& time_step_choice() const { return dt_choice_; }
  /// The stability verdict so far (crms/stability_monitor.h): advance() steps through it, so the
  /// tools' edits between frames count as work put in.
  crms::StabilitySummary stability() const { return monitor_.summary(*solver_); }
  const crms::StabilityMonitor& stability_monitor() const { return monitor_; }
  /// Per lattice node: 1 when anchored by the scene (labels, shapes).
  const std::vector<std::uint8_t>& anchored() const { return anchored_; }

  /// The most tool slots (hands) acting at once.
  static constexpr int kMaxToolSlots = 8;

  /// Moves `tool` to `pose` (deformed world) in `mode`, in slot 0.
  EditReport apply_tool(const Tool& tool, const ToolPose& pose, ToolMode mode) {
    return apply_tool(0, tool, pose, mode);
  }
  /// Moves `tool` in `slot` (0 … kMaxToolSlots − 1) to `pose` in `mode`. Ablate and cut sweep
  /// from the slot's previous pose when its previous call used the same mode and tool, else act
  /// at `pose` alone; press resolves the contacts of every pressing slot at once. Throws
  /// tsf::Error when the tool cannot run the mode or the slot is out of range.
  EditReport apply_tool(int slot, const Tool& tool, const ToolPose& pose, ToolMode mode);
  /// Lifts the tool of `slot`: releases what it alone holds and forgets its previous pose.
  void release_tool(int slot);
  /// Lifts every tool.
  void release_tool();
  /// Whether `slot` holds a tool in a mode other than idle.
  bool slot_active(int slot) const;

  /// Bodies that push this tissue, one way (another tissue instance's surface,
  /// interaction/body_field.h): they take part in every contact pass; their reaction is not the
  /// tools' (contact() leaves it out, pusher_contact() has it). The fields must outlive their use
  /// and may change between advance() calls (the pushing body moved).
  void set_pushers(std::vector<std::shared_ptr<const collision::DistanceField>> bodies);

  /// Simulates `dt_display` seconds (whole solver steps, at least one), resolving contacts of a
  /// pressing tool between step batches, then couples the render buffer.
  AdvanceReport advance(double dt_display);
  /// Couples every vertex from the current lattice state (advance() does it).
  void couple();

  /// The contact of the pressing tools after the last apply_tool/advance (zero when none): their
  /// summed force, the nodes they hold and the pass's costs.
  const collision::ContactForce& contact() const { return contact_; }
  /// One slot's share of contact() (zero when the slot does not press).
  collision::ToolReaction tool_contact(int slot) const;
  /// What the pushing bodies exert on the tissue's held nodes (the support of a resting tissue).
  const collision::ToolReaction& pusher_contact() const { return pusher_contact_; }
  /// Copy of the latest contact, safe from any thread.
  collision::ContactForce latest_contact() const;

  /// Maps a deformed-world point to rest space (nodes within `search_mm` are considered).
  RestPoint map_to_rest(const Vec3d& world, double search_mm);

  /// The surface as it looks now: IMT topology with the coupled positions and normals.
  imt::SurfaceMesh deformed_mesh() const;
  /// Number of lattice components (alive nodes joined by intact springs). O(nodes).
  std::size_t lattice_components() const;
  const InteractionTotals& totals() const { return totals_; }
  /// Exposure events so far, in order (EditReport::exposures of every edit).
  const std::vector<ExposureEvent>& exposure_events() const { return exposure_events_; }
  std::int64_t alive_nodes() const { return solver_->lattice().alive_count(); }

 private:
  /// One hand: the tool it holds, its last pose and mode, its stroke, its contact (held nodes).
  struct ToolSlot {
    std::optional<collision::WorldTool> last;
    ToolMode mode = ToolMode::kIdle;
    Tool spec;
    ToolStroke stroke;
    std::unique_ptr<collision::ToolContact> contact;
    collision::ContactForce last_contact;  ///< its last contact pass
    /// Force-dependent ablation (TissueModelOptions::feather_force_un > 0): ablate holds tissue.
    bool ablation_presses = false;
    /// Whether the slot holds tissue: it presses, or ablates pressing.
    bool pressing() const {
      return (mode == ToolMode::kPress || (mode == ToolMode::kAblate && ablation_presses)) &&
             last.has_value();
    }
  };
  /// A body pushing the tissue, with its own contact.
  struct Pusher {
    std::shared_ptr<const collision::DistanceField> body;
    std::unique_ptr<collision::ToolContact> contact;
    collision::ContactForce last_contact;
  };
  ToolSlot& slot_at(int slot);
  EditReport edit(ToolSlot& slot, const Tool& tool, const collision::WorldTool& from,
                  const collision::WorldTool& to, ToolMode mode, double rate_scale);
  /// After voxels changed (`before` holds their old densities): re-mesh, lattice topology,
  /// re-bind (also the cubes of `torn` springs, already gone from the lattice) and couple the
  /// re-bound vertices; fills r's layer fields and timings.
  void propagate_voxel_change(const DensitySnapshot& before, const VoxelBox& changed,
                              const std::vector<crms::SpringRef>& torn, EditReport& r);
  /// The springs the solver tore since the last call, through every layer (tear_separation.h).
  TearReport separate_torn();
  /// Records the exposures of an edit: events for labels it came nearer to than before.
  void record_exposures(const DensitySnapshot& before, EditReport& r);
  /// Whether an ablating tool presses (force-dependent ablation).
  bool ablation_presses() const { return options_.feather_force_un > 0.0; }
  void publish_contact(const collision::ContactForce& c);
  /// Whether a contact pass has work: a pressing slot or a pushing body.
  bool contact_active() const;
  /// Every pressing slot's tool and every body (owner: the slot, or −1 − the body's index).
  std::vector<collision::WorldTool> contact_tools(std::vector<int>& owner) const;
  /// Nodes held by every contact but `self`, ascending.
  std::vector<std::int64_t> held_by_others(const collision::ToolContact* self) const;
  /// One contact pass of one slot (owner ≥ 0) or body (−1 − index), against every tool.
  void resolve_contact(int owner);
  /// Sums the slots' last passes into contact() (and the bodies' into pusher_contact()).
  collision::ContactForce publish_contacts();
  /// A contact pass of every pressing slot and every body, then publish_contacts().
  collision::ContactForce resolve_contacts();
  /// The slot lets go of what it holds (not what others hold).
  void stop_pressing(ToolSlot& slot);

  TissueModelOptions options_;
  VoxelVolume volume_;
  imt::ImtSurface surface_;
  std::unique_ptr<crms::Solver> solver_;
  std::unique_ptr<coupler::Coupler> coupler_;
  std::unique_ptr<collision::NodeGatherer> gatherer_;
  /// The blade sweep on the device (when the solver runs on CUDA; else none).
  std::unique_ptr<BladeSweeper> sweeper_;
  /// Runs a stroke's lattice topology beside its re-mesh (made at the first such edit).
  std::unique_ptr<detail::EditWorker> edit_worker_;
  std::vector<std::uint8_t> anchored_;
  double dt_ = 0;
  crms::TimeStepChoice dt_choice_;
  crms::StabilityMonitor monitor_;
  std::vector<ToolSlot> slots_;  // grown on demand up to kMaxToolSlots
  std::vector<Pusher> pushers_;
  collision::ToolReaction pusher_contact_;
  collision::ContactForce contact_;
  mutable std::mutex contact_mutex_;
  collision::ContactForce shared_contact_;
  InteractionTotals totals_;
  collision::NodeNeighbourhood nb_;
  std::vector<ExposureEvent> exposure_events_;
  std::array<double, 256> exposure_nearest_mm_;  // per label: the nearest event so far
};

}  // namespace tsf::interaction
