#include "scene/scene_session.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/time_step_choice.h"
#include "tsf/io/nrrd_volume.h"
#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/tissue_labels.h"
#include "tsf/volume/volume_edits.h"
#ifdef TSF_HAVE_IMPORT
#include "tsf/import/tissue_volume_io.h"
#endif

namespace tsf::app {
namespace {

[[noreturn]] void refuse(const Scene& scene, SceneCommand command, const std::string& key,
                         const std::string& why) {
  throw Error(scene.file.string() + ": " + key + ": tsf " + to_string(command) + " " + why);
}

/// A segmented tissue volume (PREFIX-density.nrrd with its labels and weights): through ITK where
/// the import module is built (NRRD, MHA, …), else through the core's own NRRD reader, so the
/// GPU machine's build (no ITK) simulates the segmented tissue too.
VoxelVolume read_scene_volume(const Scene& scene, const std::filesystem::path& path) {
#ifdef TSF_HAVE_IMPORT
  (void)scene;
  return import::read_tissue_volume(path);
#else
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".nrrd" && ext != ".nhdr")
    throw Error(scene.file.string() + ": lattice.volume: '" + path.string() +
                "': this build reads NRRD volumes only (no ITK; reconfigure with "
                "-DTSF_WITH_ITK=ON for other formats)");
  return io::read_tissue_volume_nrrd(path);
#endif
}

/// The box lattice of instance `index` (build_box_lattice: node count per axis = the box size
/// over the spacing, rounded; the spacing then fits the box exactly).
crms::Lattice box_lattice(const Scene& scene, const SceneInstance& inst) {
  crms::BoxLatticeOptions o;
  o.size_mm = inst.lattice.size_mm;
  o.spacing_mm = inst.lattice.spacing_mm;
  o.min_corner_mm = inst.lattice.min_corner_mm;
  o.density_g_per_mm3 = inst.material.density_g_per_mm3;
  (void)scene;
  return crms::build_box_lattice(o);
}

/// The sub-volume of voxels whose centres lie in [lo, hi] mm.
VoxelVolume crop_volume(const VoxelVolume& v, const Vec3d& lo, const Vec3d& hi,
                        const std::string& error_prefix) {
  const VoxelBox box = voxels_near_box(v.geometry(), lo, hi, 0.0);
  if (box.empty()) {
    const VolumeGeometry& g = v.geometry();
    const Vec3d last =
        g.index_to_tissue({double(g.dims.x - 1), double(g.dims.y - 1), double(g.dims.z - 1)});
    throw Error(error_prefix + "lattice.crop: the box holds no voxel of the volume (the volume's " +
                "voxel centres span [" + std::to_string(g.origin.x) + ", " +
                std::to_string(g.origin.y) + ", " + std::to_string(g.origin.z) + "] to [" +
                std::to_string(last.x) + ", " + std::to_string(last.y) + ", " +
                std::to_string(last.z) + "] mm)");
  }
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

/// Empties every voxel whose label is not in `labels` (density 0, label outside): the instance's
/// surface and lattice are then built from its own segment classes only.
/// Empties the voxels whose centres lie outside the crop's patient-aligned box (a box tilted
/// against the voxel grid; crop_volume kept its axis-aligned bounds).
void keep_oriented_box(VoxelVolume& v, const SceneLattice& l) {
  float* d = v.density_for_tracked_write();
  std::uint8_t* lab = v.labels_for_tracked_write();
  const VolumeGeometry& g = v.geometry();
  for (int k = 0; k < g.dims.z; ++k)
    for (int j = 0; j < g.dims.y; ++j)
      for (int i = 0; i < g.dims.x; ++i) {
        const Vec3d r = g.index_to_tissue({double(i), double(j), double(k)}) - l.crop_box_centre;
        bool inside = true;
        for (int ax = 0; ax < 3 && inside; ++ax)
          inside = std::fabs(dot(r, l.crop_box_axes[static_cast<std::size_t>(ax)])) <=
                   l.crop_box_half[ax];
        if (inside) continue;
        const std::size_t at = v.index(i, j, k);
        d[at] = 0.0f;
        lab[at] = kLabelOutside;
      }
  v.mark_all_modified();
}

void keep_labels(VoxelVolume& v, const std::vector<std::uint8_t>& labels, bool cropped,
                 const std::string& error_prefix) {
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
    throw Error(error_prefix + "lattice.labels: no voxel of the volume" +
                (cropped ? " (after the crop)" : "") + " has these labels");
}

/// `lattice.paint`: labels of the voxels holding tissue inside each shape, in order.
void paint_labels(VoxelVolume& v, const std::vector<ScenePaint>& paint) {
  for (const ScenePaint& p : paint) {
    if (p.capsule)
      label_capsule(v, {p.from_mm, p.to_mm, p.radius_mm}, p.label);
    else
      label_box(v, p.min_mm, p.max_mm, p.label);
  }
}

/// Anchors of an instance on its lattice (box, plane, labels).
void apply_anchors(const std::vector<SceneAnchor>& anchors, crms::Lattice& lattice) {
  for (const SceneAnchor& a : anchors) {
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

bool inside(const Vec3d& p, const Vec3d& lo, const Vec3d& hi) {
  return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
}

/// The tissue's voxels holding tissue, per label (what lattice.labels and lattice.paint left).
nlohmann::json label_histogram(const VoxelVolume& v) {
  std::array<std::int64_t, 256> count{};
  const auto& d = v.density_data();
  const auto& l = v.label_data();
  for (std::size_t i = 0; i < d.size(); ++i) count[l[i]] += d[i] > 0.0f;
  nlohmann::json j = nlohmann::json::object();
  for (int i = 1; i < 256; ++i)
    if (count[static_cast<std::size_t>(i)] > 0)
      j[tissue_label_key(static_cast<std::uint8_t>(i))] = count[static_cast<std::size_t>(i)];
  return j;
}

/// How the model removes tissue: per-label rates (those that are not 1), force dependence,
/// exposure watch.
nlohmann::json removal_summary(const SceneTissue& t, const interaction::TissueModelOptions& o) {
  nlohmann::json ablation = nlohmann::json::object(), cut = nlohmann::json::object();
  for (int l = 1; l < 255; ++l) {
    const float a = o.removal.rates.rate[static_cast<std::size_t>(l)];
    const float c = o.cut_rates.rate[static_cast<std::size_t>(l)];
    // Rates are floats: reported to 6 digits (0.05, not 0.0500000007).
    auto six = [](float v) { return std::round(static_cast<double>(v) * 1e6) / 1e6; };
    if (a != 1.0f) ablation[tissue_label_key(static_cast<std::uint8_t>(l))] = six(a);
    if (c != 1.0f) cut[tissue_label_key(static_cast<std::uint8_t>(l))] = six(c);
  }
  nlohmann::json labels = nlohmann::json::array();
  for (std::uint8_t l : o.exposure.labels) labels.push_back(tissue_label_key(l));
  return {{"strength", o.removal.strength},
          {"rates_source",
           t.rates_source.empty() ? nlohmann::json("uniform 1") : nlohmann::json(t.rates_source)},
          {"ablation_rates", ablation},
          {"cut_rates", cut},
          {"feather_force_mn", o.feather_force_un * 1e-3},
          {"exposure_distance_mm", o.exposure.distance_mm},
          {"exposure_labels", o.exposure.labels.empty() && o.exposure.enabled()
                                  ? nlohmann::json("every overlay label (64..127)")
                                  : nlohmann::json(labels)}};
}

}  // namespace

const char* to_string(SceneCommand command) {
  switch (command) {
    case SceneCommand::kSimulate:
      return "simulate";
    case SceneCommand::kRun:
      return "run";
    case SceneCommand::kView:
      return "view";
    case SceneCommand::kHaptics:
      return "haptics";
    case SceneCommand::kLink:
      return "link";
  }
  return "?";
}

void check_scene_for_command(const Scene& scene, SceneCommand command) {
  using C = SceneCommand;
  if (scene.pipeline.present && command != C::kRun)
    refuse(scene, command, "pipeline",
           "does not import or segment: the pipeline section runs with `tsf run " +
               scene.file.string() +
               "`; give this command a scene whose lattice.volume names the segmented density");
  if ((command == C::kRun || command == C::kLink) && !scene.interactive)
    refuse(scene, command, "lattice",
           "needs an interaction scene (tissue, tools and a script); this one only steps a "
           "lattice: run it with `tsf simulate`");
  if (scene.steps_given && command != C::kSimulate)
    refuse(scene, command, "solver.steps",
           "does not run a fixed number of lattice steps (that is `tsf simulate` on a "
           "lattice-only scene); leave solver.steps and solver.report_every out");
  if (command == C::kView || command == C::kHaptics) {
    if (scene.instances.size() > 1)
      refuse(scene, command, "tissues",
             "runs one tissue instance; this scene has " + std::to_string(scene.instances.size()) +
                 " (run it with `tsf simulate` or `tsf run`)");
  }
  if (command == C::kHaptics) {
    if (!scene.tools.empty())
      refuse(scene, command, "tools",
             "drives the stylus of --trajectory, not the scene's tools (they play in `tsf "
             "simulate`, `tsf run` and `tsf view`)");
    if (scene.script_given)
      refuse(scene, command, "script",
             "plays --trajectory, not the scene's script (it plays in `tsf simulate` and `tsf "
             "run`)");
    if (scene.outputs_given)
      refuse(scene, command, "outputs",
             "writes samples.csv, metrics.json and force.png to --out, not the scene's outputs");
  }
}

int scene_tool_slot(const Scene& scene, const std::string& name) {
  for (std::size_t i = 0; i < scene.tools.size(); ++i)
    if (scene.tools[i].name == name) {
      if (i >= static_cast<std::size_t>(interaction::TissueModel::kMaxToolSlots))
        throw Error(scene.file.string() + ": tools: at most " +
                    std::to_string(interaction::TissueModel::kMaxToolSlots) +
                    " tools act at once; '" + name + "' is tool " + std::to_string(i + 1));
      return static_cast<int>(i);
    }
  throw Error(scene.file.string() + ": no tool named '" + name + "' in tools");
}

std::vector<std::size_t> instance_push_order(const Scene& scene) {
  const std::size_t n = scene.instances.size();
  auto index_of = [&](const std::string& name) {
    for (std::size_t i = 0; i < n; ++i)
      if (scene.instances[i].name == name) return i;
    throw Error(scene.file.string() + ": contact.pushed_by: no instance named '" + name + "'");
  };
  std::vector<std::size_t> order;
  std::vector<int> state(n, 0);  // 0 new, 1 on the path, 2 placed
  std::function<void(std::size_t)> visit = [&](std::size_t i) {
    if (state[i] == 2) return;
    if (state[i] == 1)
      throw Error(scene.file.string() + ": tissues[" + std::to_string(i) + "] (" +
                  scene.instances[i].name +
                  "): contact.pushed_by: pushing goes round in a circle; contact is one way (the "
                  "stiffer body pushes)");
    state[i] = 1;
    for (const std::string& by : scene.instances[i].pushed_by) visit(index_of(by));
    state[i] = 2;
    order.push_back(i);
  };
  for (std::size_t i = 0; i < n; ++i) visit(i);
  return order;
}

InstanceContacts build_instance_contacts(const Scene& scene,
                                         const std::vector<interaction::TissueModel*>& models) {
  InstanceContacts c;
  c.order = instance_push_order(scene);
  c.pushers.resize(scene.instances.size());
  for (std::size_t i = 0; i < scene.instances.size(); ++i) {
    const SceneInstance& inst = scene.instances[i];
    if (inst.pushed_by.empty()) continue;
    std::vector<std::shared_ptr<const collision::DistanceField>> fields;
    for (const std::string& by : inst.pushed_by) {
      std::size_t j = 0;
      while (scene.instances[j].name != by) ++j;
      const interaction::TissueModel& body = *models.at(j);
      const Vec3d& v = body.volume().geometry().spacing;
      const double grid =
          inst.contact_grid_mm > 0 ? inst.contact_grid_mm : std::min({v.x, v.y, v.z});
      std::shared_ptr<interaction::BodyField> field;
      try {
        field = std::make_shared<interaction::BodyField>(body, grid);
      } catch (const Error& e) {
        throw Error(scene.instance_prefix(i) + "contact.pushed_by: '" + by + "': " + e.what());
      }
      field->set_rest_allowance(*models.at(i));
      c.pushers[i].push_back({j, field});
      fields.push_back(field);
    }
    models.at(i)->set_pushers(std::move(fields));
  }
  return c;
}

crms::Backend parse_backend(const std::string& text, const std::string& option) {
  if (text == "cpu") return crms::Backend::kCpu;
  if (text == "cuda") return crms::Backend::kCuda;
  if (text == "auto") return crms::Backend::kAuto;
  throw Error(option + ": expected cpu, cuda or auto, got '" + text + "'");
}

void override_backend(Scene& scene, const std::string& text) {
  if (text.empty()) return;
  scene.solver.backend = parse_backend(text);
  for (std::size_t i = 0; i < scene.instances.size(); ++i) {
    try {
      crms::validate_solver_config(instance_solver_config(scene, i));
    } catch (const Error& e) {
      throw Error("--backend " + text + ": " + scene.instance_prefix(i) + e.what());
    }
  }
}

crms::SolverConfig instance_solver_config(const Scene& scene, std::size_t index) {
  const SceneInstance& inst = scene.instances.at(index);
  crms::SolverConfig c = scene.solver;
  c.materials.at(0) = inst.material;
  for (crms::Material& m : c.materials)  // the instance's material and the palette's
    m.poisson_ratio = inst.integration.capped(m.poisson_ratio);
  c.effects = inst.effects;
  c.integrator = inst.integration.integrator;
  c.implicit_newton_iterations = inst.integration.newton_iterations;
  c.implicit_tolerance = inst.integration.newton_tolerance;
  return c;
}

VoxelVolume instance_tissue_volume(const Scene& scene, std::size_t index,
                                   VolumeGeometry* patient_frame) {
  const SceneInstance& inst = scene.instances.at(index);
  const SceneLattice& sl = inst.lattice;
  if (sl.source == SceneLattice::Source::kBox) {
    // The box lattice's own geometry (one rounding rule), k voxels per node spacing, and one node
    // spacing of empty voxels around it: the lattice built from these voxels has the box
    // lattice's nodes plus a dead rim.
    const crms::LatticeGeometry lg = box_lattice(scene, inst).geometry();
    const int k = inst.tissue.voxels_per_node;
    VolumeGeometry g;
    for (int a = 0; a < 3; ++a) {
      g.dims[a] = lg.dims[a] * k + 2 * k;
      g.spacing[a] = lg.spacing[a] / k;
      g.origin[a] = lg.origin[a] - 0.5 * lg.spacing[a] - (k - 0.5) * g.spacing[a];
    }
    require(g.dims.volume() <= 400'000'000,
            scene.instance_prefix(index) + "tissue.voxels_per_node: the box would need " +
                std::to_string(g.dims.volume()) + " voxels (at most 4e8)");
    if (patient_frame) *patient_frame = g;
    const Vec3d half = sl.size_mm * 0.5, centre = sl.min_corner_mm + half;
    const double ramp = 0.5 * std::min({g.spacing.x, g.spacing.y, g.spacing.z});
    VoxelVolume v = make_sdf_volume(
        g, [&](const Vec3d& p) { return box_distance_local(half, p - centre); }, ramp);
    paint_labels(v, sl.paint);
    return v;
  }
  VoxelVolume v = read_scene_volume(scene, sl.volume);
  if (patient_frame) *patient_frame = v.geometry();
  if (sl.cropped) v = crop_volume(v, sl.crop_min_mm, sl.crop_max_mm, scene.instance_prefix(index));
  if (sl.crop_oriented) keep_oriented_box(v, sl);
  if (!sl.labels.empty()) keep_labels(v, sl.labels, sl.cropped, scene.instance_prefix(index));
  paint_labels(v, sl.paint);
  return v;
}

int lattice_node_spacing_voxels(const SceneInstance& inst, const VolumeGeometry& volume) {
  if (inst.lattice.source == SceneLattice::Source::kBox) return inst.tissue.voxels_per_node;
  if (!(inst.lattice.node_spacing_mm > 0)) return inst.lattice.node_spacing_voxels;
  const double voxel = std::min({volume.spacing.x, volume.spacing.y, volume.spacing.z});
  return std::max(1, static_cast<int>(std::lround(inst.lattice.node_spacing_mm / voxel)));
}

interaction::TissueModelOptions instance_model_options(const Scene& scene, std::size_t index,
                                                       const VolumeGeometry& volume) {
  const SceneInstance& inst = scene.instances.at(index);
  const bool box = inst.lattice.source == SceneLattice::Source::kBox;
  interaction::TissueModelOptions o;
  o.surface.iso = static_cast<float>(inst.tissue.iso);
  o.surface.snap_epsilon = static_cast<float>(inst.tissue.merge_epsilon);
  o.lattice.node_spacing_voxels = lattice_node_spacing_voxels(inst, volume);
  o.lattice.occupancy_threshold =
      box ? 0.125f : static_cast<float>(inst.lattice.occupancy_threshold);
  o.lattice.mass_floor = static_cast<float>(inst.lattice.mass_floor);
  o.lattice.density_g_per_mm3 = inst.material.density_g_per_mm3;
  o.solver = instance_solver_config(scene, index);
  // Gravity is given in patient coordinates (LPS): into the volume's tissue space.
  o.solver.gravity = volume.direction_to_tissue(o.solver.gravity);
  if (!box) configure_volume_lattice(scene.effect_regions, o.solver, o.lattice);
  o.deletion_threshold = static_cast<float>(inst.tissue.deletion_threshold);
  o.dt_s = inst.integration.dt_s;
  o.dt_safety = inst.integration.dt_safety;
  o.coupler_mode = inst.tissue.coupler;
  o.removal.strength = static_cast<float>(inst.tissue.removal_strength);
  o.removal.falloff_mm = inst.tissue.falloff_mm;
  o.removal.rates.rate = inst.tissue.ablation_rates;
  o.cut_rates.rate = inst.tissue.cut_rates;
  o.feather_force_un = inst.tissue.feather_force_mn * 1e3;
  o.exposure.distance_mm = inst.tissue.exposure_distance_mm;
  o.exposure.labels = inst.tissue.exposure_labels;
  o.min_blade_thickness_voxels = inst.tissue.min_blade_thickness_voxels;
  o.contact_passes_per_advance = inst.tissue.contact_passes;
  // The options own copies of what their callbacks read: they may outlive the caller's scene.
  o.anchor = [anchors = inst.anchors](crms::Lattice& l) { apply_anchors(anchors, l); };
  o.configure_effects = [regions = scene.effect_regions](const crms::Lattice& l,
                                                         crms::SolverConfig& c) {
    apply_scene_effects(regions, l, c);
  };
  return o;
}

std::size_t apply_loads_and_initial_state(const Scene& scene, crms::Solver& solver) {
  const crms::Lattice& lattice = solver.lattice();
  std::vector<std::int64_t> nodes;
  std::vector<Vec3f> forces;
  for (const SceneLoad& load : scene.loads)
    for (std::int64_t n = 0; n < lattice.node_count(); ++n)
      if (lattice.alive(n) &&
          inside(lattice.geometry().rest_position(n), load.min_mm, load.max_mm)) {
        nodes.push_back(n);
        forces.push_back(to_float(load.force_un));
      }
  if (!nodes.empty()) solver.set_external_forces(nodes, forces);
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
  }
  return nodes.size();
}

nlohmann::json poisson_json(const Scene& scene, std::size_t index, const crms::Solver& solver) {
  const SceneInstance& inst = scene.instances.at(index);
  const double cap = inst.integration.poisson_ratio_cap;
  const std::vector<crms::Material>& run = solver.config().materials;
  auto entry = [&](const std::string& name, double material, const crms::Material& m) {
    return nlohmann::json{{"name", name},
                          {"material", material},
                          {"runs_with", m.poisson_ratio},
                          {"lame_lambda_pa", m.lame_lambda_pa()},
                          {"volumetric_term", m.poisson_ratio > 0}};
  };
  nlohmann::json j = entry(inst.material_id.empty() ? "inline" : inst.material_id,
                           inst.material.poisson_ratio, run.at(0));
  j["cap"] = cap >= 0 ? nlohmann::json(cap) : nlohmann::json(nullptr);
  nlohmann::json palette = nlohmann::json::array();
  for (std::size_t e = 1; e < run.size(); ++e) {
    const std::size_t k = e - 1;
    palette.push_back(entry(k < scene.effect_regions.palette_names.size()
                                ? scene.effect_regions.palette_names[k]
                                : "entry " + std::to_string(e),
                            k < scene.effect_regions.palette_materials.size()
                                ? scene.effect_regions.palette_materials[k].poisson_ratio
                                : run[e].poisson_ratio,
                            run[e]));
  }
  j["palette"] = palette;
  return j;
}

std::string poisson_line(const nlohmann::json& p) {
  auto g = [](double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", v);
    return std::string(b);
  };
  auto one = [&](const nlohmann::json& e) {
    const double run = e.value("runs_with", 0.0), material = e.value("material", 0.0);
    std::string t = "ν = " + g(run);
    if (run != material) t += " (material " + g(material) + ", capped by solver.poisson_ratio_cap)";
    t += run > 0 ? ", volumetric term λ = " + g(e.value("lame_lambda_pa", 0.0) * 1e-3) + " kPa"
                 : " (the springs alone, no volumetric term)";
    return t;
  };
  std::string line = "Poisson ratio: " + one(p);
  for (const nlohmann::json& e : p.value("palette", nlohmann::json::array()))
    line += "; palette " + e.value("name", std::string("?")) + ": " + one(e);
  return line;
}

TissueInstance build_tissue_instance(const Scene& scene, std::size_t index) {
  Stopwatch clock;
  TissueInstance r;
  r.index = index;
  r.name = scene.instances.at(index).name;
  VoxelVolume volume = instance_tissue_volume(scene, index, &r.patient_frame);
  r.volume_geometry = volume.geometry();
  try {
    interaction::TissueModelOptions options =
        instance_model_options(scene, index, r.volume_geometry);
    r.model = std::make_unique<interaction::TissueModel>(std::move(volume), std::move(options));
  } catch (const Error& e) {
    throw Error(scene.instance_prefix(index) + e.what());
  }
  const std::size_t loaded = apply_loads_and_initial_state(scene, r.model->solver());
  if (loaded > 0 || scene.initial.scaled) r.model->couple();
  const crms::Solver& solver = r.model->solver();
  std::int64_t fixed = 0;
  for (std::int64_t n = 0; n < solver.lattice().node_count(); ++n)
    fixed += solver.lattice().alive(n) && solver.lattice().fixed(n);
  const Vec3d g = solver.config().gravity;
  r.summary = {{"instance", r.name},
               {"alive_nodes", solver.lattice().alive_count()},
               {"node_spacing_mm", nlohmann::json::array({solver.lattice().geometry().spacing.x,
                                                          solver.lattice().geometry().spacing.y,
                                                          solver.lattice().geometry().spacing.z})},
               {"fixed_nodes", fixed},
               {"loaded_nodes", loaded},
               {"elastic_nj_at_start", solver.energy().elastic_nj},
               {"dt_s", r.model->dt()},
               {"time_step", time_step_json(r.model->time_step_choice())},
               {"integrator", crms::to_string(solver.config().integrator)},
               {"backend", solver.backend_name()},
               {"gravity_mm_s2", nlohmann::json::array({g.x, g.y, g.z})},
               {"effects_active", solver.active_effects()},
               {"volume_term_folded", solver.volume_term_folded()},
               {"poisson_ratio", poisson_json(scene, index, solver)},
               {"removal", removal_summary(scene.instances.at(index).tissue, r.model->options())},
               {"tissue_labels_voxels", label_histogram(r.model->volume())}};
  if (!scene.placement_warnings.empty()) {
    r.summary["placement_warnings"] = scene.placement_warnings;
    if (index == 0)
      for (const std::string& w : scene.placement_warnings)
        std::fprintf(stderr, "tsf: warning: %s\n", w.c_str());
  }
  r.setup_s = clock.seconds();
  return r;
}

LatticeRun build_lattice_run(const Scene& scene) {
  Stopwatch clock;
  const std::size_t index = 0;
  const SceneInstance& inst = scene.instances.at(index);
  crms::Lattice lattice;
  VolumeGeometry frame;  // identity for a box
  if (inst.lattice.source == SceneLattice::Source::kBox) {
    lattice = box_lattice(scene, inst);
  } else {
    const VoxelVolume volume = instance_tissue_volume(scene, index);
    frame = volume.geometry();
    const interaction::TissueModelOptions o =
        instance_model_options(scene, index, volume.geometry());
    lattice = crms::build_lattice_from_volume(volume, o.lattice);
  }
  apply_anchors(inst.anchors, lattice);
  LatticeRun run;
  for (std::int64_t n = 0; n < lattice.node_count(); ++n)
    run.fixed_nodes += lattice.alive(n) && lattice.fixed(n);
  crms::SolverConfig config = instance_solver_config(scene, index);
  config.gravity = frame.direction_to_tissue(config.gravity);  // patient (LPS) → tissue
  apply_scene_effects(scene.effect_regions, lattice, config);
  try {
    run.solver = std::make_unique<crms::Solver>(std::move(lattice), config);
  } catch (const Error& e) {
    throw Error(scene.instance_prefix(index) + e.what());
  }
  try {
    run.dt_choice =
        crms::choose_time_step(inst.integration.dt_s, inst.integration.dt_safety, *run.solver);
  } catch (const Error& e) {
    throw Error(scene.file.string() + ": " + e.what());
  }
  run.dt_s = run.dt_choice.dt_s;
  apply_loads_and_initial_state(scene, *run.solver);
  run.setup_s = clock.seconds();
  return run;
}

nlohmann::json time_step_json(const crms::TimeStepChoice& c) {
  return {{"dt_s", c.dt_s},
          {"stable_estimate_s", c.stable_s},
          {"dt_over_estimate", c.ratio()},
          {"automatic", c.automatic},
          {"safety", c.safety},
          {"stability_limited", c.limited},
          {"how", c.how}};
}

nlohmann::json stability_json(const crms::StabilitySummary& s) {
  return {{"verdict", crms::to_string(s.verdict)},
          {"headline", s.headline()},
          {"reason", s.reason},
          {"advice", s.advice},
          {"allowed_by_scene", s.allowed},
          {"energy_nj",
           {{"start", s.energy_start_nj},
            {"end", s.energy_end_nj},
            {"work_in", s.work_in_nj},
            {"dissipated", s.dissipated_nj},
            {"largest_unexplained_gain", s.max_gain_nj},
            {"scale", s.energy_scale_nj},
            {"gain_fraction", s.gain_fraction},
            {"balance_checked", s.energy_balance_checked},
            {"kinetic_drag_estimate", s.kinetic_drag_nj}}},
          {"velocity_limit",
           {{"mm_s", s.velocity_limit_mm_s},
            {"max_fraction_at_limit", s.max_limit_fraction},
            {"end_fraction_at_limit", s.end_limit_fraction},
            {"steps_at_limit", s.steps_at_limit},
            {"longest_steps_at_limit", s.longest_at_limit}}},
          {"period2",
           {{"max_score", s.max_period2},
            {"end_score", s.end_period2},
            {"samples_held_and_flipping", s.held_flipping_samples}}},
          {"non_finite", s.non_finite ? nlohmann::json(*s.non_finite) : nlohmann::json(nullptr)},
          {"samples", s.samples},
          {"steps", s.steps},
          {"dt_max_over_estimate", s.dt_max_over_stable}};
}

void require_stable_enough(const crms::StabilitySummary& s, const std::string& who) {
  if (s.verdict == crms::StabilityVerdict::kUnstable && !s.allowed)
    throw Error((who.empty() ? "" : who + ": ") + s.headline() +
                " (set stability.allow_unstable: true to exit 0 anyway)");
}

}  // namespace tsf::app
