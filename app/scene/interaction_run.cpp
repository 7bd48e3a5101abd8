#include "scene/interaction_run.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "output/interrupt.h"
#include "output/output_folder.h"
#include "scene/scene_session.h"
#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/common/progress.h"
#include "tsf/common/stopwatch.h"
#include "tsf/crms/effects.h"
#include "tsf/imt/surface_ply.h"
#include "tsf/interaction/lattice_components.h"
#include "tsf/version.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::app {
namespace {

using nlohmann::json;

json vec(const Vec3d& v) {
  return json::array({v.x, v.y, v.z});
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto at = static_cast<std::size_t>(std::min<double>(
      static_cast<double>(v.size() - 1), std::ceil(p * static_cast<double>(v.size())) - 1));
  return v[at];
}

std::vector<std::string> kernel_feature_list(unsigned features) {
  namespace ft = crms::features;
  std::vector<std::string> list;
  if (features & ft::kSymmetricReactions) list.push_back("symmetric angular reactions");
  if (features & ft::kCosineAngular) list.push_back("cosine angular form");
  if (features & ft::kExternalForces) list.push_back("external forces");
  if (features & ft::kHeterogeneous) list.push_back("per-node materials");
  return list;
}

/// One instance while the script plays: its model, its open states file and what it measured.
struct InstanceRun {
  TissueInstance built;
  InstanceResult result;
  std::unique_ptr<SceneOutputWriter> files;  ///< rest mesh, states, final mesh
};

/// The script's frames: 1/frame_rate s each, until the duration (the last keyframe or event plus
/// 0.1 s, unless script.duration or --duration says otherwise).
struct ScriptClock {
  double frame_s = 0;
  std::int64_t frames = 0;
};

ScriptClock script_clock(const SceneScript& script, std::optional<double> duration_override) {
  const double duration = duration_override ? *duration_override : script.played_s();
  ScriptClock c;
  c.frame_s = 1.0 / script.frame_rate_hz;
  c.frames = static_cast<std::int64_t>(std::ceil(duration / c.frame_s - 1e-9));
  return c;
}

// ---- pass 1: build the instances and open their outputs --------------------------------------

InstanceRun build_instance_run(const Scene& scene, std::size_t i, const InteractionOutputs& out) {
  InstanceRun r;
  r.built = build_tissue_instance(scene, i);
  InstanceResult& res = r.result;
  res.index = i;
  res.name = r.built.name;
  res.volume = r.built.volume_geometry;
  res.patient_frame = r.built.patient_frame;
  res.setup_s = r.built.setup_s;
  res.session = r.built.summary;
  res.outputs.mesh = instance_output_path(out.mesh, scene, i);
  res.outputs.rest_mesh = instance_output_path(out.rest_mesh, scene, i);
  res.outputs.report = instance_output_path(out.report, scene, i);
  res.outputs.states = instance_output_path(out.states, scene, i);
  res.outputs.states_every = out.states_every;
  const interaction::TissueModel& model = *r.built.model;
  r.files = std::make_unique<SceneOutputWriter>(res.outputs, res.patient_frame, model);
  res.topology_start = imt::analyse_topology(model.surface().compact());
  res.components_start = model.lattice_components();
  res.alive_start = model.alive_nodes();
  return r;
}

// ---- pass 2: the tools of one frame ---------------------------------------------------------

void record_edit(InstanceResult& r, double t, const std::string& tool,
                 const interaction::EditReport& e) {
  for (const interaction::ExposureEvent& x : e.exposures) r.exposures.push_back({t, tool, x});
  if (!e.edited) return;
  r.edit_latencies_us.push_back(e.total_us);
  r.edits.push_back({t, tool, e});
}

/// Events due at `t` (the first frame at or after their time): a stroke from → to, then lift,
/// in the hand of the event's tool (scene_tool_slot); the other hands keep what they do.
void apply_due_events(const Scene& scene, double t, std::vector<bool>& done,
                      std::vector<InstanceRun>& runs) {
  for (std::size_t e = 0; e < scene.script.events.size(); ++e) {
    const SceneEvent& ev = scene.script.events[e];
    if (done[e] || ev.time_s > t + 1e-12) continue;
    done[e] = true;
    const interaction::Tool& tool = scene.find_tool(ev.tool)->tool;
    const int slot = scene_tool_slot(scene, ev.tool);
    for (InstanceRun& r : runs) {
      interaction::TissueModel& m = *r.built.model;
      m.release_tool(slot);
      m.apply_tool(slot, tool, ev.from, ev.mode);
      record_edit(r.result, t, ev.tool, m.apply_tool(slot, tool, ev.to, ev.mode));
      m.release_tool(slot);
    }
  }
}

/// Trajectories active at `t` move their tool, each in its own hand (several at once); one
/// frame past its last keyframe a trajectory lifts its tool.
void apply_trajectories(const Scene& scene, const std::vector<interaction::Trajectory>& paths,
                        double t, double frame_s, std::vector<bool>& lifted,
                        std::vector<InstanceRun>& runs) {
  for (std::size_t i = 0; i < paths.size(); ++i) {
    const interaction::TrajectorySample s = paths[i].sample(t);
    if (!s.started || lifted[i]) continue;
    const std::string& name = scene.script.trajectories[i].tool;
    const int slot = scene_tool_slot(scene, name);
    if (t > paths[i].end_time() + frame_s + 1e-12) {
      lifted[i] = true;
      for (InstanceRun& r : runs) r.built.model->release_tool(slot);
      continue;
    }
    const interaction::Tool& tool = scene.find_tool(name)->tool;
    for (InstanceRun& r : runs)
      record_edit(r.result, t, name, r.built.model->apply_tool(slot, tool, s.pose, s.mode));
  }
}

// ---- pass 3: advance every instance one frame -----------------------------------------------

/// Advances each instance by a frame, pushing bodies first (each pushed instance then sees its
/// pushers where they are at the frame's end); returns the summed tool contact at the frame's
/// end. The first instability stops the script (result.instability).
ContactSample advance_instances(const Scene& scene, const InteractionRunOptions& options,
                                double t_end, double frame_s, const InstanceContacts& contacts,
                                std::vector<InstanceRun>& runs, InteractionResult& result) {
  ContactSample sum{t_end, {0, 0, 0}, {0, 0, 0}, 0, {}};
  for (const std::size_t i : contacts.order) {
    InstanceResult& r = runs[i].result;
    interaction::TissueModel& model = *runs[i].built.model;
    for (const InstanceContacts::Pusher& p : contacts.pushers[i])
      p.field->follow(*runs[p.instance].built.model);
    const interaction::AdvanceReport a = model.advance(frame_s);
    r.steps += a.steps;
    r.stepping_s += a.step_us * 1e-6;
    r.contacts_s += a.contact_us * 1e-6;
    r.contact_phases_us += a.contact_phases_us;
    r.coupling_s += a.couple_us * 1e-6;
    if (a.instability && !result.instability) {
      r.instability = a.instability->describe();
      result.instability = r.name + ": " + *r.instability;
    }
    if (a.tear.any()) r.tears.push_back({t_end, a.tear});
    if (options.on_frame) options.on_frame(t_end, i, model);
    const collision::ContactForce& c = model.contact();
    if (!contacts.pushers[i].empty()) {
      const collision::ToolReaction& b = model.pusher_contact();
      r.body_contact.push_back(
          {t_end, b.force_un, b.torque_un_mm, static_cast<std::int64_t>(b.nodes_held), {}});
    }
    r.max_tool_force_un = std::max(r.max_tool_force_un, length(c.force_un));
    std::vector<ToolShare> shares;
    for (std::size_t t = 0; t < scene.tools.size(); ++t) {
      const collision::ToolReaction share = model.tool_contact(static_cast<int>(t));
      if (share.nodes_held > 0)
        shares.push_back(
            {scene.tools[t].name, share.force_un, static_cast<std::int64_t>(share.nodes_held)});
    }
    if (c.nodes_held > 0 || !r.contact.empty())
      r.contact.push_back(
          {t_end, c.force_un, c.torque_un_mm, static_cast<std::int64_t>(c.nodes_held), shares});
    sum.force_un = sum.force_un + c.force_un;
    sum.torque_un_mm = sum.torque_un_mm + c.torque_un_mm;
    sum.nodes_held += static_cast<std::int64_t>(c.nodes_held);
    for (const ToolShare& share : shares) {
      auto it = std::find_if(sum.tools.begin(), sum.tools.end(),
                             [&](const ToolShare& o) { return o.tool == share.tool; });
      if (it == sum.tools.end()) {
        sum.tools.push_back(share);
      } else {
        it->force_un = it->force_un + share.force_un;
        it->nodes_held += share.nodes_held;
      }
    }
  }
  return sum;
}

// ---- pass 4: finish each instance: final mesh, states, lattice pieces ------------------------

void finish_instance(const InteractionRunOptions& options, const InteractionResult& result,
                     double end_time_s, InstanceRun& run) {
  InstanceResult& r = run.result;
  interaction::TissueModel& model = *run.built.model;
  const crms::Solver& solver = model.solver();
  const crms::Lattice& lattice = solver.lattice();
  r.final_mesh = model.deformed_mesh();
  run.files->finish(r.final_mesh, end_time_s);
  r.states_saved = run.files->states_saved();
  r.topology_end = imt::analyse_topology(r.final_mesh);
  const interaction::LatticeComponents pieces = interaction::find_lattice_components(lattice);
  r.components_end = pieces.count();
  r.component_sizes_end = pieces.sizes;
  for (std::uint8_t a : pieces.anchored) r.free_components_end += a ? 0 : 1;
  for (std::int64_t n = 0; n < lattice.node_count(); ++n)
    r.fixed_nodes += lattice.alive(n) && lattice.fixed(n);
  r.alive_end = model.alive_nodes();
  r.backend = solver.backend_name();
  r.integrator = crms::to_string(solver.config().integrator);
  r.effects_active = solver.active_effects();
  r.triggers_fired = solver.fired_triggers();
  r.kernel_features = kernel_feature_list(solver.features());
  r.bytes_per_node = solver.bytes_per_node();
  r.lattice_dims = lattice.geometry().dims;
  r.lattice_spacing_mm = lattice.geometry().spacing;
  r.dt_s = model.dt();
  r.totals = model.totals();
  r.stability = model.stability();
  if (options.after_script && !result.instability && !result.interrupted)
    r.extra = options.after_script(r.index, model);
}

/// The script's simulated time: frames over the frame rate.
double simulated_s(const InteractionResult& result) {
  return result.frame_rate_hz > 0 ? static_cast<double>(result.frames) / result.frame_rate_hz : 0;
}

void print_instance_summary(const Scene& scene, const InteractionResult& result,
                            const InstanceResult& r) {
  std::printf("%s: %s\n",
              scene.multi_instance ? (scene.name + "/" + r.name).c_str() : scene.name.c_str(),
              r.stability.headline().c_str());
  const bool tearing = std::find(r.effects_active.begin(), r.effects_active.end(), "tearing") !=
                       r.effects_active.end();
  const std::string torn = tearing
                               ? ", " + std::to_string(r.totals.springs_torn) + " springs torn (" +
                                     std::to_string(r.totals.nodes_masked) + " nodes masked)"
                               : std::string();
  std::printf(
      "%s: %lld frames (%lld steps of %.3g s) on %s; %zu edits removed %.4g mm³, %zu nodes "
      "deleted, %zu springs broken%s; lattice %zu → %zu pieces (%zu free); surface %zu → %zu "
      "triangles, %s; edit → render buffer p50 %.0f µs, p99 %.0f µs; %.3g s simulated in %.3g s "
      "(real-time factor %.3g)\n",
      scene.multi_instance ? (scene.name + "/" + r.name).c_str() : scene.name.c_str(),
      static_cast<long long>(result.frames), static_cast<long long>(r.steps), r.dt_s,
      r.backend.c_str(), r.totals.edits, r.totals.removed_mm3, r.totals.nodes_deleted,
      r.totals.springs_broken, torn.c_str(), r.components_start, r.components_end,
      r.free_components_end, r.topology_start.triangles, r.topology_end.triangles,
      r.topology_end.closed_oriented_manifold() ? "closed manifold" : "NOT a closed manifold",
      percentile(r.edit_latencies_us, 0.5), percentile(r.edit_latencies_us, 0.99),
      simulated_s(result), result.script_s,
      result.script_s > 0 ? simulated_s(result) / result.script_s : 0.0);
  if (r.session.contains("poisson_ratio"))
    std::printf("%s: %s\n",
                scene.multi_instance ? (scene.name + "/" + r.name).c_str() : scene.name.c_str(),
                poisson_line(r.session["poisson_ratio"]).c_str());
  for (const ExposureRecord& e : r.exposures)
    std::printf("%s: warning: %s\n",
                scene.multi_instance ? (scene.name + "/" + r.name).c_str() : scene.name.c_str(),
                interaction::describe_exposure(e.event.hit, e.tool, e.time_s).c_str());
  if (!r.outputs.mesh.empty()) std::printf("wrote %s\n", r.outputs.mesh.string().c_str());
  if (!r.outputs.states.empty())
    std::printf("wrote %s (rest + %zu states)\n", r.outputs.states.string().c_str(),
                r.states_saved);
}

json contact_json(const std::vector<ContactSample>& samples) {
  json a = json::array();
  for (const ContactSample& c : samples) {
    json tools = json::array();
    for (const ToolShare& t : c.tools)
      tools.push_back(
          {{"tool", t.tool}, {"force_un", vec(t.force_un)}, {"nodes_held", t.nodes_held}});
    a.push_back({{"time_s", c.time_s},
                 {"force_un", vec(c.force_un)},
                 {"torque_un_mm", vec(c.torque_un_mm)},
                 {"nodes_held", c.nodes_held},
                 {"tools", tools}});
  }
  return a;
}

json by_label_json(const std::vector<std::pair<std::uint8_t, double>>& v) {
  json j = json::object();
  for (const auto& [label, mm3] : v) j[tissue_label_key(label)] = mm3;
  return j;
}

/// A contact pass's time by step (ToolContact::resolve), scaled from µs by `scale`.
json contact_phases_json(const collision::ContactForce::Phases& p, double scale) {
  return {{"gather", p.gather * scale},
          {"release", p.release * scale},
          {"narrow", p.narrow * scale},
          {"hold", p.hold * scale},
          {"feedback", p.feedback * scale}};
}

json layer_timings_json(const interaction::EditReport& r) {
  json remesh = json::object();
  for (int i = 0; i < imt::SurfaceUpdateStats::kPhases; ++i)
    remesh[imt::kUpdatePhases[i]] = r.remesh_phase_us[i];
  remesh["classify_on_threads"] = r.remesh_classify_threads_us;
  remesh["chunks"] = r.remesh_chunks;
  remesh["chunks_ahead"] = r.remesh_chunks_ahead;
  return {{"map", r.map_us},
          {"voxel_edit", r.edit_us},
          {"remesh", r.remesh_us},
          {"topology", r.topology_us},
          {"rebind", r.rebind_us},
          {"couple", r.couple_us},
          {"contact", r.contact_us},
          {"contact_phases", contact_phases_json(r.contact.phases_us, 1.0)},
          {"total", r.total_us},
          {"remesh_phases", remesh},
          {"rebind_phases",
           {{"collect", r.rebind_collect_us},
            {"locate", r.rebind_locate_us},
            {"bind", r.rebind_bind_us},
            {"link", r.rebind_link_us}}},
          {"couple_phases",
           {{"prepare", r.couple_prepare_us},
            {"upload", r.couple_upload_us},
            {"couple", r.couple_device_us},
            {"stamp", r.couple_stamp_us}}},
          {"topology_phases",
           {{"find", r.topology_find_us},
            {"break_springs", r.topology_springs_us},
            {"delete_nodes", r.topology_us - r.topology_find_us - r.topology_springs_us}}},
          {"remesh_and_topology", r.remesh_and_topology_us},
          {"voxel_edit_sweep", r.edit_sweep_us}};
}

json tear_json(const TearRecord& t) {
  const interaction::TearReport& r = t.report;
  return {{"time_s", t.time_s},
          {"springs_torn", r.springs_torn},
          {"nodes_masked", r.nodes_masked},
          {"cleared_mm3", r.cleared_mm3},
          {"nodes_deleted", r.layers.nodes_deleted},
          {"springs_broken", r.layers.springs_broken},
          {"vertices_rebound", r.layers.vertices_rebound},
          {"timings_us", layer_timings_json(r.layers)}};
}

json exposure_json(const ExposureRecord& e, const VolumeGeometry& patient_frame) {
  const interaction::ExposureHit& h = e.event.hit;
  return {{"time_s", e.time_s},
          {"tool", e.tool},
          {"label", static_cast<int>(h.label)},
          {"label_name", tissue_label_key(h.label)},
          {"distance_mm", h.distance_mm},
          {"position_mm", vec(patient_frame.tissue_to_patient(h.label_mm))},
          {"first", e.event.first}};
}

json by_label_json(const std::array<double, 256>& mm3) {
  std::vector<std::pair<std::uint8_t, double>> v;
  for (int l = 0; l < 256; ++l)
    if (mm3[static_cast<std::size_t>(l)] > 0.0)
      v.emplace_back(static_cast<std::uint8_t>(l), mm3[static_cast<std::size_t>(l)]);
  return by_label_json(v);
}

json edit_json(const EditRecord& e) {
  const interaction::EditReport& r = e.report;
  return {{"time_s", e.time_s},
          {"tool", e.tool},
          {"mode", interaction::to_string(r.mode)},
          {"removed_mm3", r.removed_mm3},
          {"removed_by_label_mm3", by_label_json(r.removed_by_label)},
          {"reached_by_label_mm3", by_label_json(r.reached_by_label)},
          {"rate_scale", r.rate_scale},
          {"contact_force_un", length(r.contact.force_un)},
          {"nodes_deleted", r.nodes_deleted},
          {"springs_broken", r.springs_broken},
          {"vertices_rebound", r.vertices_rebound},
          {"vertices_added", r.vertices_added},
          {"vertices_freed", r.vertices_freed},
          {"triangles_changed", r.triangles_changed},
          {"voxel_edit_on_device", r.edit_on_device},
          {"topology_beside_remesh", r.topology_beside_remesh},
          {"timings_us", layer_timings_json(r)}};
}

/// The worst instance's verdict, named.
json least_stable_json(const InteractionResult& result) {
  const InstanceResult* worst = result.least_stable();
  if (!worst) return nullptr;
  json s = stability_json(worst->stability);
  s["instance"] = worst->name;
  return s;
}

json path_or_null(const std::filesystem::path& p) {
  return p.empty() ? json(nullptr) : json(p.string());
}

}  // namespace

std::filesystem::path instance_output_path(const std::filesystem::path& path, const Scene& scene,
                                           std::size_t instance) {
  if (path.empty() || !scene.multi_instance) return path;
  return path.parent_path() / (path.stem().string() + "-" + scene.instances.at(instance).name +
                               path.extension().string());
}

const InstanceResult* InteractionResult::least_stable() const {
  const InstanceResult* worst = nullptr;
  for (const InstanceResult& r : instances)
    if (!worst ||
        static_cast<int>(r.stability.verdict) > static_cast<int>(worst->stability.verdict))
      worst = &r;
  return worst;
}

InteractionResult run_interaction_scene(const Scene& scene, const InteractionRunOptions& options) {
  if (scene.instances.empty())
    throw Error(scene.file.string() + ": the scene has no tissue instance");
  std::vector<InstanceRun> runs;
  for (std::size_t i = 0; i < scene.instances.size(); ++i)
    runs.push_back(build_instance_run(scene, i, options.outputs));

  std::vector<interaction::TissueModel*> models;
  for (InstanceRun& r : runs) models.push_back(r.built.model.get());
  const InstanceContacts contacts = build_instance_contacts(scene, models);
  for (std::size_t i = 0; i < runs.size(); ++i)
    for (const InstanceContacts::Pusher& p : contacts.pushers[i])
      runs[i].result.nodes_overlapping_pushers_at_rest += p.field->nodes_overlapping_at_rest();

  const ScriptClock clock = script_clock(scene.script, options.duration_s);
  std::vector<interaction::Trajectory> paths;
  for (const SceneTrajectory& t : scene.script.trajectories) paths.emplace_back(t.keyframes);
  std::vector<bool> event_done(scene.script.events.size(), false);
  std::vector<bool> lifted(paths.size(), false);

  InteractionResult result;
  result.frame_rate_hz = scene.script.frame_rate_hz;
  result.extra_key = options.extra_key;
  result.frames_planned = std::max<std::int64_t>(clock.frames, 0);
  Stopwatch wall;
  Progress progress("simulate " + scene.name, static_cast<std::uint64_t>(result.frames_planned),
                    !options.quiet && options.progress && Progress::stderr_is_terminal());
  for (std::int64_t f = 0; f < clock.frames && !result.instability; ++f) {
    if (interrupted()) {
      result.interrupted = true;
      break;
    }
    const double t = static_cast<double>(f) * clock.frame_s;
    apply_due_events(scene, t, event_done, runs);
    apply_trajectories(scene, paths, t, clock.frame_s, lifted, runs);
    if (options.before_advance)
      for (std::size_t i = 0; i < runs.size(); ++i)
        for (const EditRecord& e :
             options.before_advance(t, i, *runs[i].built.model, runs[i].result.patient_frame))
          record_edit(runs[i].result, e.time_s, e.tool, e.report);
    const ContactSample sum =
        advance_instances(scene, options, t + clock.frame_s, clock.frame_s, contacts, runs, result);
    result.frames = f + 1;
    result.max_tool_force_un = std::max(result.max_tool_force_un, length(sum.force_un));
    if (sum.nodes_held > 0 || !result.contact.empty()) result.contact.push_back(sum);
    for (InstanceRun& r : runs)
      r.files->frame(*r.built.model, f + 1, t + clock.frame_s, f + 1 == clock.frames);
    progress.set(static_cast<std::uint64_t>(f + 1));
  }
  progress.finish();
  for (InstanceRun& r : runs) r.built.model->release_tool();
  result.script_s = wall.seconds();

  const double end_time = static_cast<double>(result.frames) * clock.frame_s;
  for (InstanceRun& r : runs) {
    finish_instance(options, result, end_time, r);
    result.instances.push_back(std::move(r.result));
    r.built.model.reset();  // free each model once its results are out
  }
  if (!options.quiet)
    for (const InstanceResult& r : result.instances) print_instance_summary(scene, result, r);
  if (!options.outputs.report.empty())
    write_text_atomically(options.outputs.report,
                          interaction_report_json(scene, result).dump(2) + "\n");
  return result;
}

json instance_report_json(const Scene& scene, const InteractionResult& result,
                          const InstanceResult& r) {
  const SceneInstance& inst = scene.instances.at(r.index);
  const VolumeGeometry& vg = r.volume;
  json report = {
      {"tsf_version", TSF_VERSION_STRING},
      {"scene", {{"name", scene.name}, {"file", absolute_path(scene.file).string()}}},
      {"frame", "patient (LPS), mm"},
      {"instance", r.name},
      {"stability", stability_json(r.stability)},
      {"session", r.session},
      {"material",
       {{"id", inst.material_id.empty() ? json(nullptr) : json(inst.material_id)},
        {"youngs_modulus_pa", inst.material.youngs_modulus_pa},
        {"density_g_per_mm3", inst.material.density_g_per_mm3}}},
      {"backend", r.backend},
      {"integrator", r.integrator},
      {"effects_active", r.effects_active},
      {"triggers_fired", r.triggers_fired},
      {"kernel_features", r.kernel_features},
      {"bytes_per_node", r.bytes_per_node},
      {"coupler",
       inst.tissue.coupler == coupler::CouplerMode::kTrilinear ? "trilinear" : "local-frame"},
      {"volume",
       {{"dims", json::array({vg.dims.x, vg.dims.y, vg.dims.z})},
        {"spacing_mm", vec(vg.spacing)},
        {"origin_mm", vec(vg.origin)},
        {"tissue_bounds_mm",
         {vec(vg.origin), vec(vg.index_to_tissue({double(vg.dims.x - 1), double(vg.dims.y - 1),
                                                  double(vg.dims.z - 1)}))}}}},
      {"lattice",
       {{"dims", json::array({r.lattice_dims.x, r.lattice_dims.y, r.lattice_dims.z})},
        {"spacing_mm", vec(r.lattice_spacing_mm)},
        {"labels", inst.lattice.labels},
        {"alive_nodes_start", r.alive_start},
        {"alive_nodes_end", r.alive_end},
        {"fixed_nodes", r.fixed_nodes},
        {"components_start", r.components_start},
        {"components_end", r.components_end},
        {"free_components_end", r.free_components_end},
        {"component_sizes_end", r.component_sizes_end}}},
      {"surface",
       {{"vertices_start", r.topology_start.vertices},
        {"triangles_start", r.topology_start.triangles},
        {"vertices_end", r.topology_end.vertices},
        {"triangles_end", r.topology_end.triangles},
        {"components_end", r.topology_end.components},
        {"closed_manifold_end", r.topology_end.closed_oriented_manifold()}}},
      {"dt_s", r.dt_s},
      {"frame_rate_hz", result.frame_rate_hz},
      {"frames", result.frames},
      {"frames_planned", result.frames_planned},
      {"interrupted", result.interrupted},
      {"steps", r.steps},
      {"simulated_s", static_cast<double>(r.steps) * r.dt_s},
      {"totals",
       {{"edits", r.totals.edits},
        {"removed_mm3", r.totals.removed_mm3},
        {"removed_by_label_mm3", by_label_json(r.totals.removed_by_label_mm3)},
        {"reached_by_label_mm3", by_label_json(r.totals.reached_by_label_mm3)},
        {"nodes_deleted", r.totals.nodes_deleted},
        {"springs_broken", r.totals.springs_broken},
        {"springs_torn", r.totals.springs_torn},
        {"nodes_masked", r.totals.nodes_masked},
        {"tear_cleared_mm3", r.totals.tear_cleared_mm3},
        {"tear_nodes_deleted", r.totals.tear_nodes_deleted},
        {"tear_springs_broken", r.totals.tear_springs_broken},
        {"exposure_events", r.exposures.size()},
        {"vertices_rebound", r.totals.vertices_rebound}}},
      {"edit_latency_us",
       {{"p50", percentile(r.edit_latencies_us, 0.5)},
        {"p99", percentile(r.edit_latencies_us, 0.99)},
        {"max", r.edit_latencies_us.empty()
                    ? 0.0
                    : *std::max_element(r.edit_latencies_us.begin(), r.edit_latencies_us.end())}}},
      {"max_tool_force_un", r.max_tool_force_un},
      {"timings_s",
       {{"setup", r.setup_s},
        // One instance: the script's wall time. Several: this instance's share (its stepping,
        // contacts and coupling; edits are in edits[].timings_us).
        {"script", result.instances.size() == 1 ? result.script_s
                                                : r.stepping_s + r.contacts_s + r.coupling_s},
        {"stepping", r.stepping_s},
        {"contacts", r.contacts_s},
        {"contact_phases", contact_phases_json(r.contact_phases_us, 1e-6)},
        {"coupling", r.coupling_s}}},
      {"outputs",
       {{"mesh", path_or_null(r.outputs.mesh)},
        {"rest_mesh", path_or_null(r.outputs.rest_mesh)},
        {"states", path_or_null(r.outputs.states)},
        {"states_saved", r.outputs.states.empty() ? json(nullptr) : json(r.states_saved)}}},
      {"instability", r.instability ? json(*r.instability) : json(nullptr)},
      {"edits", json::array()},
      {"tears", json::array()},
      {"exposures", json::array()},
      {"contact", contact_json(r.contact)},
  };
  if (!inst.pushed_by.empty())
    report["body_contact"] = {{"pushed_by", inst.pushed_by},
                              {"nodes_overlapping_at_rest", r.nodes_overlapping_pushers_at_rest},
                              {"samples", contact_json(r.body_contact)}};
  for (const EditRecord& e : r.edits) report["edits"].push_back(edit_json(e));
  for (const TearRecord& t : r.tears) report["tears"].push_back(tear_json(t));
  for (const ExposureRecord& e : r.exposures)
    report["exposures"].push_back(exposure_json(e, r.patient_frame));
  if (!r.extra.is_null()) report[result.extra_key] = r.extra;
  return report;
}

json interaction_report_json(const Scene& scene, const InteractionResult& result) {
  if (result.instances.size() == 1) return instance_report_json(scene, result, result.instances[0]);
  // Scene-wide: the frames, the script's wall time, sums of each instance's costs and totals.
  double setup = 0, stepping = 0, contacts = 0, coupling = 0, removed = 0;
  std::int64_t steps = 0, edits = 0;
  std::vector<double> latencies;
  json instances = json::array();
  for (const InstanceResult& r : result.instances) {
    setup += r.setup_s;
    stepping += r.stepping_s;
    contacts += r.contacts_s;
    coupling += r.coupling_s;
    steps += r.steps;
    edits += static_cast<std::int64_t>(r.totals.edits);
    removed += r.totals.removed_mm3;
    latencies.insert(latencies.end(), r.edit_latencies_us.begin(), r.edit_latencies_us.end());
    instances.push_back(instance_report_json(scene, result, r));
  }
  const double frame_s = result.frame_rate_hz > 0 ? 1.0 / result.frame_rate_hz : 0.0;
  return {
      {"tsf_version", TSF_VERSION_STRING},
      {"scene", {{"name", scene.name}, {"file", absolute_path(scene.file).string()}}},
      {"frame", "patient (LPS), mm"},
      {"backend", result.instances.front().backend},
      {"frame_rate_hz", result.frame_rate_hz},
      {"frames", result.frames},
      {"frames_planned", result.frames_planned},
      {"interrupted", result.interrupted},
      {"steps", steps},
      {"simulated_s", static_cast<double>(result.frames) * frame_s},
      {"totals", {{"edits", edits}, {"removed_mm3", removed}}},
      {"edit_latency_us",
       {{"p50", percentile(latencies, 0.5)}, {"p99", percentile(latencies, 0.99)}}},
      {"max_tool_force_un", result.max_tool_force_un},
      {"timings_s",
       {{"setup", setup},
        {"script", result.script_s},
        {"stepping", stepping},
        {"contacts", contacts},
        {"coupling", coupling}}},
      {"instability", result.instability ? json(*result.instability) : json(nullptr)},
      {"stability", least_stable_json(result)},
      {"contact", contact_json(result.contact)},
      {"instances", std::move(instances)},
  };
}

}  // namespace tsf::app
