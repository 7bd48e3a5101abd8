#include "tsf/interaction/tissue_model.h"
#include "tsf/crms/time_step_choice.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <string>

#include <omp.h>

#include "edit_worker.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/interaction/lattice_components.h"
#include "tsf/interaction/lattice_topology_edit.h"
#include "tsf/interaction/tear_separation.h"

namespace tsf::interaction {
namespace {

/// From this many OpenMP threads on, a stroke's topology runs beside its re-mesh. With fewer, the
/// team's threads that wait actively after a parallel region (for milliseconds, by default) hold
/// the cores the worker would need: on 2 cores the two ran one after the other anyway.
constexpr int kTopologyBesideThreads = 4;

double micros(const Stopwatch& s) {
  return s.seconds() * 1e6;
}

double min_voxel(const VolumeGeometry& g) {
  return std::min(g.spacing.x, std::min(g.spacing.y, g.spacing.z));
}

void grow(Vec3d& lo, Vec3d& hi, const Vec3d& a, const Vec3d& b) {
  lo = {std::min({lo.x, a.x, b.x}), std::min({lo.y, a.y, b.y}), std::min({lo.z, a.z, b.z})};
  hi = {std::max({hi.x, a.x, b.x}), std::max({hi.y, a.y, b.y}), std::max({hi.z, a.z, b.z})};
}

bool same_tool(const Tool& a, const Tool& b) {
  return a.same_as(b);
}

}  // namespace

void TissueModelOptions::validate() const {
  surface.validate();
  require(surface_headroom >= 0.0 && surface_headroom <= 10.0,
          "tissue model: surface_headroom must be in [0, 10]");
  require(lattice.node_spacing_voxels >= 1 && lattice.node_spacing_voxels <= 64,
          "tissue model: lattice.node_spacing_voxels must be in [1, 64], got " +
              std::to_string(lattice.node_spacing_voxels));
  require(
      std::isfinite(deletion_threshold) && deletion_threshold > 0.0f && deletion_threshold <= 1.0f,
      "tissue model: deletion_threshold must be in (0, 1], got " +
          std::to_string(deletion_threshold));
  require(std::isfinite(dt_s) && dt_s >= 0.0 && dt_s <= 1.0,
          "tissue model: dt must be in [0, 1] s (0 = automatic), got " + std::to_string(dt_s));
  require(std::isfinite(dt_safety) && dt_safety > 0.0 && dt_safety <= 10.0,
          "tissue model: dt_safety must be in (0, 10], got " + std::to_string(dt_safety));
  require(std::isfinite(min_blade_thickness_voxels) && min_blade_thickness_voxels >= 0.0 &&
              min_blade_thickness_voxels <= 100.0,
          "tissue model: min_blade_thickness_voxels must be in [0, 100]");
  require(contact_passes_per_advance >= 1 && contact_passes_per_advance <= 1000,
          "tissue model: contact_passes_per_advance must be in [1, 1000]");
  require(std::isfinite(removal.strength) && removal.strength >= 0.0f && removal.strength <= 1.0f,
          "tissue model: removal.strength must be in [0, 1]");
  for (int l = 0; l < 256; ++l)
    require(
        std::isfinite(cut_rates.rate[l]) && cut_rates.rate[l] >= 0.0f && cut_rates.rate[l] <= 1.0f,
        "tissue model: the cut rate of label " + std::to_string(l) + " must be in [0, 1]");
  require(std::isfinite(feather_force_un) && feather_force_un >= 0.0 && feather_force_un <= 1e12,
          "tissue model: feather_force must be in [0, 1e12] µN (0 = ablation without contact)");
  require(std::isfinite(exposure.distance_mm) && exposure.distance_mm >= 0.0 &&
              exposure.distance_mm <= 100.0,
          "tissue model: exposure.distance_mm must be in [0, 100] (0 = off)");
  require(contact.margin_spacings >= 1.0 && contact.margin_spacings <= 100.0 &&
              contact.max_narrow_iterations >= 0 && contact.max_narrow_iterations <= 1000 &&
              contact.vertex_tolerance_spacings >= 0.0,
          "tissue model: contact options out of range (margin ≥ 1 spacing, iterations ≤ 1000)");
}

TissueModel::TissueModel(VoxelVolume volume, TissueModelOptions options)
    : options_(std::move(options)),
      volume_(std::move(volume)),
      surface_(options_.surface, options_.surface_headroom) {
  options_.validate();
  exposure_nearest_mm_.fill(std::numeric_limits<double>::infinity());
  require(volume_.voxel_count() > 0, "tissue model: the volume is empty");
  if (!volume_.brick_ranges_current()) volume_.mark_all_modified();
  surface_.build(volume_);
  (void)surface_.take_changes();

  crms::Lattice lattice = crms::build_lattice_from_volume(volume_, options_.lattice);
  if (options_.anchor) options_.anchor(lattice);
  require(lattice.alive_count() > 0,
          "tissue model: no lattice node reaches the occupancy threshold: the volume holds no "
          "tissue (density ≥ " +
              std::to_string(options_.lattice.occupancy_threshold) + " per cell)");
  anchored_.resize(static_cast<std::size_t>(lattice.node_count()));
  for (std::int64_t n = 0; n < lattice.node_count(); ++n)
    anchored_[static_cast<std::size_t>(n)] = lattice.alive(n) && lattice.fixed(n);
  const crms::LatticeGeometry geometry = lattice.geometry();
  crms::SolverConfig solver_config = options_.solver;
  if (options_.configure_effects) options_.configure_effects(lattice, solver_config);
  solver_ = std::make_unique<crms::Solver>(std::move(lattice), solver_config);
  dt_choice_ = crms::choose_time_step(options_.dt_s, options_.dt_safety, *solver_);
  dt_ = dt_choice_.dt_s;

  coupler_ =
      std::make_unique<coupler::Coupler>(geometry, coupler::CouplerOptions{options_.coupler_mode});
  coupler_->bind_all(surface_, solver_->lattice());
  coupler_->couple(*solver_);
  gatherer_ = std::make_unique<collision::NodeGatherer>(geometry);
  // On CUDA a cut's blade sweep runs on the device; made here so that the first cut does not pay
  // for the stream and the staging.
  if (solver_->on_cuda()) sweeper_ = make_cuda_blade_sweeper();
}

TissueModel::~TissueModel() = default;

void TissueModel::publish_contact(const collision::ContactForce& c) {
  contact_ = c;
  const std::lock_guard<std::mutex> lock(contact_mutex_);
  shared_contact_ = c;
}

collision::ContactForce TissueModel::latest_contact() const {
  const std::lock_guard<std::mutex> lock(contact_mutex_);
  return shared_contact_;
}

TissueModel::ToolSlot& TissueModel::slot_at(int slot) {
  require(slot >= 0 && slot < kMaxToolSlots, "tissue model: tool slot " + std::to_string(slot) +
                                                 " out of range (0 … " +
                                                 std::to_string(kMaxToolSlots - 1) + ")");
  while (static_cast<std::size_t>(slot) >= slots_.size()) slots_.emplace_back();
  ToolSlot& s = slots_[static_cast<std::size_t>(slot)];
  s.ablation_presses = ablation_presses();
  if (!s.contact)
    s.contact = std::make_unique<collision::ToolContact>(solver_->lattice().geometry(), anchored_,
                                                         options_.contact);
  return s;
}

bool TissueModel::slot_active(int slot) const {
  return slot >= 0 && static_cast<std::size_t>(slot) < slots_.size() &&
         slots_[static_cast<std::size_t>(slot)].mode != ToolMode::kIdle;
}

collision::ToolReaction TissueModel::tool_contact(int slot) const {
  if (slot < 0 || static_cast<std::size_t>(slot) >= slots_.size()) return {};
  const ToolSlot& s = slots_[static_cast<std::size_t>(slot)];
  if (!s.pressing()) return {};
  return {s.last_contact.force_un, s.last_contact.torque_un_mm, s.last_contact.nodes_held};
}

void TissueModel::set_pushers(std::vector<std::shared_ptr<const collision::DistanceField>> bodies) {
  for (const auto& b : bodies) require(b != nullptr, "tissue model: a pushing body is null");
  for (Pusher& p : pushers_) p.contact->release_all(*solver_, held_by_others(p.contact.get()));
  pushers_.clear();
  for (auto& b : bodies) {
    Pusher p;
    p.body = std::move(b);
    p.contact = std::make_unique<collision::ToolContact>(solver_->lattice().geometry(), anchored_,
                                                         options_.contact);
    pushers_.push_back(std::move(p));
  }
  pusher_contact_ = {};
}

bool TissueModel::contact_active() const {
  if (!pushers_.empty()) return true;
  for (const ToolSlot& s : slots_)
    if (s.pressing()) return true;
  return false;
}

std::vector<std::int64_t> TissueModel::held_by_others(const collision::ToolContact* self) const {
  std::vector<std::int64_t> all;
  auto add = [&](const collision::ToolContact* c) {
    if (c == nullptr || c == self || c->held().empty()) return;
    std::vector<std::int64_t> merged;
    std::set_union(all.begin(), all.end(), c->held().begin(), c->held().end(),
                   std::back_inserter(merged));
    all.swap(merged);
  };
  for (const ToolSlot& s : slots_) add(s.contact.get());
  for (const Pusher& p : pushers_) add(p.contact.get());
  return all;
}

std::vector<collision::WorldTool> TissueModel::contact_tools(std::vector<int>& owner) const {
  std::vector<collision::WorldTool> tools;
  owner.clear();
  for (std::size_t i = 0; i < slots_.size(); ++i)
    if (slots_[i].pressing()) {
      tools.push_back(*slots_[i].last);
      owner.push_back(static_cast<int>(i));
    }
  for (std::size_t i = 0; i < pushers_.size(); ++i) {
    collision::WorldTool w;
    w.shape = collision::ToolShape::kField;
    w.field = pushers_[i].body.get();
    Vec3d lo, hi;
    w.field->bounds(lo, hi);
    w.pose.position = (lo + hi) * 0.5;
    tools.push_back(w);
    owner.push_back(-1 - static_cast<int>(i));
  }
  return tools;
}

void TissueModel::resolve_contact(int owner) {
  std::vector<int> owners;
  const std::vector<collision::WorldTool> tools = contact_tools(owners);
  const auto at = std::find(owners.begin(), owners.end(), owner);
  if (at == owners.end()) return;
  const std::size_t own = static_cast<std::size_t>(at - owners.begin());
  collision::ToolContact& c = owner >= 0 ? *slots_[static_cast<std::size_t>(owner)].contact
                                         : *pushers_[static_cast<std::size_t>(-1 - owner)].contact;
  const collision::ContactForce r =
      c.resolve(*solver_, *gatherer_, *coupler_, tools, own, held_by_others(&c));
  if (owner >= 0)
    slots_[static_cast<std::size_t>(owner)].last_contact = r;
  else
    pushers_[static_cast<std::size_t>(-1 - owner)].last_contact = r;
}

collision::ContactForce TissueModel::publish_contacts() {
  collision::ContactForce sum;
  for (const ToolSlot& s : slots_) {
    if (!s.pressing()) continue;
    const collision::ContactForce& c = s.last_contact;
    sum.force_un += c.force_un;
    sum.torque_un_mm += c.torque_un_mm;  // each about its own tool's reference point
    sum.nodes_held += c.nodes_held;
    sum.nodes_released += c.nodes_released;
    sum.vertices_tested += c.vertices_tested;
    sum.vertices_pushed += c.vertices_pushed;
    sum.narrow_iterations = std::max(sum.narrow_iterations, c.narrow_iterations);
    sum.narrow_cube_tests += c.narrow_cube_tests;
    sum.max_vertex_depth_mm = std::max(sum.max_vertex_depth_mm, c.max_vertex_depth_mm);
    sum.nodes_gathered += c.nodes_gathered;
    sum.phases_us += c.phases_us;
  }
  pusher_contact_ = {};
  for (const Pusher& p : pushers_) {
    // What the body exerts on the tissue: minus what the tissue exerts on it.
    pusher_contact_.force_un -= p.last_contact.force_un;
    pusher_contact_.torque_un_mm -= p.last_contact.torque_un_mm;
    pusher_contact_.nodes_held += p.last_contact.nodes_held;
  }
  publish_contact(sum);
  return sum;
}

collision::ContactForce TissueModel::resolve_contacts() {
  for (std::size_t i = 0; i < slots_.size(); ++i)
    if (slots_[i].pressing()) resolve_contact(static_cast<int>(i));
  for (std::size_t i = 0; i < pushers_.size(); ++i) resolve_contact(-1 - static_cast<int>(i));
  return publish_contacts();
}

void TissueModel::stop_pressing(ToolSlot& slot) {
  if (slot.pressing()) slot.contact->release_all(*solver_, held_by_others(slot.contact.get()));
  slot.last_contact = {};
}

void TissueModel::release_tool(int slot) {
  ToolSlot& s = slot_at(slot);
  s.stroke.end();
  const bool was_pressing = s.pressing();
  stop_pressing(s);  // released nodes keep their positions
  s.last.reset();
  s.mode = ToolMode::kIdle;
  if (was_pressing) publish_contacts();
}

void TissueModel::release_tool() {
  for (ToolSlot& s : slots_) {
    s.stroke.end();
    stop_pressing(s);  // released nodes keep their positions
    s.last.reset();
    s.mode = ToolMode::kIdle;
  }
  publish_contacts();
}

EditReport TissueModel::apply_tool(int slot_index, const Tool& tool, const ToolPose& pose,
                                   ToolMode mode) {
  tool.validate();
  ToolSlot& slot = slot_at(slot_index);
  if (!tool.supports(mode))
    throw Error(std::string("apply_tool: a ") + to_string(tool.shape) + " cannot " +
                to_string(mode) + " (ablate: sphere or capsule; cut: blade)");
  require(all_finite(pose.position), "apply_tool: the tool position is not finite");
  EditReport report;
  report.mode = mode;
  if (mode == ToolMode::kIdle) {
    release_tool(slot_index);
    return report;
  }
  const collision::WorldTool world = place_tool(tool, pose);
  if (mode == ToolMode::kPress) {
    slot.stroke.end();
    Stopwatch total;
    // A pressing tool that has not moved keeps its contact as the last pass left it (advance()
    // re-resolves it between steps): resolving again at once would let go of the nodes the
    // narrow phase holds off the tool's surface, for nothing.
    if (slot.pressing() && slot.mode == ToolMode::kPress && same_tool(tool, slot.spec) &&
        length(pose.position - slot.last->pose.position) == 0.0 &&
        pose.orientation.normalized().angle_to(slot.last->pose.orientation) < 1e-7) {
      report.contact = contact_;
      report.tissue_near = contact_.nodes_gathered > 0;
      report.total_us = micros(total);
      return report;
    }
    // The hand took another tool: what the old one held is let go first.
    if (slot.pressing() && !same_tool(tool, slot.spec)) stop_pressing(slot);
    slot.last = world;
    slot.spec = tool;
    slot.mode = mode;
    resolve_contact(slot_index);
    const collision::ContactForce c = publish_contacts();
    report.contact = c;
    report.tissue_near = slot.last_contact.nodes_gathered > 0;
    report.total_us = micros(total);
    return report;
  }
  // Force-dependent ablation presses as it ablates: the hand keeps what it holds (unless it took
  // another tool) and its force before the move sets the rate. Otherwise editing lets go (this
  // hand only: the others and the bodies keep theirs).
  const bool presses = mode == ToolMode::kAblate && ablation_presses();
  if (slot.pressing() && (!presses || !same_tool(tool, slot.spec))) {
    stop_pressing(slot);
    slot.mode = ToolMode::kIdle;
    publish_contacts();
  }
  const bool sweep = slot.last && slot.mode == mode && same_tool(tool, slot.spec);
  if (!sweep) slot.stroke.end();
  const double scale =
      presses ? -std::expm1(-length(slot.last_contact.force_un) / options_.feather_force_un) : 1.0;
  report = edit(slot, tool, sweep ? *slot.last : world, world, mode, scale);
  slot.last = world;
  slot.spec = tool;
  slot.mode = mode;
  if (presses) {
    Stopwatch clock;
    resolve_contact(slot_index);
    const collision::ContactForce c = publish_contacts();
    report.contact = c;
    report.tissue_near = report.tissue_near || slot.last_contact.nodes_gathered > 0;
    report.contact_us = micros(clock);
    report.total_us += report.contact_us;
  }
  return report;
}

EditReport TissueModel::edit(ToolSlot& slot, const Tool& tool, const collision::WorldTool& from,
                             const collision::WorldTool& to, ToolMode mode, double rate_scale) {
  EditReport r;
  r.mode = mode;
  r.rate_scale = rate_scale;
  Stopwatch total, clock;
  const crms::LatticeGeometry& g = solver_->lattice().geometry();
  const VolumeGeometry& vg = volume_.geometry();
  const double voxel = min_voxel(vg);
  const double falloff = options_.removal.falloff_mm < 0 ? voxel : options_.removal.falloff_mm;

  // Map the swept tool into rest space through the lattice: gather the nodes around the points
  // to map (centres, capsule ends) — the cubes Newton tries and their neighbours; only when none
  // is there (a large tool whose centre is in the air) look around the whole tool.
  const double h_max = std::max(g.spacing.x, std::max(g.spacing.y, g.spacing.z));
  const Vec3d margin{2.5 * h_max, 2.5 * h_max, 2.5 * h_max};
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  if (tool.shape == collision::ToolShape::kBlade) {
    grow(lo, hi, from.pose.position, to.pose.position);
  } else {
    grow(lo, hi, from.a, from.b);
    grow(lo, hi, to.a, to.b);
  }
  gatherer_->gather(*solver_, to_float(lo - margin), to_float(hi + margin), std::nullopt, nb_);
  if (nb_.size() == 0) {
    Vec3d a, b;
    collision::tool_bounds(from, lo, hi);
    collision::tool_bounds(to, a, b);
    grow(lo, hi, a, b);
    gatherer_->gather(*solver_, to_float(lo - margin), to_float(hi + margin), std::nullopt, nb_);
  }
  if (nb_.size() == 0) {
    r.map_us = micros(clock);
    r.total_us = micros(total);
    return r;
  }
  r.tissue_near = true;
  coupler::VertexBinder binder(solver_->lattice());
  auto to_rest = [&](const Vec3d& x) { return interaction::map_to_rest(nb_, binder, g, x); };

  Vec3d rest_lo{1e300, 1e300, 1e300}, rest_hi{-1e300, -1e300, -1e300};
  double reach = falloff + 2.0 * voxel;
  CapsuleTool cap_from{}, cap_to{};
  BladeTool blade{};
  ToolPose pose_from{}, pose_to{};
  if (tool.shape == collision::ToolShape::kBlade) {
    const RestPoint pf = to_rest(from.pose.position), pt = to_rest(to.pose.position);
    pose_from = {pf.rest, rest_orientation(from.pose.orientation, pf.gradient)};
    pose_to = {pt.rest, rest_orientation(to.pose.orientation, pt.gradient)};
    blade.half_extents = tool.half_extents_mm;
    blade.half_extents.z =
        std::max(blade.half_extents.z, 0.5 * options_.min_blade_thickness_voxels * voxel);
    grow(rest_lo, rest_hi, pf.rest, pt.rest);
    reach += length(blade.half_extents);
  } else {
    cap_from = {to_rest(from.a).rest, to_rest(from.b).rest, from.radius};
    cap_to = {to_rest(to.a).rest, to_rest(to.b).rest, to.radius};
    grow(rest_lo, rest_hi, cap_from.a, cap_from.b);
    grow(rest_lo, rest_hi, cap_to.a, cap_to.b);
    reach += tool.radius_mm;
  }
  r.map_us = micros(clock);

  // The voxel edit, with the densities it may touch saved for the spring test.
  clock.restart();
  RemovalOptions removal = options_.removal;
  removal.strength = static_cast<float>(static_cast<double>(removal.strength) * rate_scale);
  if (tool.shape == collision::ToolShape::kBlade) removal.rates = options_.cut_rates;
  // A blade's own sweep box (its sub-steps' world-axis extents), not the sphere through its
  // corners: for the sinus scene's 40 mm blade ~20× fewer voxels to copy.
  BladeSweepPlan plan;
  if (tool.shape == collision::ToolShape::kBlade)
    plan = plan_blade_sweep(vg, blade, pose_from, pose_to, removal);
  DensitySnapshot before;
  before.capture(volume_, tool.shape == collision::ToolShape::kBlade
                              ? plan.box
                              : voxels_near_box(vg, rest_lo, rest_hi, reach));
  VoxelBox changed{};
  if (tool.shape == collision::ToolShape::kBlade) {
    // On CUDA the sweep's blade distances (a cut's million) run on the device; the weights come
    // back and the stroke applies them here, the same edit (BladeSweeper).
    r.edit_on_device = sweeper_ != nullptr;
    changed = slot.stroke.cut_blade(volume_, plan, removal, sweeper_.get());
    r.edit_sweep_us = slot.stroke.last_sweep_seconds() * 1e6;
  } else if (tool.shape == collision::ToolShape::kSphere) {
    changed = slot.stroke.ablate_ball(volume_, cap_from.a, cap_to.a, tool.radius_mm, removal);
  } else {
    changed = slot.stroke.ablate_wand(volume_, cap_from, cap_to, removal);
  }
  r.edit_us = micros(clock);
  r.changed_voxels = changed;
  const double voxel_mm3 = vg.spacing.x * vg.spacing.y * vg.spacing.z;
  for (int l = 0; l < 256; ++l) {
    const double reached = slot.stroke.last_reached()[static_cast<std::size_t>(l)] * voxel_mm3;
    if (reached > 0.0) {
      r.reached_by_label.emplace_back(static_cast<std::uint8_t>(l), reached);
      totals_.reached_by_label_mm3[static_cast<std::size_t>(l)] += reached;
    }
  }
  if (changed.empty()) {
    r.total_us = micros(total);
    return r;
  }
  require(changed.intersected(before.box()) == changed,
          "tissue model: an edit changed voxels outside the region saved before it (internal)");
  r.edited = true;
  r.removed_mm3 = before.removed_volume_mm3(volume_, changed);
  r.removed_by_label = before.removed_by_label_mm3(volume_, changed);
  propagate_voxel_change(before, changed, {}, r);
  r.total_us = micros(total);
  record_exposures(before, r);

  ++totals_.edits;
  totals_.removed_mm3 += r.removed_mm3;
  for (const auto& [label, mm3] : r.removed_by_label) totals_.removed_by_label_mm3[label] += mm3;
  totals_.nodes_deleted += r.nodes_deleted;
  totals_.springs_broken += r.springs_broken;
  totals_.vertices_rebound += r.vertices_rebound;
  return r;
}

void TissueModel::propagate_voxel_change(const DensitySnapshot& before, const VoxelBox& changed,
                                         const std::vector<crms::SpringRef>& torn, EditReport& r) {
  // The lattice's topology edit and the surface's re-mesh read the same voxels and write what
  // the other does not touch (the solver and the contacts; the surface). When the re-mesh is one
  // chunk (a stroke: it runs on this thread alone) and OpenMP may use enough threads, the
  // topology runs on the edit worker meanwhile. Neither reads what the other writes, so the
  // outcome is the same as one after the other (EditThreads.*).
  LatticeTopologyEdit topo;
  auto topology = [&] {
    Stopwatch t;
    topo = find_lattice_topology_edit(volume_, before, changed, solver_->lattice(),
                                      options_.lattice.node_spacing_voxels,
                                      options_.deletion_threshold, options_.surface.iso);
    r.topology_find_us = micros(t);
    if (!topo.broken_springs.empty()) solver_->break_springs(topo.broken_springs);
    r.topology_springs_us = micros(t) - r.topology_find_us;
    if (!topo.deleted_nodes.empty()) {
      solver_->delete_nodes(topo.deleted_nodes);
      for (ToolSlot& s : slots_)
        if (s.contact) s.contact->forget(topo.deleted_nodes);
      for (Pusher& p : pushers_) p.contact->forget(topo.deleted_nodes);
    }
    // Deleting nodes and breaking springs moves nothing: the broad phase's boxes stay valid (a
    // deleted node is skipped by the query), so no refit is needed.
    r.topology_us = micros(t);
  };
  Stopwatch both;
  r.topology_beside_remesh =
      omp_get_max_threads() >= kTopologyBesideThreads && surface_.update_chunks(changed) == 1;
  if (r.topology_beside_remesh && !edit_worker_)
    edit_worker_ = std::make_unique<detail::EditWorker>();
  detail::WorkerWait topology_done(r.topology_beside_remesh ? edit_worker_.get() : nullptr);
  if (r.topology_beside_remesh) edit_worker_->start(topology);

  Stopwatch clock;
  const imt::SurfaceUpdateStats remesh = surface_.update(volume_, changed);
  const imt::SurfaceChanges changes = surface_.take_changes();
  r.remesh_us = micros(clock);
  for (int i = 0; i < imt::SurfaceUpdateStats::kPhases; ++i)
    r.remesh_phase_us[i] = remesh.phase_seconds[i] * 1e6;
  r.remesh_classify_threads_us = remesh.classify_threads_seconds * 1e6;
  r.remesh_chunks = remesh.chunks_meshed;
  r.remesh_chunks_ahead = remesh.chunks_ahead;
  r.vertices_added = changes.vertices_added.size();
  r.vertices_freed = changes.vertices_freed.size();
  r.triangles_changed = changes.triangles_added.size() + changes.triangles_freed.size();

  if (r.topology_beside_remesh)
    topology_done.wait();
  else
    topology();
  r.remesh_and_topology_us = micros(both);
  r.nodes_deleted = topo.deleted_nodes.size();
  r.springs_broken = topo.broken_springs.size();

  clock.restart();
  std::vector<crms::SpringRef> broken = topo.broken_springs;
  broken.insert(broken.end(), torn.begin(), torn.end());
  const coupler::RebindReport rebind =
      coupler_->apply_changes(surface_, changes, solver_->lattice(), topo.deleted_nodes, broken);
  r.vertices_rebound = rebind.rebound;
  r.vertices_rebound_for_topology = rebind.from_topology;
  r.rebind_us = micros(clock);
  r.rebind_collect_us = rebind.collect_s * 1e6;
  r.rebind_locate_us = rebind.locate_s * 1e6;
  r.rebind_bind_us = rebind.bind_s * 1e6;
  r.rebind_link_us = rebind.link_s * 1e6;

  clock.restart();
  if (rebind.full_rebind)
    coupler_->couple(*solver_);
  else
    coupler_->couple_slots(*solver_, coupler_->last_rebound());
  r.couple_us = micros(clock);
  if (!rebind.full_rebind) {
    const coupler::Coupler::CoupleTiming& ct = coupler_->last_couple_timing();
    r.couple_prepare_us = ct.prepare_s * 1e6;
    r.couple_upload_us = ct.upload_s * 1e6;
    r.couple_device_us = ct.couple_s * 1e6;
    r.couple_stamp_us = ct.stamp_s * 1e6;
  }
}

void TissueModel::record_exposures(const DensitySnapshot& before, EditReport& r) {
  if (!options_.exposure.enabled()) return;
  for (const ExposureHit& hit :
       find_exposures(volume_, before, r.changed_voxels, options_.surface.iso, options_.exposure)) {
    double& nearest = exposure_nearest_mm_[hit.label];
    if (!(hit.distance_mm < nearest - 1e-9)) continue;
    ExposureEvent e;
    e.time_s = totals_.simulated_s;
    e.hit = hit;
    e.first = !std::isfinite(nearest);
    nearest = hit.distance_mm;
    if (e.first) solver_->raise_event(exposure_event_name(hit.label));
    r.exposures.push_back(e);
    exposure_events_.push_back(e);
  }
}

TearReport TissueModel::separate_torn() {
  TearReport t;
  const std::vector<crms::SpringRef> torn = solver_->take_torn_springs();
  if (torn.empty()) return t;
  Stopwatch total;
  t.springs_torn = torn.size();
  const TornVoxels voxels =
      torn_voxels(solver_->lattice(), torn, options_.lattice.node_spacing_voxels, volume_.dims());
  t.nodes_masked = voxels.masked_nodes.size();
  EditReport& r = t.layers;
  r.mode = ToolMode::kIdle;
  Stopwatch clock;
  DensitySnapshot before;
  VoxelBox changed{};
  if (!voxels.bounds.empty()) {
    before.capture(volume_, voxels.bounds);
    changed = clear_voxels(volume_, voxels.boxes);
  }
  r.edit_us = micros(clock);
  r.changed_voxels = changed;
  if (!changed.empty()) {
    r.edited = true;
    r.removed_mm3 = before.removed_volume_mm3(volume_, changed);
    r.removed_by_label = before.removed_by_label_mm3(volume_, changed);
    t.cleared_mm3 = r.removed_mm3;
    propagate_voxel_change(before, changed, torn, r);
  } else {
    // No tissue between the nodes (it was cut or torn before): re-bind their cubes alone.
    clock.restart();
    const coupler::RebindReport rebind =
        coupler_->apply_changes(surface_, imt::SurfaceChanges{}, solver_->lattice(), {}, torn);
    r.vertices_rebound = rebind.rebound;
    r.rebind_us = micros(clock);
  }
  r.total_us = micros(total);
  totals_.springs_torn += t.springs_torn;
  totals_.nodes_masked += t.nodes_masked;
  totals_.tear_cleared_mm3 += t.cleared_mm3;
  totals_.tear_nodes_deleted += r.nodes_deleted;
  totals_.tear_springs_broken += r.springs_broken;
  totals_.vertices_rebound += r.vertices_rebound;
  return t;
}

AdvanceReport TissueModel::advance(double dt_display) {
  require(std::isfinite(dt_display) && dt_display > 0 && dt_display <= 10.0,
          "advance: the frame time must be in (0, 10] s, got " + std::to_string(dt_display));
  AdvanceReport r;
  const std::int64_t steps = std::max<std::int64_t>(1, std::llround(dt_display / dt_));
  const bool pressing = contact_active();
  const std::int64_t passes =
      pressing ? std::min<std::int64_t>(options_.contact_passes_per_advance, steps) : 1;
  for (std::int64_t p = 0; p < passes; ++p) {
    const std::int64_t chunk = steps * (p + 1) / passes - steps * p / passes;
    Stopwatch clock;
    const crms::StepReport sr = monitor_.step(*solver_, static_cast<int>(chunk), dt_);
    r.step_us += micros(clock);
    r.steps += sr.steps_run;
    gatherer_->state_changed();
    if (sr.instability) {
      r.instability = sr.instability;
      break;
    }
    if (pressing) {
      clock.restart();
      r.contact_phases_us += resolve_contacts().phases_us;
      r.contact_us += micros(clock);
    }
  }
  r.simulated_s = static_cast<double>(r.steps) * dt_;
  // What tearing did during these steps, through the voxels, surface and coupler.
  if (!r.instability) r.tear = separate_torn();
  Stopwatch clock;
  coupler_->couple(*solver_);
  r.couple_us = micros(clock);
  totals_.steps += r.steps;
  totals_.simulated_s += r.simulated_s;
  return r;
}

void TissueModel::couple() {
  coupler_->couple(*solver_);
}

RestPoint TissueModel::map_to_rest(const Vec3d& world, double search_mm) {
  require(std::isfinite(search_mm) && search_mm > 0, "map_to_rest: search radius must be > 0");
  const Vec3d m{search_mm, search_mm, search_mm};
  gatherer_->gather(*solver_, to_float(world - m), to_float(world + m), std::nullopt, nb_);
  coupler::VertexBinder binder(solver_->lattice());
  return interaction::map_to_rest(nb_, binder, solver_->lattice().geometry(), world);
}

imt::SurfaceMesh TissueModel::deformed_mesh() const {
  std::vector<std::uint32_t> slots;
  imt::SurfaceMesh m = surface_.compact(&slots);
  m.normals.resize(m.positions.size());
  const auto& p = coupler_->positions();
  const auto& n = coupler_->normals();
  for (std::size_t i = 0; i < slots.size(); ++i) {
    m.positions[i] = p[slots[i]];
    m.normals[i] = n[slots[i]];
  }
  return m;
}

std::size_t TissueModel::lattice_components() const {
  return find_lattice_components(solver_->lattice()).count();
}

}  // namespace tsf::interaction
