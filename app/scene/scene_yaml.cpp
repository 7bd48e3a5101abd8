// Strict YAML reading of a tsf scene (scene.h). yaml-cpp stays in app/: tissue/ never sees it.
#include <yaml-cpp/yaml.h>

#include <cctype>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>
#include <string>

#include "run/material_library.h"
#include "scene/scene.h"
#include "tsf/common/error.h"
#include "tsf/volume/tissue_labels.h"
#include "tsf/volume/tool_shapes.h"
#include "yaml_field.h"

namespace tsf::app {
namespace {

using Field = YamlField;

// `volume_from_pipeline`: the scene has a `pipeline:` section (tsf run, app/run/run_spec.h),
// which writes the volume and fills lattice.volume in.
void read_lattice(const Field& f, const std::filesystem::path& folder, SceneLattice& l,
                  bool volume_from_pipeline) {
  if (!f.defined()) f.fail("is required");
  f.expect_keys({"source", "size", "spacing", "origin", "volume", "node_spacing_voxels",
                 "occupancy_threshold", "mass_floor", "crop", "labels"});
  l.source = f["source"].choice(
      SceneLattice::Source::kBox,
      {{"box", SceneLattice::Source::kBox}, {"volume", SceneLattice::Source::kVolume}});
  if (l.source == SceneLattice::Source::kBox) {
    for (const char* k :
         {"volume", "node_spacing_voxels", "occupancy_threshold", "mass_floor", "crop", "labels"})
      if (f[k].defined()) f[k].fail("only for source: volume");
    if (!f["size"].defined()) f["size"].fail("is required for source: box");
    l.size_mm = f["size"].vec3({});
    for (int a = 0; a < 3; ++a)
      if (!(l.size_mm[a] > 0 && l.size_mm[a] <= 1e4))
        f["size"].fail("each size must be in (0, 1e4] mm");
    l.spacing_mm = f["spacing"].number(1.0, 0.0, 1e3, true);
    l.min_corner_mm = f["origin"].vec3({0, 0, 0});
    const double cells =
        l.size_mm.x / l.spacing_mm * l.size_mm.y / l.spacing_mm * l.size_mm.z / l.spacing_mm;
    if (cells > 2e9) f["spacing"].fail("the box would need more than 2e9 nodes");
  } else {
    for (const char* k : {"size", "spacing", "origin"})
      if (f[k].defined()) f[k].fail("only for source: box");
    if (volume_from_pipeline && f["volume"].defined())
      f["volume"].fail("comes from the pipeline section's segmentation: leave it out");
    if (!volume_from_pipeline && !f["volume"].defined())
      f["volume"].fail("is required for source: volume");
    if (f["volume"].defined()) {
      l.volume = f["volume"].text();
      if (l.volume.is_relative()) l.volume = folder / l.volume;
    }
    l.node_spacing_voxels = static_cast<int>(f["node_spacing_voxels"].integer(2, 1, 64));
    l.occupancy_threshold = f["occupancy_threshold"].number(0.125, 0.0, 1.0, true);
    l.mass_floor = f["mass_floor"].number(0.5, 0.0, 1.0);
    const Field crop = f["crop"];
    if (crop.defined()) {
      crop.expect_keys({"min", "max"});
      if (!crop["min"].defined() || !crop["max"].defined()) crop.fail("needs min and max (mm)");
      l.cropped = true;
      l.crop_min_mm = crop["min"].vec3({});
      l.crop_max_mm = crop["max"].vec3({});
      for (int a = 0; a < 3; ++a)
        if (!(l.crop_max_mm[a] > l.crop_min_mm[a]))
          crop["max"].fail("must exceed min on every axis");
    }
    const Field labels = f["labels"];
    if (labels.defined()) {
      if (!labels.node().IsSequence() || labels.size() == 0)
        labels.fail("expected a non-empty list of tissue label names or numbers");
      for (std::size_t i = 0; i < labels.size(); ++i) {
        const std::uint8_t label = parse_label(labels.at(i));
        for (std::uint8_t other : l.labels)
          if (other == label) labels.at(i).fail("is listed twice");
        l.labels.push_back(label);
      }
    }
  }
}

/// The material library a scene's library ids refer to: pipeline.material_library, else the
/// bundled materials/tissues.yaml (read once, on the first id).
struct LibraryRef {
  std::filesystem::path path;
  std::optional<MaterialLibrary> library;
  const MaterialLibrary& get() {
    if (!library)
      library = read_material_library(path.empty() ? default_material_library_path() : path);
    return *library;
  }
};

/// `material:` inline (a map of E, G, η, ρ) or a library id (a string); returns the id or "".
std::string read_material(const Field& f, crms::Material& m, LibraryRef& library) {
  if (!f.defined()) f.fail("is required (a material library id or an inline material)");
  if (f.node().IsScalar()) {
    const std::string id = f.text();
    const MaterialLibrary& lib = library.get();
    const LibraryMaterial* found = lib.find(id);
    if (!found) {
      std::string known;
      for (const auto& k : lib.materials) known += (known.empty() ? "" : ", ") + k.id;
      f.fail("no material '" + id + "' in " + lib.file.string() + " (known: " + known + ")");
    }
    m = found->crms_material();
    return id;
  }
  f.expect_keys({"youngs_modulus", "shear_modulus", "viscosity", "density"});
  if (!f["youngs_modulus"].defined()) f["youngs_modulus"].fail("is required (Pa)");
  m.youngs_modulus_pa = f["youngs_modulus"].number(0, 1.0, 1e11);
  m.shear_modulus_pa = f["shear_modulus"].is_auto()
                           ? 0.0
                           : f["shear_modulus"].number(0.0, 0.0, 10.0 * m.youngs_modulus_pa);
  m.viscosity_pa_s = f["viscosity"].number(0.0, 0.0, 1e6);
  m.density_g_per_mm3 = f["density"].number(1e-3, 1e-6, 1e-1);
  return "";
}

void read_solver(const Field& f, Scene& s) {
  f.expect_keys({"integrator", "backend", "angular_form", "angular_reactions", "dt", "dt_safety",
                 "steps", "report_every", "steps_per_graph", "newton_iterations",
                 "newton_tolerance"});
  using crms::AngularForm;
  using crms::AngularReactions;
  using crms::Backend;
  using crms::Integrator;
  crms::SolverConfig& c = s.solver;
  c.integrator = f["integrator"].choice(Integrator::kSymplecticEuler,
                                        {{"explicit-euler", Integrator::kExplicitEuler},
                                         {"symplectic-euler", Integrator::kSymplecticEuler},
                                         {"implicit-euler", Integrator::kImplicitEuler}});
  c.backend = f["backend"].choice(
      Backend::kAuto, {{"auto", Backend::kAuto}, {"cpu", Backend::kCpu}, {"cuda", Backend::kCuda}});
  c.angular_form = f["angular_form"].choice(
      AngularForm::kExact, {{"exact", AngularForm::kExact}, {"cosine", AngularForm::kCosine}});
  c.angular_reactions = f["angular_reactions"].choice(
      AngularReactions::kSymmetric,
      {{"gather", AngularReactions::kGather}, {"symmetric", AngularReactions::kSymmetric}});
  s.dt_s = f["dt"].is_auto() ? 0.0 : f["dt"].number(0.0, 0.0, 1.0, true);
  s.dt_safety = f["dt_safety"].number(0.9, 0.0, 10.0, true);
  s.steps = f["steps"].integer(1000, 0, 1'000'000'000'000);
  s.report_every = f["report_every"].integer(100, 1, 1'000'000'000);
  c.cuda_steps_per_graph = static_cast<int>(f["steps_per_graph"].integer(64, 2, 4096));
  if (c.cuda_steps_per_graph % 2) f["steps_per_graph"].fail("expected an even number");
  c.implicit_newton_iterations = static_cast<int>(f["newton_iterations"].integer(8, 1, 50));
  c.implicit_tolerance = f["newton_tolerance"].number(1e-7, 0.0, 1.0);
  if (c.integrator == Integrator::kImplicitEuler && c.backend == Backend::kCuda)
    f["backend"].fail("implicit-euler runs on the CPU only: use cpu or auto");
}

void read_stability(const Field& f, crms::StabilityControls& st) {
  f.expect_keys({"kinetic_damping", "velocity_limit", "velocity_limit_fraction"});
  st.kinetic_damping = f["kinetic_damping"].number(0.0, 0.0, 1e3);
  st.velocity_limit = (!f["velocity_limit"].defined() || f["velocity_limit"].is_auto())
                          ? -1.0
                          : f["velocity_limit"].number(0.0, 0.0, 1e9);
  st.velocity_limit_auto_fraction = f["velocity_limit_fraction"].number(0.25, 0.0, 10.0, true);
}

void read_anchors(const Field& f, std::vector<SceneAnchor>& anchors) {
  if (!f.defined()) return;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const Field a = f.at(i);
    a.expect_keys({"box", "plane", "labels"});
    const int kinds = a["box"].defined() + a["plane"].defined() + a["labels"].defined();
    if (kinds != 1) a.fail("expected exactly one of box, plane, labels");
    SceneAnchor anchor;
    if (a["box"].defined()) {
      anchor.kind = SceneAnchor::Kind::kBox;
      a["box"].expect_keys({"min", "max"});
      anchor.min_mm = a["box"]["min"].vec3({});
      anchor.max_mm = a["box"]["max"].vec3({});
      if (!a["box"]["min"].defined() || !a["box"]["max"].defined())
        a["box"].fail("needs min and max");
    } else if (a["plane"].defined()) {
      anchor.kind = SceneAnchor::Kind::kPlane;
      a["plane"].expect_keys({"point", "normal"});
      anchor.point_mm = a["plane"]["point"].vec3({0, 0, 0});
      anchor.normal = a["plane"]["normal"].vec3({});
      if (!(length_squared(anchor.normal) > 0)) a["plane"]["normal"].fail("must not be zero");
    } else {
      anchor.kind = SceneAnchor::Kind::kLabels;
      const Field labels = a["labels"];
      for (std::size_t l = 0; l < labels.size(); ++l)
        anchor.labels.push_back(parse_label(labels.at(l)));
    }
    anchors.push_back(anchor);
  }
}

void read_loads(const Field& f, std::vector<SceneLoad>& loads) {
  if (!f.defined()) return;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const Field l = f.at(i);
    l.expect_keys({"box", "force"});
    l["box"].expect_keys({"min", "max"});
    if (!l["box"]["min"].defined() || !l["box"]["max"].defined() || !l["force"].defined())
      l.fail("needs box (min, max) and force");
    SceneLoad load;
    load.min_mm = l["box"]["min"].vec3({});
    load.max_mm = l["box"]["max"].vec3({});
    load.force_un = l["force"].vec3({});
    loads.push_back(load);
  }
}

void read_tissue(const Field& f, SceneTissue& t) {
  if (!f.defined()) return;
  t.present = true;
  f.expect_keys({"voxels_per_node", "iso", "merge_epsilon", "coupler", "deletion_threshold",
                 "min_blade_thickness_voxels", "removal", "contact_passes"});
  t.voxels_per_node = static_cast<int>(f["voxels_per_node"].integer(2, 1, 16));
  t.iso = f["iso"].number(0.5, 0.0, 1.0, true);
  t.merge_epsilon = f["merge_epsilon"].number(0.1, 0.0, 0.49);
  t.coupler = f["coupler"].choice(coupler::CouplerMode::kTrilinear,
                                  {{"trilinear", coupler::CouplerMode::kTrilinear},
                                   {"local-frame", coupler::CouplerMode::kLocalFrame}});
  t.deletion_threshold = f["deletion_threshold"].number(0.125, 0.0, 1.0, true);
  t.min_blade_thickness_voxels = f["min_blade_thickness_voxels"].number(2.0, 0.0, 100.0);
  const Field r = f["removal"];
  r.expect_keys({"strength", "falloff"});
  t.removal_strength = r["strength"].number(1.0, 0.0, 1.0);
  t.falloff_mm = r["falloff"].is_auto() ? -1.0 : r["falloff"].number(-1.0, 0.0, 100.0);
  t.contact_passes = static_cast<int>(f["contact_passes"].integer(2, 1, 1000));
}

Rotation read_rotation(const Field& f) {
  if (!f.defined()) return {};
  f.expect_keys({"axis", "angle_deg", "quaternion"});
  if (f["quaternion"].defined()) {
    if (f["axis"].defined() || f["angle_deg"].defined())
      f.fail("give either quaternion or axis + angle_deg, not both");
    const Field q = f["quaternion"];
    if (q.size() != 4) q.fail("expected a list of 4 numbers [w, x, y, z]");
    const Rotation r{q.at(0).number(), q.at(1).number(), q.at(2).number(), q.at(3).number()};
    if (!(r.w * r.w + r.x * r.x + r.y * r.y + r.z * r.z > 1e-12)) q.fail("must not be zero");
    return r.normalized();
  }
  if (!f["axis"].defined() || !f["angle_deg"].defined())
    f.fail("needs axis and angle_deg (or quaternion)");
  const Vec3d axis = f["axis"].vec3({});
  if (!(length_squared(axis) > 0)) f["axis"].fail("must not be zero");
  const double angle = f["angle_deg"].number(0.0, -36000.0, 36000.0);
  return Rotation::about_axis(axis, angle * 3.14159265358979323846 / 180.0);
}

ToolPose read_pose(const Field& f) {
  if (!f.defined()) f.fail("is required (position, optional rotation)");
  f.expect_keys({"position", "rotation"});
  if (!f["position"].defined()) f["position"].fail("is required ([x, y, z] mm)");
  return {f["position"].vec3({}), read_rotation(f["rotation"])};
}

interaction::ToolMode read_mode(const Field& f) {
  return f.choice(interaction::ToolMode::kPress, {{"press", interaction::ToolMode::kPress},
                                                  {"ablate", interaction::ToolMode::kAblate},
                                                  {"cut", interaction::ToolMode::kCut},
                                                  {"idle", interaction::ToolMode::kIdle}});
}

void read_tools(const Field& f, std::vector<SceneTool>& tools) {
  if (!f.defined()) return;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const Field t = f.at(i);
    t.expect_keys({"name", "shape", "radius", "length", "size"});
    SceneTool tool;
    if (!t["name"].defined()) t["name"].fail("is required");
    tool.name = t["name"].text();
    for (const SceneTool& other : tools)
      if (other.name == tool.name) t["name"].fail("'" + tool.name + "' is used twice");
    using collision::ToolShape;
    if (!t["shape"].defined()) t["shape"].fail("is required (sphere, capsule or blade)");
    tool.tool.shape = t["shape"].choice(ToolShape::kSphere, {{"sphere", ToolShape::kSphere},
                                                             {"capsule", ToolShape::kCapsule},
                                                             {"blade", ToolShape::kBlade}});
    const bool round = tool.tool.shape != ToolShape::kBlade;
    if (round) {
      if (!t["radius"].defined()) t["radius"].fail("is required for a sphere or capsule (mm)");
      if (t["size"].defined()) t["size"].fail("only for a blade");
      tool.tool.radius_mm = t["radius"].number(1.0, 0.0, 1e3, true);
    } else {
      if (t["radius"].defined()) t["radius"].fail("not for a blade (use size)");
      if (!t["size"].defined())
        t["size"].fail("is required for a blade: [length, depth, thickness] mm");
      const Vec3d size = t["size"].vec3({});
      for (int a = 0; a < 3; ++a)
        if (!(size[a] > 0 && size[a] <= 2e3)) t["size"].fail("each must be in (0, 2000] mm");
      tool.tool.half_extents_mm = size * 0.5;
    }
    if (tool.tool.shape == ToolShape::kCapsule) {
      if (!t["length"].defined()) t["length"].fail("is required for a capsule (its axis, mm)");
      tool.tool.half_length_mm = 0.5 * t["length"].number(0.0, 0.0, 2e3);
    } else if (t["length"].defined()) {
      t["length"].fail("only for a capsule");
    }
    tools.push_back(tool);
  }
}

void read_script(const Field& f, const std::vector<SceneTool>& tools, SceneScript& s) {
  if (!f.defined()) return;
  f.expect_keys({"frame_rate", "duration", "trajectories", "events"});
  s.frame_rate_hz = f["frame_rate"].number(60.0, 0.0, 1e4, true);
  s.duration_s = f["duration"].defined() ? f["duration"].number(0.0, 0.0, 1e5) : -1.0;
  auto tool_of = [&](const Field& name) -> const SceneTool& {
    if (!name.defined()) name.fail("is required (a name from tools)");
    const std::string n = name.text();
    for (const SceneTool& t : tools)
      if (t.name == n) return t;
    name.fail("no tool named '" + n + "' in tools");
  };
  const Field trs = f["trajectories"];
  if (trs.defined()) {
    for (std::size_t i = 0; i < trs.size(); ++i) {
      const Field tr = trs.at(i);
      tr.expect_keys({"tool", "keyframes"});
      SceneTrajectory out;
      const SceneTool& tool = tool_of(tr["tool"]);
      out.tool = tool.name;
      const Field keys = tr["keyframes"];
      if (!keys.defined() || keys.size() == 0) keys.fail("needs at least one keyframe");
      for (std::size_t k = 0; k < keys.size(); ++k) {
        const Field key = keys.at(k);
        key.expect_keys({"time", "position", "rotation", "mode"});
        interaction::Keyframe kf;
        if (!key["time"].defined()) key["time"].fail("is required (s)");
        kf.time_s = key["time"].number(0.0, 0.0, 1e5);
        if (!out.keyframes.empty() && !(kf.time_s > out.keyframes.back().time_s))
          key["time"].fail("must be later than the previous keyframe's");
        if (!key["position"].defined()) key["position"].fail("is required ([x, y, z] mm)");
        kf.pose.position = key["position"].vec3({});
        kf.pose.orientation = read_rotation(key["rotation"]);
        if (!key["mode"].defined()) key["mode"].fail("is required (press, ablate, cut or idle)");
        kf.mode = read_mode(key["mode"]);
        if (!tool.tool.supports(kf.mode))
          key["mode"].fail(std::string("tool '") + tool.name + "' (a " +
                           interaction::to_string(tool.tool.shape) + ") cannot " +
                           interaction::to_string(kf.mode) +
                           " (ablate: sphere or capsule; cut: blade)");
        out.keyframes.push_back(kf);
      }
      // One tool at a time: trajectories may not overlap in time.
      for (std::size_t j = 0; j < s.trajectories.size(); ++j) {
        const auto& o = s.trajectories[j].keyframes;
        if (out.keyframes.front().time_s <= o.back().time_s &&
            o.front().time_s <= out.keyframes.back().time_s)
          tr.fail("overlaps trajectories[" + std::to_string(j) +
                  "] in time: one tool moves at a time");
      }
      s.trajectories.push_back(out);
    }
  }
  const Field evs = f["events"];
  if (evs.defined()) {
    for (std::size_t i = 0; i < evs.size(); ++i) {
      const Field ev = evs.at(i);
      ev.expect_keys({"time", "tool", "mode", "from", "to"});
      SceneEvent e;
      if (!ev["time"].defined()) ev["time"].fail("is required (s)");
      e.time_s = ev["time"].number(0.0, 0.0, 1e5);
      const SceneTool& tool = tool_of(ev["tool"]);
      e.tool = tool.name;
      if (!ev["mode"].defined()) ev["mode"].fail("is required (ablate or cut)");
      e.mode = read_mode(ev["mode"]);
      if (e.mode != interaction::ToolMode::kAblate && e.mode != interaction::ToolMode::kCut)
        ev["mode"].fail("an event ablates or cuts");
      if (!tool.tool.supports(e.mode))
        ev["mode"].fail(std::string("tool '") + tool.name + "' cannot " +
                        interaction::to_string(e.mode));
      e.from = read_pose(ev["from"]);
      e.to = ev["to"].defined() ? read_pose(ev["to"]) : e.from;
      s.events.push_back(e);
    }
  }
}

void read_outputs(const Field& f, const std::filesystem::path& folder, SceneOutputs& o) {
  if (!f.defined()) return;
  f.expect_keys({"mesh", "rest_mesh", "report", "states", "states_every"});
  auto path = [&](const Field& p) -> std::filesystem::path {
    if (!p.defined()) return {};
    std::filesystem::path out = p.text();
    if (out.is_relative()) out = folder / out;
    return out;
  };
  o.mesh = path(f["mesh"]);
  o.rest_mesh = path(f["rest_mesh"]);
  o.report = path(f["report"]);
  o.states = path(f["states"]);
  o.states_every = f["states_every"].integer(10, 1, 1'000'000'000);
  if (f["states"].defined() && std::filesystem::path(f["states"].text()).extension() != ".tsfmesh")
    f["states"].fail("expected a .tsfmesh file name");
  for (const char* k : {"mesh", "rest_mesh"})
    if (f[k].defined() && std::filesystem::path(f[k].text()).extension() != ".ply")
      f[k].fail("expected a .ply file name");
  if (f["report"].defined() && std::filesystem::path(f["report"].text()).extension() != ".json")
    f["report"].fail("expected a .json file name");
}

/// `effects:` (tsf/crms/effects_config.h): a listed effect is on unless it says `enabled: false`.
void read_effects(const Field& f, crms::EffectsConfig& e) {
  if (!f.defined()) return;
  // palette and animation need the lattice: read_scene_effects (scene_effects.h).
  f.expect_keys({"plasticity", "anisotropy", "fluid", "tearing", "palette", "animation"});
  if (const Field p = f["plasticity"]; p.defined()) {
    p.expect_keys({"enabled", "yield_strain", "creep_rate", "recovery_rate"});
    e.plasticity.enabled = p["enabled"].boolean(true);
    e.plasticity.yield_strain = p["yield_strain"].number(0.05, 0.0, 10.0, true);
    e.plasticity.creep_rate = p["creep_rate"].number(200, 0.0, 1e6);
    e.plasticity.recovery_rate = p["recovery_rate"].number(0.0, 0.0, 1e6);
  }
  if (const Field a = f["anisotropy"]; a.defined()) {
    a.expect_keys({"enabled", "axis", "stiffness_factor"});
    e.anisotropy.enabled = a["enabled"].boolean(true);
    e.anisotropy.axis = a["axis"].vec3({1, 0, 0});
    if (!(length_squared(e.anisotropy.axis) > 0)) a["axis"].fail("must not be zero");
    e.anisotropy.stiffness_factor = a["stiffness_factor"].number(2.0, 0.01, 100.0);
  }
  if (const Field fl = f["fluid"]; fl.defined()) {
    fl.expect_keys({"enabled", "bulk_modulus", "diffusion_rate"});
    e.fluid.enabled = fl["enabled"].boolean(true);
    e.fluid.bulk_modulus_pa = fl["bulk_modulus"].number(5e3, 1.0, 1e11);
    e.fluid.diffusion_rate = fl["diffusion_rate"].number(0.0, 0.0, 1e6);
  }
  if (const Field t = f["tearing"]; t.defined()) {
    t.expect_keys({"enabled", "strain_threshold", "node_force_threshold"});
    e.tearing.enabled = t["enabled"].boolean(true);
    e.tearing.strain_threshold = t["strain_threshold"].number(0.5, 0.0, 100.0, true);
    e.tearing.node_force_threshold_un = t["node_force_threshold"].number(0.0, 0.0, 1e12);
  }
}

/// Output file names are built from instance names: letters, digits, '-' and '_' only.
bool is_file_name_safe(const std::string& n) {
  if (n.empty() || n.size() > 64) return false;
  for (char c : n)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) return false;
  return true;
}

/// The scene-wide time integration an instance starts from.
void inherit_integration(const Scene& s, SceneInstance& inst) {
  inst.integrator = s.solver.integrator;
  inst.dt_s = s.dt_s;
  inst.dt_safety = s.dt_safety;
  inst.newton_iterations = s.solver.implicit_newton_iterations;
  inst.newton_tolerance = s.solver.implicit_tolerance;
}

/// `tissues[i].solver`: the instance's own integrator and step (the rest of `solver` is
/// scene-wide).
void read_instance_solver(const Field& f, const Scene& s, SceneInstance& inst) {
  if (!f.defined()) return;
  f.expect_keys({"integrator", "dt", "dt_safety", "newton_iterations", "newton_tolerance"});
  using crms::Integrator;
  inst.integrator =
      f["integrator"].choice(inst.integrator, {{"explicit-euler", Integrator::kExplicitEuler},
                                               {"symplectic-euler", Integrator::kSymplecticEuler},
                                               {"implicit-euler", Integrator::kImplicitEuler}});
  if (f["dt"].defined()) inst.dt_s = f["dt"].is_auto() ? 0.0 : f["dt"].number(0.0, 0.0, 1.0, true);
  inst.dt_safety = f["dt_safety"].number(inst.dt_safety, 0.0, 10.0, true);
  inst.newton_iterations =
      static_cast<int>(f["newton_iterations"].integer(inst.newton_iterations, 1, 50));
  inst.newton_tolerance = f["newton_tolerance"].number(inst.newton_tolerance, 0.0, 1.0);
  if (inst.integrator == Integrator::kImplicitEuler && s.solver.backend == crms::Backend::kCuda)
    f["integrator"].fail("implicit-euler runs on the CPU only: set solver.backend to cpu or auto");
}

/// One entry of `tissues:`. `s` holds the scene-wide solver and effects read so far.
SceneInstance read_instance(const Field& f, const std::filesystem::path& folder,
                            bool volume_from_pipeline, const Scene& s, LibraryRef& library) {
  const crms::EffectsConfig& default_effects = s.solver.effects;
  f.expect_keys({"name", "lattice", "material", "anchors", "tissue", "effects", "solver"});
  SceneInstance inst;
  inherit_integration(s, inst);
  read_instance_solver(f["solver"], s, inst);
  if (!f["name"].defined()) f["name"].fail("is required (names the instance's outputs)");
  inst.name = f["name"].text();
  if (!is_file_name_safe(inst.name))
    f["name"].fail("expected 1 to 64 letters, digits, '-' or '_', got '" + inst.name + "'");
  read_lattice(f["lattice"], folder, inst.lattice, volume_from_pipeline);
  inst.material_id = read_material(f["material"], inst.material, library);
  read_anchors(f["anchors"], inst.anchors);
  read_tissue(f["tissue"], inst.tissue);
  inst.tissue.present = true;
  inst.effects = default_effects;
  if (f["effects"].defined()) {
    for (const char* k : {"palette", "animation"})
      if (f["effects"][k].defined())
        f["effects"][k].fail(
            "give it in the scene's top-level effects (it applies to every "
            "instance)");
    inst.effects = crms::EffectsConfig{};
    read_effects(f["effects"], inst.effects);
    inst.effects.animation = default_effects.animation;  // scene-wide (scene_effects.h)
  }
  return inst;
}

}  // namespace

Scene scene_for_instance(const Scene& scene, std::size_t index) {
  const SceneInstance& inst = scene.instances.at(index);
  Scene s = scene;
  s.lattice = inst.lattice;
  s.solver.materials.at(0) = inst.material;
  s.solver.effects = inst.effects;
  s.anchors = inst.anchors;
  const bool present = scene.tissue.present;
  s.tissue = inst.tissue;
  s.tissue.present = present;
  s.solver.integrator = inst.integrator;
  s.solver.implicit_newton_iterations = inst.newton_iterations;
  s.solver.implicit_tolerance = inst.newton_tolerance;
  s.dt_s = inst.dt_s;
  s.dt_safety = inst.dt_safety;
  s.instances = {inst};
  return s;
}

Scene read_scene(const std::filesystem::path& file) {
  const std::string name = file.string();
  YAML::Node root;
  try {
    root = YAML::LoadFile(name);
  } catch (const YAML::BadFile&) {
    throw Error(name + ": cannot open the scene file");
  } catch (const YAML::Exception& e) {
    throw Error(name + ": not valid YAML: " + e.what());
  }
  const Field top(root, "", name);
  if (!top.defined()) top.fail("the scene is empty");
  // `pipeline` is read by `tsf run` (app/run/run_spec.h).
  top.expect_keys({"name", "lattice", "material", "solver", "gravity", "stability", "anchors",
                   "loads", "initial", "effects", "tissue", "tools", "script", "outputs",
                   "pipeline", "tissues"});
  Scene s;
  s.file = file;
  s.name = top["name"].defined() ? top["name"].text() : file.stem().string();
  LibraryRef library;
  if (top["pipeline"]["material_library"].defined()) {
    library.path = top["pipeline"]["material_library"].text();
    if (library.path.is_relative()) library.path = file.parent_path() / library.path;
  }
  const Field tissues = top["tissues"];
  s.multi_instance = tissues.defined();
  std::string material_id;
  if (s.multi_instance) {
    // Several instances: what a single tissue says at the top level, each says for itself.
    for (const char* k : {"lattice", "material", "anchors", "tissue"})
      if (top[k].defined())
        top[k].fail("give it per instance under tissues[] (this scene has a tissues list)");
    if (top["pipeline"]["material"].defined())
      top["pipeline"]["material"].fail(
          "give each instance its material under tissues[].material (a library id or inline)");
    if (!tissues.node().IsSequence() || tissues.size() == 0)
      tissues.fail("expected a non-empty list of tissue instances");
  } else {
    read_lattice(top["lattice"], file.parent_path(), s.lattice, top["pipeline"].defined());
    // A scene whose pipeline names a library material (tsf run) may leave `material` out.
    if (top["material"].defined() || !top["pipeline"]["material"].defined())
      material_id = read_material(top["material"], s.solver.materials.at(0), library);
  }
  read_solver(top["solver"], s);
  s.solver.gravity = top["gravity"].vec3({0, 0, 0});
  if (std::sqrt(length_squared(s.solver.gravity)) > 1e7)
    top["gravity"].fail("magnitude must be at most 1e7 mm/s² (Earth: 9810)");
  read_stability(top["stability"], s.solver.stability);
  if (!s.multi_instance) read_anchors(top["anchors"], s.anchors);
  read_loads(top["loads"], s.loads);
  read_effects(top["effects"], s.solver.effects);
  read_scene_effects(top["effects"], s.effect_regions, s.solver);
  const Field init = top["initial"];
  init.expect_keys({"scale", "about"});
  if (init.defined()) {
    s.initial.scaled = true;
    s.initial.scale = init["scale"].vec3({1, 1, 1});
    for (int a = 0; a < 3; ++a)
      if (!(s.initial.scale[a] > 0.01 && s.initial.scale[a] <= 100))
        init["scale"].fail("each factor must be in (0.01, 100]");
    s.initial.about_mm = init["about"].vec3({0, 0, 0});
  }
  if (s.multi_instance) {
    for (std::size_t i = 0; i < tissues.size(); ++i) {
      SceneInstance inst =
          read_instance(tissues.at(i), file.parent_path(), top["pipeline"].defined(), s, library);
      for (const SceneInstance& other : s.instances)
        if (other.name == inst.name)
          tissues.at(i)["name"].fail("'" + inst.name + "' is used twice");
      s.instances.push_back(std::move(inst));
    }
  } else {
    read_tissue(top["tissue"], s.tissue);
  }
  if (s.effect_regions.channels_given) {
    bool volume = s.lattice.source == SceneLattice::Source::kVolume;
    for (const SceneInstance& inst : s.instances)
      volume = volume && inst.lattice.source == SceneLattice::Source::kVolume;
    if (!volume)
      top["effects"]["palette"]["channels"].fail(
          "needs lattice.source: volume (the channels are segment's material weights)");
  }
  read_tools(top["tools"], s.tools);
  read_script(top["script"], s.tools, s.script);
  read_outputs(top["outputs"], file.parent_path(), s.outputs);
  if (!s.tools.empty() || top["script"].defined() || s.multi_instance) s.tissue.present = true;
  if (top["script"].defined() && s.tools.empty()) top["script"].fail("needs tools");
  if (!s.multi_instance) {
    SceneInstance single;
    single.name = s.name;
    single.lattice = s.lattice;
    single.material = s.solver.materials.at(0);
    single.material_id = material_id;
    single.anchors = s.anchors;
    single.tissue = s.tissue;
    single.effects = s.solver.effects;
    inherit_integration(s, single);
    s.instances.push_back(std::move(single));
  }
  // Cross-field checks with the library's own messages (they name material.* fields).
  for (std::size_t i = 0; i < s.instances.size(); ++i) {
    try {
      crms::validate_solver_config(scene_for_instance(s, i).solver);
    } catch (const Error& e) {
      throw Error(name + ": " +
                  (s.multi_instance
                       ? "tissues[" + std::to_string(i) + "] (" + s.instances[i].name + "): "
                       : std::string()) +
                  e.what());
    }
  }
  // The top-level fields are the first instance's (tsf simulate, view and haptics use them).
  if (s.multi_instance) {
    Scene first = scene_for_instance(s, 0);
    first.instances = s.instances;
    s = std::move(first);
  }
  return s;
}

}  // namespace tsf::app
