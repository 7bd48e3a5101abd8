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
#include "tsf/crms/lattice_builders.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/imt/surface_ply.h"
#include "tsf/interaction/lattice_components.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/io/mesh_sequence.h"
#include "tsf/version.h"
#include "tsf/volume/analytic_volumes.h"
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

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto at = static_cast<std::size_t>(std::min<double>(
      static_cast<double>(v.size() - 1), std::ceil(p * static_cast<double>(v.size())) - 1));
  return v[at];
}

}  // namespace

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

json run_interaction_scene(const Scene& scene, const InteractionRunOptions& run) {
  Stopwatch setup_clock;
  const interaction::TissueModelOptions o = tissue_model_options(scene);

  VoxelVolume volume = scene_tissue_volume(scene);
  const VolumeGeometry vg = volume.geometry();
  interaction::TissueModel model(std::move(volume), o);
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
    solver.set_external_forces(nodes, forces);
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
  const double setup_s = setup_clock.seconds();

  // Outputs named by the command line win over the scene's.
  const std::filesystem::path mesh_path = !run.mesh.empty() ? run.mesh : scene.outputs.mesh;
  const std::filesystem::path report_path = !run.report.empty() ? run.report : scene.outputs.report;
  if (!scene.outputs.rest_mesh.empty())
    imt::write_surface_ply(scene.outputs.rest_mesh, model.deformed_mesh());
  const std::filesystem::path states_path = !run.states.empty() ? run.states : scene.outputs.states;
  // Streams to a temporary beside the file; it appears only when the run finishes.
  std::optional<io::MeshSequenceWriter> states;
  if (!states_path.empty()) states.emplace(states_path, vg, model.deformed_mesh(), 0.0);

  const imt::MeshTopology start_topology = imt::analyse_topology(model.surface().compact());
  const std::size_t start_components = model.lattice_components();
  const std::int64_t start_alive = model.alive_nodes();

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

  json edits = json::array(), contact_series = json::array();
  std::vector<double> latencies_us;
  double max_force = 0, stepping_s = 0, couple_s = 0, contact_s = 0;
  std::int64_t steps = 0;
  std::optional<crms::Instability> instability;
  Stopwatch run_clock;
  Progress progress("simulate " + scene.name,
                    static_cast<std::uint64_t>(std::max<std::int64_t>(frames, 0)),
                    !run.quiet && Progress::stderr_is_terminal());
  auto record_edit = [&](double t, const std::string& tool, const interaction::EditReport& r) {
    if (!r.edited) return;
    latencies_us.push_back(r.total_us);
    edits.push_back({{"time_s", t},
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
                       {"total", r.total_us}}}});
  };
  for (std::int64_t f = 0; f < frames && !instability; ++f) {
    const double t = static_cast<double>(f) * frame;
    for (std::size_t e = 0; e < script.events.size(); ++e) {
      const SceneEvent& ev = script.events[e];
      if (event_done[e] || ev.time_s > t + 1e-12) continue;
      event_done[e] = true;
      const interaction::Tool& tool = scene.find_tool(ev.tool)->tool;
      model.release_tool();
      model.apply_tool(tool, ev.from, ev.mode);
      record_edit(t, ev.tool, model.apply_tool(tool, ev.to, ev.mode));
      model.release_tool();
    }
    for (std::size_t i = 0; i < trajectories.size(); ++i) {
      const interaction::TrajectorySample s = trajectories[i].sample(t);
      const bool active = s.started && t <= trajectories[i].end_time() + frame;
      if (!active) continue;
      const std::string& name = script.trajectories[i].tool;
      const interaction::Tool& tool = scene.find_tool(name)->tool;
      record_edit(t, name, model.apply_tool(tool, s.pose, s.mode));
    }
    const interaction::AdvanceReport a = model.advance(frame);
    steps += a.steps;
    stepping_s += a.step_us * 1e-6;
    contact_s += a.contact_us * 1e-6;
    couple_s += a.couple_us * 1e-6;
    if (a.instability) instability = a.instability;
    if (run.on_frame) run.on_frame(t + frame, model);
    const collision::ContactForce& c = model.contact();
    max_force = std::max(max_force, length(c.force_un));
    if (c.nodes_held > 0 || !contact_series.empty())
      contact_series.push_back({{"time_s", t + frame},
                                {"force_un", vec(c.force_un)},
                                {"torque_un_mm", vec(c.torque_un_mm)},
                                {"nodes_held", c.nodes_held}});
    if (states && (f + 1) % scene.outputs.states_every == 0 && f + 1 < frames)
      states->add_frame(t + frame, model.deformed_mesh());
    progress.set(static_cast<std::uint64_t>(f + 1));
  }
  progress.finish();
  model.release_tool();
  const double run_s = run_clock.seconds();

  const imt::SurfaceMesh final_mesh = model.deformed_mesh();
  if (states) {
    if (frames > 0) states->add_frame(static_cast<double>(frames) * frame, final_mesh);
    states->finish();
  }
  const imt::MeshTopology end_topology = imt::analyse_topology(final_mesh);
  if (!mesh_path.empty()) imt::write_surface_ply(mesh_path, final_mesh);
  const interaction::LatticeComponents pieces = interaction::find_lattice_components(lattice);
  std::size_t free_pieces = 0;
  for (std::uint8_t a : pieces.anchored) free_pieces += a ? 0 : 1;
  const interaction::InteractionTotals& tot = model.totals();
  const crms::LatticeGeometry& lg = lattice.geometry();
  json report = {
      {"tsf_version", TSF_VERSION_STRING},
      {"scene", {{"name", scene.name}, {"file", scene.file.string()}}},
      {"backend", solver.backend_name()},
      {"coupler",
       scene.tissue.coupler == coupler::CouplerMode::kTrilinear ? "trilinear" : "local-frame"},
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
        {"alive_nodes_start", start_alive},
        {"alive_nodes_end", model.alive_nodes()},
        {"components_start", start_components},
        {"components_end", pieces.count()},
        {"free_components_end", free_pieces},
        {"component_sizes_end", pieces.sizes}}},
      {"surface",
       {{"vertices_start", start_topology.vertices},
        {"triangles_start", start_topology.triangles},
        {"vertices_end", end_topology.vertices},
        {"triangles_end", end_topology.triangles},
        {"components_end", end_topology.components},
        {"closed_manifold_end", end_topology.closed_oriented_manifold()}}},
      {"dt_s", model.dt()},
      {"frame_rate_hz", script.frame_rate_hz},
      {"frames", frames},
      {"steps", steps},
      {"simulated_s", static_cast<double>(steps) * model.dt()},
      {"totals",
       {{"edits", tot.edits},
        {"removed_mm3", tot.removed_mm3},
        {"nodes_deleted", tot.nodes_deleted},
        {"springs_broken", tot.springs_broken},
        {"vertices_rebound", tot.vertices_rebound}}},
      {"edit_latency_us",
       {{"p50", percentile(latencies_us, 0.5)},
        {"p99", percentile(latencies_us, 0.99)},
        {"max", latencies_us.empty()
                    ? 0.0
                    : *std::max_element(latencies_us.begin(), latencies_us.end())}}},
      {"max_tool_force_un", max_force},
      {"timings_s",
       {{"setup", setup_s},
        {"script", run_s},
        {"stepping", stepping_s},
        {"contacts", contact_s},
        {"coupling", couple_s}}},
      {"outputs",
       {{"mesh", mesh_path.empty() ? json(nullptr) : json(mesh_path.string())},
        {"rest_mesh",
         scene.outputs.rest_mesh.empty() ? json(nullptr) : json(scene.outputs.rest_mesh.string())},
        {"states", states_path.empty() ? json(nullptr) : json(states_path.string())},
        {"states_saved", states ? json(states->frame_count()) : json(nullptr)}}},
      {"instability", instability ? json(instability->describe()) : json(nullptr)},
      {"edits", edits},
      {"contact", contact_series},
  };
  if (!report_path.empty()) write_text_atomically(report_path, report.dump(2) + "\n");
  if (!run.quiet) {
    std::printf(
        "%s: %lld frames (%lld steps of %.3g s) on %s; %zu edits removed %.4g mm³, %zu nodes "
        "deleted, %zu springs broken; lattice %zu → %zu pieces (%zu free); surface %zu → %zu "
        "triangles, %s; edit → render buffer p50 %.0f µs, p99 %.0f µs\n",
        scene.name.c_str(), static_cast<long long>(frames), static_cast<long long>(steps),
        model.dt(), solver.backend_name().c_str(), tot.edits, tot.removed_mm3, tot.nodes_deleted,
        tot.springs_broken, start_components, pieces.count(), free_pieces, start_topology.triangles,
        end_topology.triangles,
        end_topology.closed_oriented_manifold() ? "closed manifold" : "NOT a closed manifold",
        percentile(latencies_us, 0.5), percentile(latencies_us, 0.99));
    if (!mesh_path.empty()) std::printf("wrote %s\n", mesh_path.string().c_str());
    if (states)
      std::printf("wrote %s (rest + %zu states)\n", states_path.string().c_str(),
                  states->frame_count());
  }
  if (instability) throw Error("unstable: " + instability->describe());
  return report;
}

}  // namespace tsf::app
