#include "tsf/interaction/tissue_model.h"
#include "tsf/crms/time_step_choice.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/interaction/lattice_components.h"
#include "tsf/interaction/lattice_topology_edit.h"
#include "tsf/interaction/tear_separation.h"

namespace tsf::interaction {
namespace {

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
  return a.shape == b.shape && a.radius_mm == b.radius_mm && a.half_length_mm == b.half_length_mm &&
         a.half_extents_mm == b.half_extents_mm;
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
  contact_resolver_ =
      std::make_unique<collision::ToolContact>(geometry, anchored_, options_.contact);
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

void TissueModel::release_tool() {
  stroke_.end();
  contact_resolver_->release_all(*solver_);  // released nodes keep their positions
  last_tool_.reset();
  last_mode_ = ToolMode::kIdle;
  publish_contact({});
}

EditReport TissueModel::apply_tool(const Tool& tool, const ToolPose& pose, ToolMode mode) {
  tool.validate();
  if (!tool.supports(mode))
    throw Error(std::string("apply_tool: a ") + to_string(tool.shape) + " cannot " +
                to_string(mode) + " (ablate: sphere or capsule; cut: blade)");
  require(all_finite(pose.position), "apply_tool: the tool position is not finite");
  EditReport report;
  report.mode = mode;
  if (mode == ToolMode::kIdle) {
    release_tool();
    return report;
  }
  const collision::WorldTool world = place_tool(tool, pose);
  if (mode == ToolMode::kPress) {
    stroke_.end();
    Stopwatch total;
    if (last_mode_ != ToolMode::kIdle && last_tool_ && !same_tool(tool, last_tool_spec_))
      contact_resolver_->release_all(*solver_);
    const collision::ContactForce c =
        contact_resolver_->resolve(*solver_, *gatherer_, *coupler_, world);
    publish_contact(c);
    report.contact = c;
    report.tissue_near = c.nodes_gathered > 0;
    last_tool_ = world;
    last_tool_spec_ = tool;
    last_mode_ = mode;
    report.total_us = micros(total);
    return report;
  }
  // Force-dependent ablation presses as it ablates: the tool keeps what it holds (unless it is
  // another tool) and the force before the move sets the rate. Otherwise editing lets go.
  const bool presses = mode == ToolMode::kAblate && ablation_presses();
  const bool held = last_mode_ == ToolMode::kPress || (last_mode_ == ToolMode::kAblate && presses);
  if (held && (!presses || !last_tool_ || !same_tool(tool, last_tool_spec_))) {
    contact_resolver_->release_all(*solver_);
    publish_contact({});
  }
  const bool sweep = last_tool_ && last_mode_ == mode && same_tool(tool, last_tool_spec_);
  if (!sweep) stroke_.end();
  const double scale =
      presses ? -std::expm1(-length(contact_.force_un) / options_.feather_force_un) : 1.0;
  report = edit(tool, sweep ? *last_tool_ : world, world, mode, scale);
  if (presses) {
    Stopwatch clock;
    const collision::ContactForce c =
        contact_resolver_->resolve(*solver_, *gatherer_, *coupler_, world);
    publish_contact(c);
    report.contact = c;
    report.tissue_near = report.tissue_near || c.nodes_gathered > 0;
    report.total_us += micros(clock);
  }
  last_tool_ = world;
  last_tool_spec_ = tool;
  last_mode_ = mode;
  return report;
}

EditReport TissueModel::edit(const Tool& tool, const collision::WorldTool& from,
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
  DensitySnapshot before;
  before.capture(volume_, voxels_near_box(vg, rest_lo, rest_hi, reach));
  VoxelBox changed{};
  RemovalOptions removal = options_.removal;
  removal.strength = static_cast<float>(static_cast<double>(removal.strength) * rate_scale);
  if (tool.shape == collision::ToolShape::kBlade) {
    removal.rates = options_.cut_rates;
    changed = stroke_.cut_blade(volume_, blade, pose_from, pose_to, removal);
  } else if (tool.shape == collision::ToolShape::kSphere) {
    changed = stroke_.ablate_ball(volume_, cap_from.a, cap_to.a, tool.radius_mm, removal);
  } else {
    changed = stroke_.ablate_wand(volume_, cap_from, cap_to, removal);
  }
  r.edit_us = micros(clock);
  r.changed_voxels = changed;
  const double voxel_mm3 = vg.spacing.x * vg.spacing.y * vg.spacing.z;
  for (int l = 0; l < 256; ++l) {
    const double reached = stroke_.last_reached()[static_cast<std::size_t>(l)] * voxel_mm3;
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
  Stopwatch clock;
  surface_.update(volume_, changed);
  const imt::SurfaceChanges changes = surface_.take_changes();
  r.remesh_us = micros(clock);
  r.vertices_added = changes.vertices_added.size();
  r.vertices_freed = changes.vertices_freed.size();
  r.triangles_changed = changes.triangles_added.size() + changes.triangles_freed.size();

  clock.restart();
  const LatticeTopologyEdit topo = find_lattice_topology_edit(
      volume_, before, changed, solver_->lattice(), options_.lattice.node_spacing_voxels,
      options_.deletion_threshold, options_.surface.iso);
  if (!topo.broken_springs.empty()) solver_->break_springs(topo.broken_springs);
  if (!topo.deleted_nodes.empty()) {
    solver_->delete_nodes(topo.deleted_nodes);
    contact_resolver_->forget(topo.deleted_nodes);
  }
  // Deleting nodes and breaking springs moves nothing: the broad phase's boxes stay valid (a
  // deleted node is skipped by the query), so no refit is needed.
  r.nodes_deleted = topo.deleted_nodes.size();
  r.springs_broken = topo.broken_springs.size();
  r.topology_us = micros(clock);

  clock.restart();
  std::vector<crms::SpringRef> broken = topo.broken_springs;
  broken.insert(broken.end(), torn.begin(), torn.end());
  const coupler::RebindReport rebind =
      coupler_->apply_changes(surface_, changes, solver_->lattice(), topo.deleted_nodes, broken);
  r.vertices_rebound = rebind.rebound;
  r.vertices_rebound_for_topology = rebind.from_topology;
  r.rebind_us = micros(clock);

  clock.restart();
  if (rebind.full_rebind)
    coupler_->couple(*solver_);
  else
    coupler_->couple_slots(*solver_, coupler_->last_rebound());
  r.couple_us = micros(clock);
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
  const bool pressing =
      (last_mode_ == ToolMode::kPress || (last_mode_ == ToolMode::kAblate && ablation_presses())) &&
      last_tool_.has_value();
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
      publish_contact(contact_resolver_->resolve(*solver_, *gatherer_, *coupler_, *last_tool_));
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
