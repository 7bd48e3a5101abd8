#include "scene/interaction_run.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/common/stopwatch.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/imt/surface_ply.h"
#include "tsf/interaction/lattice_components.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/io/mesh_sequence.h"
#include "tsf/version.h"
#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/tissue_labels.h"
#include "tsf/volume/volume_edits.h"
#ifdef TSF_HAVE_IMPORT
#include "tsf/import/tissue_volume_io.h"
#endif

namespace tsf::app {
namespace {

using nlohmann::json;

json vec(const Vec3d& v) {
  return json::array({v.x, v.y, v.z});
}

#ifdef TSF_HAVE_IMPORT
/// The sub-volume of voxels whose centres lie in [lo, hi] mm.
VoxelVolume crop_volume(const VoxelVolume& v, const Vec3d& lo, const Vec3d& hi,
                        const std::string& scene_file) {
  const VoxelBox box = voxels_near_box(v.geometry(), lo, hi, 0.0);
  if (box.empty())
    throw Error(scene_file +
                ": lattice.crop: the box holds no voxel of the volume (its bounds are " +
                "given in the volume's tissue space, mm)");
  VolumeGeometry g = v.geometry();
  g.dims = box.extent();
  g.origin = v.geometry().index_to_tissue({double(box.lo.x), double(box.lo.y), double(box.lo.z)});
  VoxelVolume out(g, v.has_material_weights());
  float* d = out.density_for_tracked_write();
  std::uint8_t* l = out.labels_for_tracked_write();
  for (int k = 0; k < g.dims.z; ++k)
    for (int j = 0; j < g.dims.y; ++j)
      for (int i = 0; i < g.dims.x; ++i) {
        const std::size_t src = v.index(i + box.lo.x, j + box.lo.y, k + box.lo.z);
        const std::size_t dst = out.index(i, j, k);
        d[dst] = v.density_data()[src];
        l[dst] = v.label_data()[src];
        if (v.has_material_weights())
          out.material_weight_data()[dst] = v.material_weight_data()[src];
      }
  out.mark_all_modified();
  return out;
}
#endif

/// Empties every voxel whose label is not in `labels` (density 0, label outside): the instance's
/// surface and lattice are then built from its own segment classes only.
[[maybe_unused]] void keep_labels(VoxelVolume& v, const std::vector<std::uint8_t>& labels,
                                  const Scene& scene) {
  bool keep[256] = {};
  for (std::uint8_t l : labels) keep[l] = true;
  float* d = v.density_for_tracked_write();
  std::uint8_t* l = v.labels_for_tracked_write();
  std::size_t kept = 0;
  const auto n = static_cast<std::size_t>(v.geometry().dims.volume());
  for (std::size_t i = 0; i < n; ++i) {
    if (keep[l[i]]) {
      kept += d[i] > 0.0f;
      continue;
    }
    d[i] = 0.0f;
    l[i] = kLabelOutside;
  }
  v.mark_all_modified();
  if (kept == 0)
    throw Error(scene.file.string() + ": " +
                (scene.multi_instance ? "tissues[" + scene.instances.at(0).name + "]." : "") +
                "lattice.labels: no voxel of the volume" +
                (scene.lattice.cropped ? " (after the crop)" : "") + " has these labels");
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto at = static_cast<std::size_t>(std::min<double>(
      static_cast<double>(v.size() - 1), std::ceil(p * static_cast<double>(v.size())) - 1));
  return v[at];
}

}  // namespace

std::filesystem::path instance_output_path(const std::filesystem::path& path, const Scene& scene,
                                           std::size_t instance) {
  if (path.empty() || !scene.multi_instance) return path;
  return path.parent_path() / (path.stem().string() + "-" + scene.instances.at(instance).name +
                               path.extension().string());
}

void apply_scene_anchors(crms::Lattice& lattice, const Scene& scene) {
  for (const SceneAnchor& a : scene.anchors) {
    switch (a.kind) {
      case SceneAnchor::Kind::kBox:
        crms::fix_nodes_in_box(lattice, a.min_mm, a.max_mm);
        break;
      case SceneAnchor::Kind::kPlane:
        crms::fix_nodes_behind_plane(lattice, a.point_mm, a.normal);
        break;
      case SceneAnchor::Kind::kLabels:
        crms::fix_nodes_with_labels(lattice, a.labels);
        break;
    }
  }
}

VoxelVolume scene_tissue_volume(const Scene& scene) {
  const SceneLattice& sl = scene.lattice;
  if (sl.source == SceneLattice::Source::kBox) {
    // Voxels of spacing/k with one node spacing of empty voxels around the box, so the lattice
    // built from them has the box lattice's nodes (lattice_builders.h) plus a dead rim.
    const int k = scene.tissue.voxels_per_node;
    const double voxel = sl.spacing_mm / k;
    VolumeGeometry g;
    for (int a = 0; a < 3; ++a)
      g.dims[a] = static_cast<int>(std::lround(sl.size_mm[a] / voxel)) + 2 * k;
    require(g.dims.volume() <= 400'000'000,
            scene.file.string() + ": tissue.voxels_per_node: the box would need " +
                std::to_string(g.dims.volume()) + " voxels (at most 4e8)");
    g.spacing = {voxel, voxel, voxel};
    g.origin = sl.min_corner_mm - Vec3d{k * voxel, k * voxel, k * voxel} +
               Vec3d{0.5 * voxel, 0.5 * voxel, 0.5 * voxel};
    const Vec3d half = sl.size_mm * 0.5, centre = sl.min_corner_mm + half;
    return make_sdf_volume(
        g, [&](const Vec3d& p) { return box_distance_local(half, p - centre); }, 0.5 * voxel);
  }
#ifdef TSF_HAVE_IMPORT
  VoxelVolume v = import::read_tissue_volume(sl.volume);
  if (sl.cropped) v = crop_volume(v, sl.crop_min_mm, sl.crop_max_mm, scene.file.string());
  if (!sl.labels.empty()) keep_labels(v, sl.labels, scene);
  return v;
#else
  throw Error(scene.file.string() +
              ": lattice.source: volume needs a build with ITK (reconfigure with "
              "-DTSF_WITH_ITK=ON); this build reads analytic boxes only");
#endif
}

interaction::TissueModelOptions tissue_model_options(const Scene& scene) {
  interaction::TissueModelOptions o;
  o.surface.iso = static_cast<float>(scene.tissue.iso);
  o.surface.snap_epsilon = static_cast<float>(scene.tissue.merge_epsilon);
  o.lattice.node_spacing_voxels = scene.lattice.source == SceneLattice::Source::kBox
                                      ? scene.tissue.voxels_per_node
                                      : scene.lattice.node_spacing_voxels;
  o.lattice.occupancy_threshold = scene.lattice.source == SceneLattice::Source::kBox
                                      ? 0.125f
                                      : static_cast<float>(scene.lattice.occupancy_threshold);
  o.lattice.mass_floor = static_cast<float>(scene.lattice.mass_floor);
  o.lattice.density_g_per_mm3 = scene.solver.materials.at(0).density_g_per_mm3;
  if (scene.lattice.source == SceneLattice::Source::kVolume)
    configure_volume_lattice(scene.effect_regions, scene.solver, o.lattice);
  o.deletion_threshold = static_cast<float>(scene.tissue.deletion_threshold);
  o.solver = scene.solver;
  o.dt_s = scene.dt_s;
  o.dt_safety = scene.dt_safety;
  o.coupler_mode = scene.tissue.coupler;
  o.removal.strength = static_cast<float>(scene.tissue.removal_strength);
  o.removal.falloff_mm = scene.tissue.falloff_mm;
  o.min_blade_thickness_voxels = scene.tissue.min_blade_thickness_voxels;
  o.contact_passes_per_advance = scene.tissue.contact_passes;
  // The options own a copy of the scene for the anchors: they may outlive the caller's scene.
  auto held = std::make_shared<const Scene>(scene);
  o.anchor = [held](crms::Lattice& l) { apply_scene_anchors(l, *held); };
  o.configure_effects = [held](const crms::Lattice& l, crms::SolverConfig& c) {
    apply_scene_effects(held->effect_regions, l, c);
  };
  return o;
}

namespace {

json kernel_feature_list(unsigned features) {
  namespace ft = crms::features;
  json list = json::array();
  if (features & ft::kSymmetricReactions) list.push_back("symmetric angular reactions");
  if (features & ft::kCosineAngular) list.push_back("cosine angular form");
  if (features & ft::kExternalForces) list.push_back("external forces");
  if (features & ft::kHeterogeneous) list.push_back("per-node materials");
  return list;
}

/// One tissue instance's model and what its run measured.
struct InstanceRun {
  Scene scene;  ///< scene_for_instance: the top-level fields are this instance's
  std::string name;
  std::unique_ptr<interaction::TissueModel> model;
  VolumeGeometry vg;
  double setup_s = 0;
  imt::MeshTopology start_topology;
  std::size_t start_components = 0;
  std::int64_t start_alive = 0;
  std::filesystem::path mesh_path, rest_mesh_path, states_path;
  std::optional<io::MeshSequenceWriter> states;
  json edits = json::array();
  json contact_series = json::array();
  std::vector<double> latencies_us;
  double stepping_s = 0, couple_s = 0, contact_s = 0, max_force = 0;
  std::int64_t steps = 0;
  json extra;
};

/// Builds the instance's model, applies loads and the initial state, writes the rest mesh and
/// opens the states file.
void build_instance(InstanceRun& r) {
  Stopwatch clock;
  const Scene& scene = r.scene;
  VoxelVolume volume = scene_tissue_volume(scene);
  r.vg = volume.geometry();
  try {
    r.model =
        std::make_unique<interaction::TissueModel>(std::move(volume), tissue_model_options(scene));
  } catch (const Error& e) {
    if (!scene.multi_instance) throw;
    throw Error(scene.file.string() + ": tissues[" + r.name + "]: " + e.what());
  }
  interaction::TissueModel& model = *r.model;
  crms::Solver& solver = model.solver();
  const crms::Lattice& lattice = solver.lattice();
  if (!scene.loads.empty()) {
    std::vector<std::int64_t> nodes;
    std::vector<Vec3f> forces;
    for (const SceneLoad& load : scene.loads)
      for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
        const Vec3d p = lattice.geometry().rest_position(n);
        if (lattice.alive(n) && p.x >= load.min_mm.x && p.x <= load.max_mm.x &&
            p.y >= load.min_mm.y && p.y <= load.max_mm.y && p.z >= load.min_mm.z &&
            p.z <= load.max_mm.z) {
          nodes.push_back(n);
          forces.push_back(to_float(load.force_un));
        }
      }
    if (!nodes.empty()) solver.set_external_forces(nodes, forces);
  }
  if (scene.initial.scaled) {
    std::vector<Vec3f> u(static_cast<std::size_t>(lattice.node_count())), v(u.size());
    for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
      if (!lattice.alive(n) || lattice.fixed(n)) continue;
      const Vec3d p = lattice.geometry().rest_position(n);
      const Vec3d q =
          scene.initial.about_mm + cwise_mul(scene.initial.scale, p - scene.initial.about_mm);
      u[static_cast<std::size_t>(n)] = to_float(q - p);
    }
    solver.set_state(u, v);
    model.couple();
  }
  r.setup_s = clock.seconds();
  if (!r.rest_mesh_path.empty()) imt::write_surface_ply(r.rest_mesh_path, model.deformed_mesh());
  // Streams to a temporary beside the file; it appears only when the run finishes.
  if (!r.states_path.empty()) r.states.emplace(r.states_path, r.vg, model.deformed_mesh(), 0.0);
  r.start_topology = imt::analyse_topology(model.surface().compact());
  r.start_components = model.lattice_components();
  r.start_alive = model.alive_nodes();
}

json edit_json(double t, const std::string& tool, const interaction::EditReport& r) {
  return {{"time_s", t},
          {"tool", tool},
          {"mode", interaction::to_string(r.mode)},
          {"removed_mm3", r.removed_mm3},
          {"nodes_deleted", r.nodes_deleted},
          {"springs_broken", r.springs_broken},
          {"vertices_rebound", r.vertices_rebound},
          {"vertices_added", r.vertices_added},
          {"vertices_freed", r.vertices_freed},
          {"triangles_changed", r.triangles_changed},
          {"timings_us",
           {{"map", r.map_us},
            {"voxel_edit", r.edit_us},
            {"remesh", r.remesh_us},
            {"topology", r.topology_us},
            {"rebind", r.rebind_us},
            {"couple", r.couple_us},
            {"total", r.total_us}}}};
}

}  // namespace

json run_interaction_scene(const Scene& scene, const InteractionRunOptions& run) {
  if (scene.instances.empty())
    throw Error(scene.file.string() + ": the scene has no tissue instance");
  // Outputs named by the command line win over the scene's.
  const std::filesystem::path mesh_path = !run.mesh.empty() ? run.mesh : scene.outputs.mesh;
  const std::filesystem::path report_path = !run.report.empty() ? run.report : scene.outputs.report;
  const std::filesystem::path states_path = !run.states.empty() ? run.states : scene.outputs.states;

  std::vector<std::unique_ptr<InstanceRun>> runs;
  for (std::size_t i = 0; i < scene.instances.size(); ++i) {
    auto r = std::make_unique<InstanceRun>();
    r->scene = scene_for_instance(scene, i);
    r->scene.multi_instance = scene.multi_instance;
    r->name = scene.instances[i].name;
    r->mesh_path = instance_output_path(mesh_path, scene, i);
    r->rest_mesh_path = instance_output_path(scene.outputs.rest_mesh, scene, i);
    r->states_path = instance_output_path(states_path, scene, i);
    build_instance(*r);
    runs.push_back(std::move(r));
  }

  // The script: frames of 1/frame_rate s; events at the first frame at or after their time.
  const SceneScript& script = scene.script;
  double end = 0.0;
  std::vector<interaction::Trajectory> trajectories;
  for (const SceneTrajectory& t : script.trajectories) {
    trajectories.emplace_back(t.keyframes);
    end = std::max(end, t.keyframes.back().time_s);
  }
  for (const SceneEvent& e : script.events) end = std::max(end, e.time_s);
  double duration = script.duration_s >= 0 ? script.duration_s : end + 0.1;
  if (run.duration_s) duration = *run.duration_s;
  const double frame = 1.0 / script.frame_rate_hz;
  const auto frames = static_cast<std::int64_t>(std::ceil(duration / frame - 1e-9));
  std::vector<bool> event_done(script.events.size(), false);

  json contact_series = json::array();  // the tool's force: the sum over instances
  double max_force = 0;
  std::optional<crms::Instability> instability;
  std::string unstable_instance;
  Stopwatch run_clock;
  Progress progress("simulate " + scene.name,
                    static_cast<std::uint64_t>(std::max<std::int64_t>(frames, 0)),
                    !run.quiet && Progress::stderr_is_terminal());
  auto record_edit = [](InstanceRun& r, double t, const std::string& tool,
                        const interaction::EditReport& e) {
    if (!e.edited) return;
    r.latencies_us.push_back(e.total_us);
    r.edits.push_back(edit_json(t, tool, e));
  };
  for (std::int64_t f = 0; f < frames && !instability; ++f) {
    const double t = static_cast<double>(f) * frame;
    for (std::size_t e = 0; e < script.events.size(); ++e) {
      const SceneEvent& ev = script.events[e];
      if (event_done[e] || ev.time_s > t + 1e-12) continue;
      event_done[e] = true;
      const interaction::Tool& tool = scene.find_tool(ev.tool)->tool;
      for (auto& r : runs) {
        r->model->release_tool();
        r->model->apply_tool(tool, ev.from, ev.mode);
        record_edit(*r, t, ev.tool, r->model->apply_tool(tool, ev.to, ev.mode));
        r->model->release_tool();
      }
    }
    for (std::size_t i = 0; i < trajectories.size(); ++i) {
      const interaction::TrajectorySample s = trajectories[i].sample(t);
      const bool active = s.started && t <= trajectories[i].end_time() + frame;
      if (!active) continue;
      const std::string& name = script.trajectories[i].tool;
      const interaction::Tool& tool = scene.find_tool(name)->tool;
      for (auto& r : runs) record_edit(*r, t, name, r->model->apply_tool(tool, s.pose, s.mode));
    }
    Vec3d force{0, 0, 0}, torque{0, 0, 0};
    std::int64_t held = 0;
    for (std::size_t i = 0; i < runs.size(); ++i) {
      InstanceRun& r = *runs[i];
      const interaction::AdvanceReport a = r.model->advance(frame);
      r.steps += a.steps;
      r.stepping_s += a.step_us * 1e-6;
      r.contact_s += a.contact_us * 1e-6;
      r.couple_s += a.couple_us * 1e-6;
      if (a.instability && !instability) {
        instability = a.instability;
        unstable_instance = r.name;
      }
      if (run.on_frame) run.on_frame(t + frame, i, *r.model);
      const collision::ContactForce& c = r.model->contact();
      r.max_force = std::max(r.max_force, length(c.force_un));
      if (c.nodes_held > 0 || !r.contact_series.empty())
        r.contact_series.push_back({{"time_s", t + frame},
                                    {"force_un", vec(c.force_un)},
                                    {"torque_un_mm", vec(c.torque_un_mm)},
                                    {"nodes_held", c.nodes_held}});
      force = force + c.force_un;
      torque = torque + c.torque_un_mm;
      held += static_cast<std::int64_t>(c.nodes_held);
      if (r.states && (f + 1) % scene.outputs.states_every == 0 && f + 1 < frames)
        r.states->add_frame(t + frame, r.model->deformed_mesh());
    }
    max_force = std::max(max_force, length(force));
    if (held > 0 || !contact_series.empty())
      contact_series.push_back({{"time_s", t + frame},
                                {"force_un", vec(force)},
                                {"torque_un_mm", vec(torque)},
                                {"nodes_held", held}});
    progress.set(static_cast<std::uint64_t>(f + 1));
  }
  progress.finish();
  for (auto& r : runs) r->model->release_tool();
  const double run_s = run_clock.seconds();

  json instance_reports = json::array();
  for (std::size_t i = 0; i < runs.size(); ++i) {
    InstanceRun& r = *runs[i];
    interaction::TissueModel& model = *r.model;
    const crms::Solver& solver = model.solver();
    const crms::Lattice& lattice = solver.lattice();
    const imt::SurfaceMesh final_mesh = model.deformed_mesh();
    if (r.states) {
      if (frames > 0) r.states->add_frame(static_cast<double>(frames) * frame, final_mesh);
      r.states->finish();
    }
    const imt::MeshTopology end_topology = imt::analyse_topology(final_mesh);
    if (!r.mesh_path.empty()) imt::write_surface_ply(r.mesh_path, final_mesh);
    const interaction::LatticeComponents pieces = interaction::find_lattice_components(lattice);
    std::size_t free_pieces = 0;
    for (std::uint8_t a : pieces.anchored) free_pieces += a ? 0 : 1;
    const interaction::InteractionTotals& tot = model.totals();
    const crms::LatticeGeometry& lg = lattice.geometry();
    const VolumeGeometry& vg = r.vg;
    std::int64_t fixed_nodes = 0;
    for (std::int64_t n = 0; n < lattice.node_count(); ++n)
      fixed_nodes += lattice.alive(n) && lattice.fixed(n);
    const SceneInstance& inst = scene.instances[i];
    json report = {
        {"tsf_version", TSF_VERSION_STRING},
        {"scene", {{"name", scene.name}, {"file", scene.file.string()}}},
        {"instance", r.name},
        {"material",
         {{"id", inst.material_id.empty() ? json(nullptr) : json(inst.material_id)},
          {"youngs_modulus_pa", inst.material.youngs_modulus_pa},
          {"density_g_per_mm3", inst.material.density_g_per_mm3}}},
        {"backend", solver.backend_name()},
        {"integrator", crms::to_string(solver.config().integrator)},
        {"effects_active", solver.active_effects()},
        {"triggers_fired", solver.fired_triggers()},
        {"kernel_features", kernel_feature_list(solver.features())},
        {"bytes_per_node", solver.bytes_per_node()},
        {"coupler",
         r.scene.tissue.coupler == coupler::CouplerMode::kTrilinear ? "trilinear" : "local-frame"},
        {"volume",
         {{"dims", json::array({vg.dims.x, vg.dims.y, vg.dims.z})},
          {"spacing_mm", vec(vg.spacing)},
          {"origin_mm", vec(vg.origin)},
          {"tissue_bounds_mm",
           {vec(vg.origin), vec(vg.index_to_tissue({double(vg.dims.x - 1), double(vg.dims.y - 1),
                                                    double(vg.dims.z - 1)}))}}}},
        {"lattice",
         {{"dims", json::array({lg.dims.x, lg.dims.y, lg.dims.z})},
          {"spacing_mm", vec(lg.spacing)},
          {"labels", inst.lattice.labels},
          {"alive_nodes_start", r.start_alive},
          {"alive_nodes_end", model.alive_nodes()},
          {"fixed_nodes", fixed_nodes},
          {"components_start", r.start_components},
          {"components_end", pieces.count()},
          {"free_components_end", free_pieces},
          {"component_sizes_end", pieces.sizes}}},
        {"surface",
         {{"vertices_start", r.start_topology.vertices},
          {"triangles_start", r.start_topology.triangles},
          {"vertices_end", end_topology.vertices},
          {"triangles_end", end_topology.triangles},
          {"components_end", end_topology.components},
          {"closed_manifold_end", end_topology.closed_oriented_manifold()}}},
        {"dt_s", model.dt()},
        {"frame_rate_hz", script.frame_rate_hz},
        {"frames", frames},
        {"steps", r.steps},
        {"simulated_s", static_cast<double>(r.steps) * model.dt()},
        {"totals",
         {{"edits", tot.edits},
          {"removed_mm3", tot.removed_mm3},
          {"nodes_deleted", tot.nodes_deleted},
          {"springs_broken", tot.springs_broken},
          {"vertices_rebound", tot.vertices_rebound}}},
        {"edit_latency_us",
         {{"p50", percentile(r.latencies_us, 0.5)},
          {"p99", percentile(r.latencies_us, 0.99)},
          {"max", r.latencies_us.empty()
                      ? 0.0
                      : *std::max_element(r.latencies_us.begin(), r.latencies_us.end())}}},
        {"max_tool_force_un", r.max_force},
        {"timings_s",
         {{"setup", r.setup_s},
          // One instance: the script's wall time. Several: this instance's share (its stepping,
          // contacts and coupling; edits are in edits[].timings_us).
          {"script", runs.size() == 1 ? run_s : r.stepping_s + r.contact_s + r.couple_s},
          {"stepping", r.stepping_s},
          {"contacts", r.contact_s},
          {"coupling", r.couple_s}}},
        {"outputs",
         {{"mesh", r.mesh_path.empty() ? json(nullptr) : json(r.mesh_path.string())},
          {"rest_mesh", r.rest_mesh_path.empty() ? json(nullptr) : json(r.rest_mesh_path.string())},
          {"states", r.states_path.empty() ? json(nullptr) : json(r.states_path.string())},
          {"states_saved", r.states ? json(r.states->frame_count()) : json(nullptr)}}},
        {"instability", instability && unstable_instance == r.name ? json(instability->describe())
                                                                   : json(nullptr)},
        {"edits", r.edits},
        {"contact", r.contact_series},
    };
    if (run.after_script && !instability) report[run.extra_key] = run.after_script(i, model);
    instance_reports.push_back(std::move(report));
    if (!run.quiet) {
      std::printf(
          "%s: %lld frames (%lld steps of %.3g s) on %s; %zu edits removed %.4g mm³, %zu nodes "
          "deleted, %zu springs broken; lattice %zu → %zu pieces (%zu free); surface %zu → %zu "
          "triangles, %s; edit → render buffer p50 %.0f µs, p99 %.0f µs\n",
          scene.multi_instance ? (scene.name + "/" + r.name).c_str() : scene.name.c_str(),
          static_cast<long long>(frames), static_cast<long long>(r.steps), model.dt(),
          solver.backend_name().c_str(), tot.edits, tot.removed_mm3, tot.nodes_deleted,
          tot.springs_broken, r.start_components, pieces.count(), free_pieces,
          r.start_topology.triangles, end_topology.triangles,
          end_topology.closed_oriented_manifold() ? "closed manifold" : "NOT a closed manifold",
          percentile(r.latencies_us, 0.5), percentile(r.latencies_us, 0.99));
      if (!r.mesh_path.empty()) std::printf("wrote %s\n", r.mesh_path.string().c_str());
      if (r.states)
        std::printf("wrote %s (rest + %zu states)\n", r.states_path.string().c_str(),
                    r.states->frame_count());
    }
  }

  json report;
  if (runs.size() == 1) {
    report = std::move(instance_reports[0]);
  } else {
    // Scene-wide: the frames, the script's wall time, sums of each instance's costs and totals.
    double setup = 0, stepping = 0, contacts = 0, coupling = 0, removed = 0;
    std::int64_t steps = 0, edits = 0;
    std::vector<double> latencies;
    for (const auto& r : runs) {
      setup += r->setup_s;
      stepping += r->stepping_s;
      contacts += r->contact_s;
      coupling += r->couple_s;
      steps += r->steps;
      edits += static_cast<std::int64_t>(r->model->totals().edits);
      removed += r->model->totals().removed_mm3;
      latencies.insert(latencies.end(), r->latencies_us.begin(), r->latencies_us.end());
    }
    report = {
        {"tsf_version", TSF_VERSION_STRING},
        {"scene", {{"name", scene.name}, {"file", scene.file.string()}}},
        {"backend", runs[0]->model->solver().backend_name()},
        {"frame_rate_hz", script.frame_rate_hz},
        {"frames", frames},
        {"steps", steps},
        {"simulated_s", static_cast<double>(frames) * frame},
        {"totals", {{"edits", edits}, {"removed_mm3", removed}}},
        {"edit_latency_us",
         {{"p50", percentile(latencies, 0.5)}, {"p99", percentile(latencies, 0.99)}}},
        {"max_tool_force_un", max_force},
        {"timings_s",
         {{"setup", setup},
          {"script", run_s},
          {"stepping", stepping},
          {"contacts", contacts},
          {"coupling", coupling}}},
        {"instability",
         instability ? json(unstable_instance + ": " + instability->describe()) : json(nullptr)},
        {"contact", contact_series},
        {"instances", std::move(instance_reports)},
    };
  }
  if (!report_path.empty()) write_text_atomically(report_path, report.dump(2) + "\n");
  if (instability)
    throw Error("unstable" +
                (scene.multi_instance ? " (" + unstable_instance + ")" : std::string()) + ": " +
                instability->describe());
  return report;
}

}  // namespace tsf::app
