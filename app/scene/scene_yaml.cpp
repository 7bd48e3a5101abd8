// Strict YAML reading of a tsf scene (scene.h). yaml-cpp stays in app/: tissue/ never sees it.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>
#include <string>

#include "run/material_library.h"
#include "scene/anatomy_placement.h"
#include "scene/mesh_file.h"
#include "scene/scene.h"
#include "scene/scene_session.h"
#include "tsf/common/error.h"
#include "tsf/volume/tissue_labels.h"
#include "tsf/volume/tool_shapes.h"
#include "yaml_field.h"

namespace tsf::app {
namespace {

using Field = YamlField;

std::string joined_names(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

/// `offset_mm: {anterior: 5, left: 2}` -> (left, anterior, superior) mm.
Vec3d read_anatomy_offset(const Field& f) {
  if (!f.defined()) return {0, 0, 0};
  f.expect_keys({"left", "right", "anterior", "posterior", "superior", "inferior"});
  Vec3d out{0, 0, 0};
  for (const char* k : {"left", "right", "anterior", "posterior", "superior", "inferior"}) {
    if (!f[k].defined()) continue;
    Vec3d dir;
    anatomy_direction(k, dir);
    out = out + dir * f[k].number(0.0, -500.0, 500.0);
  }
  for (const auto& [a, b] : {std::pair<const char*, const char*>{"left", "right"},
                             {"anterior", "posterior"},
                             {"superior", "inferior"}})
    if (f[a].defined() && f[b].defined())
      f[b].fail(std::string("give ") + a + " or " + b + ", not both");
  return out;
}

/// `{landmark: nose-tip, offset_mm: {...}}`: a position relative to the anatomy.
AnatomyPosition read_anatomy_position(const Field& f) {
  f.expect_keys({"landmark", "offset_mm"});
  if (!f["landmark"].defined())
    f["landmark"].fail("is required (one of " + joined_names(anatomy_landmark_names()) + ")");
  AnatomyPosition p;
  p.landmark = f["landmark"].text();
  const auto& names = anatomy_landmark_names();
  if (std::find(names.begin(), names.end(), p.landmark) == names.end())
    f["landmark"].fail("unknown landmark '" + p.landmark + "' (expected one of " +
                       joined_names(names) + ")");
  p.offset_mm = read_anatomy_offset(f["offset_mm"]);
  p.key = f.path();
  return p;
}

/// `position:` [x, y, z] mm (tissue space), or a position relative to the anatomy.
Vec3d read_position(const Field& f, AnatomyPosition& anatomy) {
  if (f.defined() && f.node().IsMap()) {
    anatomy = read_anatomy_position(f);
    return {0, 0, 0};
  }
  return f.vec3({});
}

/// `lattice.paint: [{label, box: {min, max}} | {label, capsule: {from, to, radius}}]`.
void read_paint(const Field& f, std::vector<ScenePaint>& paint) {
  if (!f.defined()) return;
  if (!f.node().IsSequence()) f.fail("expected a list of {label, box | capsule}");
  for (std::size_t i = 0; i < f.size(); ++i) {
    const Field p = f.at(i);
    p.expect_keys({"label", "box", "capsule"});
    ScenePaint out;
    out.label = parse_label(p["label"].required());
    if (out.label == kLabelOutside || out.label == kLabelInvalid)
      p["label"].fail("expected a tissue label (soft-tissue, mucosa, …, vessel, nerve, 1..254)");
    if (p["box"].defined() == p["capsule"].defined())
      p.fail("expected exactly one of box, capsule");
    if (const Field box = p["box"]; box.defined()) {
      box.expect_keys({"min", "max"});
      out.min_mm = box["min"].vec3();
      out.max_mm = box["max"].vec3();
      for (int a = 0; a < 3; ++a)
        if (!(out.max_mm[a] >= out.min_mm[a])) box["max"].fail("must not be below min on any axis");
    } else {
      const Field c = p["capsule"];
      c.expect_keys({"from", "to", "radius"});
      out.capsule = true;
      out.from_mm = c["from"].vec3();
      out.to_mm = c["to"].vec3();
      out.radius_mm = c["radius"].required_number(0.0, 1000.0, true);
    }
    paint.push_back(out);
  }
}

// `volume_from_pipeline`: the scene has a `pipeline:` section (tsf run, app/run/run_spec.h),
// which writes the volume and fills lattice.volume in.
void read_lattice(const Field& f, const std::filesystem::path& folder, SceneLattice& l,
                  bool volume_from_pipeline) {
  if (!f.defined()) f.fail("is required");
  f.expect_keys({"source", "size", "spacing", "origin", "volume", "node_spacing_voxels",
                 "node_spacing_mm", "occupancy_threshold", "mass_floor", "crop", "labels",
                 "paint"});
  read_paint(f["paint"], l.paint);
  l.source = f["source"].choice(
      SceneLattice::Source::kBox,
      {{"box", SceneLattice::Source::kBox}, {"volume", SceneLattice::Source::kVolume}});
  if (l.source == SceneLattice::Source::kBox) {
    for (const char* k : {"volume", "node_spacing_voxels", "node_spacing_mm", "occupancy_threshold",
                          "mass_floor", "crop", "labels"})
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
    if (f["node_spacing_voxels"].defined() && f["node_spacing_mm"].defined())
      f["node_spacing_mm"].fail("give node_spacing_mm or node_spacing_voxels, not both");
    l.node_spacing_voxels = static_cast<int>(f["node_spacing_voxels"].integer(2, 1, 64));
    l.node_spacing_mm = f["node_spacing_mm"].number(0.0, 0.0, 100.0, true);
    l.occupancy_threshold = f["occupancy_threshold"].number(0.125, 0.0, 1.0, true);
    l.mass_floor = f["mass_floor"].number(0.5, 0.0, 1.0);
    const Field crop = f["crop"];
    if (crop.defined() && crop["region"].defined()) {
      crop.expect_keys({"region", "include", "margin_mm"});
      l.crop_region = crop["region"].text();
      const auto& regions = anatomy_region_names();
      if (std::find(regions.begin(), regions.end(), l.crop_region) == regions.end())
        crop["region"].fail("unknown region '" + l.crop_region + "' (expected one of " +
                            joined_names(regions) + ")");
      const Field include = crop["include"];
      const auto& landmarks = anatomy_landmark_names();
      for (std::size_t i = 0; include.defined() && i < include.size(); ++i) {
        const std::string n = include.at(i).text();
        if (std::find(landmarks.begin(), landmarks.end(), n) == landmarks.end())
          include.at(i).fail("unknown landmark '" + n + "' (expected one of " +
                             joined_names(landmarks) + ")");
        l.crop_include.push_back(n);
      }
      l.crop_margin_mm = crop["margin_mm"].number(0.0, 0.0, 200.0);
      l.crop_key = crop["region"].path();
    } else if (crop.defined() && crop["center"].defined()) {
      crop.expect_keys({"center", "size_mm"});
      if (!crop["center"].node().IsMap())
        crop["center"].fail(
            "expected {landmark: NAME, offset_mm: {...}} (a box placed by anatomy)");
      l.crop_center = read_anatomy_position(crop["center"]);
      if (!crop["size_mm"].defined())
        crop["size_mm"].fail("is required: [left-right, anterior-posterior, superior-inferior] mm");
      l.crop_size_mm = crop["size_mm"].vec3({});
      for (int a = 0; a < 3; ++a)
        if (!(l.crop_size_mm[a] > 0 && l.crop_size_mm[a] <= 1000))
          crop["size_mm"].fail("each extent must be in (0, 1000] mm");
      l.crop_key = crop["center"].path();
    } else if (crop.defined()) {
      crop.expect_keys({"min", "max", "region", "include", "margin_mm", "center", "size_mm"});
      if (!crop["min"].defined() || !crop["max"].defined())
        crop.fail(
            "needs min and max (mm), a region (an anatomy region and margin_mm), or a center "
            "placed by anatomy and size_mm");
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

/// The library material `id` that `f` names; the error names the key, the library and the ids.
const LibraryMaterial& library_material(const Field& f, const std::string& id,
                                        LibraryRef& library) {
  const MaterialLibrary& lib = library.get();
  if (const LibraryMaterial* found = lib.find(id)) return *found;
  std::string known;
  for (const auto& k : lib.materials) known += (known.empty() ? "" : ", ") + k.id;
  f.fail("no material '" + id + "' in " + lib.file.string() + " (known: " + known + ")");
}

/// `material:` inline (a map of E, G, η, ρ) or a library id (a string); returns the id or "".
std::string read_material(const Field& f, crms::Material& m, LibraryRef& library) {
  if (!f.defined()) f.fail("is required (a material library id or an inline material)");
  if (f.node().IsScalar()) {
    const LibraryMaterial found = library_material(f, f.text(), library);
    m = found.crms_material();
    return found.id;
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

crms::Integrator read_integrator(const Field& f, crms::Integrator fallback) {
  using crms::Integrator;
  return f.choice(fallback, {{"explicit-euler", Integrator::kExplicitEuler},
                             {"symplectic-euler", Integrator::kSymplecticEuler},
                             {"implicit-euler", Integrator::kImplicitEuler}});
}

/// Integration keys (`solver.integrator`, `dt`, `dt_safety`, `newton_*`): the scene's default, or
/// an instance's own under `tissues[i].solver` (starting from the scene's).
void read_integration(const Field& f, SceneIntegration& in, crms::Backend backend) {
  in.integrator = read_integrator(f["integrator"], in.integrator);
  if (f["dt"].defined()) in.dt_s = f["dt"].is_auto() ? 0.0 : f["dt"].number(0.0, 0.0, 1.0, true);
  in.dt_safety = f["dt_safety"].number(in.dt_safety, 0.0, 10.0, true);
  in.newton_iterations =
      static_cast<int>(f["newton_iterations"].integer(in.newton_iterations, 1, 50));
  in.newton_tolerance = f["newton_tolerance"].number(in.newton_tolerance, 0.0, 1.0);
  if (in.integrator == crms::Integrator::kImplicitEuler && backend == crms::Backend::kCuda)
    f["integrator"].fail("implicit-euler runs on the CPU only: set solver.backend to cpu or auto");
}

/// `solver:` — the scene-wide settings into s.solver, the default integration into `integration`.
void read_solver(const Field& f, Scene& s, SceneIntegration& integration) {
  f.expect_keys({"integrator", "backend", "angular_form", "angular_reactions", "dt", "dt_safety",
                 "steps", "report_every", "steps_per_graph", "newton_iterations",
                 "newton_tolerance"});
  using crms::AngularForm;
  using crms::AngularReactions;
  using crms::Backend;
  crms::SolverConfig& c = s.solver;
  c.backend = f["backend"].choice(
      Backend::kAuto, {{"auto", Backend::kAuto}, {"cpu", Backend::kCpu}, {"cuda", Backend::kCuda}});
  c.angular_form = f["angular_form"].choice(
      AngularForm::kExact, {{"exact", AngularForm::kExact}, {"cosine", AngularForm::kCosine}});
  c.angular_reactions = f["angular_reactions"].choice(
      AngularReactions::kSymmetric,
      {{"gather", AngularReactions::kGather}, {"symmetric", AngularReactions::kSymmetric}});
  s.steps_given = f["steps"].defined() || f["report_every"].defined();
  s.steps = f["steps"].integer(1000, 0, 1'000'000'000'000);
  s.report_every = f["report_every"].integer(100, 1, 1'000'000'000);
  c.cuda_steps_per_graph = static_cast<int>(f["steps_per_graph"].integer(64, 2, 4096));
  if (c.cuda_steps_per_graph % 2) f["steps_per_graph"].fail("expected an even number");
  read_integration(f, integration, c.backend);
}

void read_stability(const Field& f, crms::StabilityControls& st) {
  f.expect_keys({"kinetic_damping", "velocity_limit", "velocity_limit_fraction", "allow_unsafe_dt",
                 "allow_unstable"});
  st.kinetic_damping = f["kinetic_damping"].number(0.0, 0.0, 1e3);
  st.velocity_limit = (!f["velocity_limit"].defined() || f["velocity_limit"].is_auto())
                          ? -1.0
                          : f["velocity_limit"].number(0.0, 0.0, 1e9);
  st.velocity_limit_auto_fraction = f["velocity_limit_fraction"].number(0.25, 0.0, 10.0, true);
  st.allow_unsafe_dt = f["allow_unsafe_dt"].boolean(false);
  st.allow_unstable = f["allow_unstable"].boolean(false);
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
      const Field plane = a["plane"];
      plane.expect_keys({"point", "normal", "landmark", "offset_mm"});
      if (plane["landmark"].defined()) {
        if (plane["point"].defined())
          plane["point"].fail("give point (mm) or landmark (with offset_mm), not both");
        anchor.point_anatomy.landmark = plane["landmark"].text();
        const auto& names = anatomy_landmark_names();
        if (std::find(names.begin(), names.end(), anchor.point_anatomy.landmark) == names.end())
          plane["landmark"].fail("unknown landmark '" + anchor.point_anatomy.landmark +
                                 "' (expected one of " + joined_names(names) + ")");
        anchor.point_anatomy.offset_mm = read_anatomy_offset(plane["offset_mm"]);
        anchor.point_anatomy.key = plane["landmark"].path();
      } else {
        if (plane["offset_mm"].defined()) plane["offset_mm"].fail("needs landmark");
        anchor.point_mm = plane["point"].vec3({0, 0, 0});
      }
      const Field normal = plane["normal"];
      Vec3d dir;
      if (normal.defined() && normal.node().IsScalar()) {
        anchor.normal_direction = normal.text();
        if (!anatomy_direction(anchor.normal_direction, dir))
          normal.fail(
              "expected [x, y, z] or a patient direction (left, right, anterior, "
              "posterior, superior, inferior), got '" +
              anchor.normal_direction + "'");
        anchor.normal_key = normal.path();
        anchor.normal = dir;
      } else {
        anchor.normal = normal.vec3({});
        if (!(length_squared(anchor.normal) > 0)) normal.fail("must not be zero");
      }
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

/// `removal.rates`: `library` or {LABEL: rate | {ablate, cut}}.
void read_removal_rates(const Field& f, SceneTissue& t, LibraryRef& library) {
  if (!f.defined()) return;
  if (f.node().IsScalar()) {
    if (f.text() != "library")
      f.fail(
          "expected `library` (the material library's removal_rates) or a mapping of tissue "
          "labels to rates, got '" +
          f.text() + "'");
    const MaterialLibrary& lib = library.get();
    if (lib.removal_rates.empty()) f.fail(lib.file.string() + " has no removal_rates section");
    for (const LabelRemovalRates& r : lib.removal_rates) {
      t.ablation_rates[r.label] = static_cast<float>(r.ablation);
      t.cut_rates[r.label] = static_cast<float>(r.cut);
    }
    t.rates_source = lib.file.string();
    return;
  }
  for (const std::string& key : f.keys()) {
    const Field r = f[key];
    const std::uint8_t label = parse_label(Field(YAML::Node(key), r.path(), r.file()));
    if (label == kLabelOutside || label == kLabelInvalid)
      r.fail("expected a tissue label (soft-tissue, mucosa, …, vessel, nerve, or 1..254)");
    if (r.node().IsMap()) {
      r.expect_keys({"ablate", "cut"});
      if (!r["ablate"].defined() && !r["cut"].defined()) r.fail("needs ablate, cut or both");
      t.ablation_rates[label] = static_cast<float>(r["ablate"].number(1.0, 0.0, 1.0));
      t.cut_rates[label] = static_cast<float>(r["cut"].number(1.0, 0.0, 1.0));
    } else {
      t.ablation_rates[label] = t.cut_rates[label] =
          static_cast<float>(r.required_number(0.0, 1.0));
    }
  }
  t.rates_source = "scene";
}

void read_tissue(const Field& f, SceneTissue& t, LibraryRef& library) {
  if (!f.defined()) return;
  f.expect_keys({"voxels_per_node", "iso", "merge_epsilon", "coupler", "deletion_threshold",
                 "min_blade_thickness_voxels", "removal", "contact_passes", "exposure"});
  t.voxels_per_node = static_cast<int>(f["voxels_per_node"].integer(2, 1, 16));
  t.iso = f["iso"].number(0.5, 0.0, 1.0, true);
  t.merge_epsilon = f["merge_epsilon"].number(0.1, 0.0, 0.49);
  t.coupler = f["coupler"].choice(coupler::CouplerMode::kTrilinear,
                                  {{"trilinear", coupler::CouplerMode::kTrilinear},
                                   {"local-frame", coupler::CouplerMode::kLocalFrame}});
  t.deletion_threshold = f["deletion_threshold"].number(0.125, 0.0, 1.0, true);
  t.min_blade_thickness_voxels = f["min_blade_thickness_voxels"].number(2.0, 0.0, 100.0);
  const Field r = f["removal"];
  r.expect_keys({"strength", "falloff", "rates", "feather_force_mn"});
  t.removal_strength = r["strength"].number(1.0, 0.0, 1.0);
  t.falloff_mm = r["falloff"].is_auto() ? -1.0 : r["falloff"].number(-1.0, 0.0, 100.0);
  read_removal_rates(r["rates"], t, library);
  t.feather_force_mn = r["feather_force_mn"].number(0.0, 0.0, 1e6, true);
  t.contact_passes = static_cast<int>(f["contact_passes"].integer(2, 1, 1000));
  const Field e = f["exposure"];
  if (e.defined()) {
    e.expect_keys({"distance_mm", "labels"});
    t.exposure_distance_mm = e["distance_mm"].required_number(0.0, 100.0, true);
    const Field labels = e["labels"];
    for (std::size_t i = 0; labels.defined() && i < labels.size(); ++i) {
      const std::uint8_t l = parse_label(labels.at(i));
      if (l == kLabelOutside || l == kLabelInvalid)
        labels.at(i).fail("expected a tissue label (vessel, nerve, 64..127, or any 1..254)");
      for (std::uint8_t other : t.exposure_labels)
        if (other == l) labels.at(i).fail("is listed twice");
      t.exposure_labels.push_back(l);
    }
    if (labels.defined() && t.exposure_labels.empty()) labels.fail("expected at least one label");
  }
}

Rotation read_rotation(const Field& f, AnatomyPosition* anatomy = nullptr) {
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
  if (f["axis"].node().IsScalar()) {
    // A patient direction: resolved with the anatomy (anatomy_placement.h).
    const std::string word = f["axis"].text();
    Vec3d dir;
    if (!anatomy_direction(word, dir))
      f["axis"].fail(
          "expected [x, y, z] or a patient direction (left, right, anterior, "
          "posterior, superior, inferior), got '" +
          word + "'");
    if (anatomy == nullptr) f["axis"].fail("a patient direction is not accepted here");
    anatomy->rotation_axis = word;
    anatomy->rotation_angle_rad =
        f["angle_deg"].number(0.0, -36000.0, 36000.0) * 3.14159265358979323846 / 180.0;
    anatomy->rotation_key = f["axis"].path();
    return {};
  }
  const Vec3d axis = f["axis"].vec3({});
  if (!(length_squared(axis) > 0)) f["axis"].fail("must not be zero");
  const double angle = f["angle_deg"].number(0.0, -36000.0, 36000.0);
  return Rotation::about_axis(axis, angle * 3.14159265358979323846 / 180.0);
}

ToolPose read_pose(const Field& f, AnatomyPosition& anatomy) {
  if (!f.defined()) f.fail("is required (position, optional rotation)");
  f.expect_keys({"position", "rotation"});
  if (!f["position"].defined()) f["position"].fail("is required ([x, y, z] mm)");
  const Vec3d position = read_position(f["position"], anatomy);
  return {position, read_rotation(f["rotation"], &anatomy)};
}

interaction::ToolMode read_mode(const Field& f) {
  return f.choice(interaction::ToolMode::kPress, {{"press", interaction::ToolMode::kPress},
                                                  {"ablate", interaction::ToolMode::kAblate},
                                                  {"cut", interaction::ToolMode::kCut},
                                                  {"idle", interaction::ToolMode::kIdle}});
}

/// A tool made from a mesh file: `{shape: mesh, file: endoscope.stl, scale: 1, grid: 0.25}` (the
/// file relative to the scene's folder; its coordinates are the tool's own frame, mm × scale).
std::shared_ptr<const interaction::ToolMesh> read_tool_mesh(const Field& t,
                                                            const std::filesystem::path& folder) {
  if (!t["file"].defined()) t["file"].fail("is required for a mesh tool (an OBJ, STL or PLY file)");
  std::filesystem::path file = t["file"].text();
  if (file.is_relative()) file = folder / file;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) t["file"].fail("no such file: " + file.string());
  const double scale = t["scale"].number(1.0, 0.0, 1e4, true);
  MeshFile mesh;
  try {
    mesh = read_mesh_file(file, scale);
  } catch (const Error& e) {
    t["file"].fail(e.what());
  }
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const Vec3f& v : mesh.vertices)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(v[a]));
      hi[a] = std::max(hi[a], double(v[a]));
    }
  // Default grid: 1/24 of the tool's smallest extent, within [0.05, 1] mm.
  const double smallest = std::min({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  const double grid = t["grid"].defined() ? t["grid"].number(0.25, 0.01, 10.0)
                                          : std::clamp(smallest / 24.0, 0.05, 1.0);
  try {
    return interaction::ToolMesh::from_closed_mesh(file.string(), std::move(mesh.vertices),
                                                   std::move(mesh.triangles), grid);
  } catch (const Error& e) {
    t["file"].fail(e.what());
  }
}

void read_tools(const Field& f, const std::filesystem::path& folder,
                std::vector<SceneTool>& tools) {
  if (!f.defined()) return;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const Field t = f.at(i);
    t.expect_keys({"name", "shape", "radius", "length", "size", "file", "scale", "grid"});
    SceneTool tool;
    if (!t["name"].defined()) t["name"].fail("is required");
    tool.name = t["name"].text();
    for (const SceneTool& other : tools)
      if (other.name == tool.name) t["name"].fail("'" + tool.name + "' is used twice");
    using collision::ToolShape;
    if (!t["shape"].defined()) t["shape"].fail("is required (sphere, capsule, blade or mesh)");
    tool.tool.shape = t["shape"].choice(ToolShape::kSphere, {{"sphere", ToolShape::kSphere},
                                                             {"capsule", ToolShape::kCapsule},
                                                             {"blade", ToolShape::kBlade},
                                                             {"mesh", ToolShape::kMesh}});
    const bool mesh = tool.tool.shape == ToolShape::kMesh;
    for (const char* k : {"file", "scale", "grid"})
      if (!mesh && t[k].defined()) t[k].fail("only for a mesh tool");
    const bool round =
        tool.tool.shape == ToolShape::kSphere || tool.tool.shape == ToolShape::kCapsule;
    if (mesh) {
      for (const char* k : {"radius", "size"})
        if (t[k].defined()) t[k].fail("not for a mesh tool (its file gives its shape)");
      tool.tool.mesh = read_tool_mesh(t, folder);
    } else if (round) {
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
        AnatomyPosition anatomy;
        kf.pose.position = read_position(key["position"], anatomy);
        out.anatomy.push_back(anatomy);
        kf.pose.orientation = read_rotation(key["rotation"], &out.anatomy.back());
        if (!key["mode"].defined()) key["mode"].fail("is required (press, ablate, cut or idle)");
        kf.mode = read_mode(key["mode"]);
        if (!tool.tool.supports(kf.mode))
          key["mode"].fail(std::string("tool '") + tool.name + "' (a " +
                           interaction::to_string(tool.tool.shape) + ") cannot " +
                           interaction::to_string(kf.mode) +
                           " (ablate: sphere or capsule; cut: blade; press: any)");
        out.keyframes.push_back(kf);
      }
      // Tools act at once, each in its own hand; one tool is in one place at a time, so two
      // trajectories of the same tool may not overlap in time (their lift frame included).
      for (std::size_t j = 0; j < s.trajectories.size(); ++j) {
        const auto& o = s.trajectories[j].keyframes;
        if (s.trajectories[j].tool == out.tool &&
            out.keyframes.front().time_s <= o.back().time_s + 1.0 / s.frame_rate_hz &&
            o.front().time_s <= out.keyframes.back().time_s + 1.0 / s.frame_rate_hz)
          tr.fail("overlaps trajectories[" + std::to_string(j) + "] of the same tool '" + out.tool +
                  "' in time: a tool is in one place at a time (give another tool "
                  "for a second hand)");
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
      e.from = read_pose(ev["from"], e.from_anatomy);
      if (ev["to"].defined()) {
        e.to = read_pose(ev["to"], e.to_anatomy);
      } else {
        e.to = e.from;
        e.to_anatomy = e.from_anatomy;
      }
      s.events.push_back(e);
    }
  }
}

void read_outputs(const Field& f, SceneOutputs& o) {
  if (!f.defined()) return;
  f.expect_keys({"mesh", "rest_mesh", "report", "states", "states_every"});
  // A file name inside the command's output folder: never absolute, never `..`.
  auto name = [&](const Field& p, const char* extension) -> std::filesystem::path {
    if (!p.defined()) return {};
    const std::filesystem::path out = p.text();
    bool climbs = false;
    for (const auto& part : out) climbs = climbs || part == "..";
    if (out.empty() || out.is_absolute() || climbs)
      p.fail("expected a file name inside the output folder (--out), got '" + out.string() +
             "': outputs are written under the command's output folder only");
    if (out.extension() != extension)
      p.fail(std::string("expected a ") + extension + " file name, got '" + out.string() + "'");
    return out;
  };
  o.mesh = name(f["mesh"], ".ply");
  o.rest_mesh = name(f["rest_mesh"], ".ply");
  o.report = name(f["report"], ".json");
  o.states = name(f["states"], ".tsfmesh");
  o.states_every = f["states_every"].integer(10, 1, 1'000'000'000);
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

/// One entry of `tissues:`. `s` holds the scene-wide solver and effects read so far; `integration`
/// the scene's default integration.
SceneInstance read_instance(const Field& f, const std::filesystem::path& folder,
                            bool volume_from_pipeline, const Scene& s,
                            const SceneIntegration& integration, const crms::EffectsConfig& effects,
                            LibraryRef& library) {
  f.expect_keys(
      {"name", "lattice", "material", "anchors", "tissue", "effects", "solver", "contact"});
  SceneInstance inst;
  inst.integration = integration;
  if (const Field solver = f["solver"]; solver.defined()) {
    solver.expect_keys({"integrator", "dt", "dt_safety", "newton_iterations", "newton_tolerance"});
    read_integration(solver, inst.integration, s.solver.backend);
  }
  if (!f["name"].defined()) f["name"].fail("is required (names the instance's outputs)");
  inst.name = f["name"].text();
  if (!is_file_name_safe(inst.name))
    f["name"].fail("expected 1 to 64 letters, digits, '-' or '_', got '" + inst.name + "'");
  read_lattice(f["lattice"], folder, inst.lattice, volume_from_pipeline);
  inst.material_id = read_material(f["material"], inst.material, library);
  read_anchors(f["anchors"], inst.anchors);
  read_tissue(f["tissue"], inst.tissue, library);
  inst.effects = effects;
  if (f["effects"].defined()) {
    for (const char* k : {"palette", "animation"})
      if (f["effects"][k].defined())
        f["effects"][k].fail(
            "give it in the scene's top-level effects (it applies to every "
            "instance)");
    inst.effects = crms::EffectsConfig{};
    read_effects(f["effects"], inst.effects);
    inst.effects.animation = effects.animation;  // scene-wide (scene_effects.h)
  }
  if (const Field c = f["contact"]; c.defined()) {
    c.expect_keys({"pushed_by", "grid_mm"});
    const Field by = c["pushed_by"];
    if (!by.defined() || !by.node().IsSequence() || by.size() == 0)
      by.fail("expected a non-empty list of instance names (the bodies that push this one)");
    for (std::size_t k = 0; k < by.size(); ++k) {
      const std::string name = by.at(k).text();
      if (name == inst.name) by.at(k).fail("an instance does not push itself");
      if (std::find(inst.pushed_by.begin(), inst.pushed_by.end(), name) != inst.pushed_by.end())
        by.at(k).fail("'" + name + "' is listed twice");
      inst.pushed_by.push_back(name);
    }
    inst.contact_grid_mm = c["grid_mm"].number(0.0, 0.0, 10.0);
  }
  return inst;
}

/// A scene without a pipeline that places by anatomy runs on a `tsf segment` output: the anatomy
/// is the `anatomy` section of PREFIX-report.json beside PREFIX-density.nrrd (segment_job.h).
void place_by_segment_report(Scene& s, const std::string& name) {
  std::filesystem::path volume;
  for (const SceneInstance& inst : s.instances) {
    if (inst.lattice.source != SceneLattice::Source::kVolume) continue;
    if (!volume.empty() && inst.lattice.volume != volume)
      throw Error(name + ": " + s.anatomy_key +
                  ": places by anatomy, but the instances' lattices read different volumes ('" +
                  volume.string() + "', '" + inst.lattice.volume.string() +
                  "'): one segment report's anatomy cannot place both");
    volume = inst.lattice.volume;
  }
  const std::string v = volume.string();
  const std::filesystem::path report = segment_report_beside(volume);
  std::error_code ec;
  if (report.empty() || !std::filesystem::is_regular_file(report, ec))
    throw Error(name + ": " + s.anatomy_key +
                ": places by the patient's anatomy, which tsf segment finds and writes into "
                "PREFIX-report.json beside PREFIX-density.nrrd; " +
                (volume.empty()   ? std::string("this scene has no volume lattice")
                 : report.empty() ? "lattice.volume '" + v + "' is not a PREFIX-density.nrrd"
                                  : "'" + report.string() + "' does not exist") +
                ". Segment the CT with tsf segment, add a pipeline section (tsf run), or give "
                "millimetres (docs/patients.md)");
  nlohmann::json j;
  try {
    std::ifstream in(report);
    j = nlohmann::json::parse(in);
  } catch (const std::exception& e) {
    throw Error(report.string() + ": not a readable segment report (" + e.what() + ")");
  }
  s.placement_warnings = place_scene_by_anatomy(s, j);
}

}  // namespace

std::string Scene::instance_prefix(std::size_t index) const {
  return file.string() + ": " +
         (multi_instance
              ? "tissues[" + std::to_string(index) + "] (" + instances.at(index).name + "): "
              : std::string());
}

Scene read_scene(const std::filesystem::path& file) {
  const std::string name = file.string();
  const Field top(load_yaml_file(name), "", name);
  if (!top.defined()) top.fail("the scene is empty");
  top.expect_keys({"name", "lattice", "material", "solver", "gravity", "stability", "anchors",
                   "loads", "initial", "effects", "tissue", "tools", "script", "outputs",
                   "pipeline", "tissues"});
  Scene s;
  s.file = file;
  s.name = top["name"].defined() ? top["name"].text() : file.stem().string();
  if (!is_file_name_safe(s.name))
    top["name"].fail("expected 1 to 64 letters, digits, '-' or '_' (it names output files), got '" +
                     s.name + "'");
  s.pipeline = read_run_spec(file);
  const bool from_pipeline = s.pipeline.present;
  LibraryRef library;
  library.path = s.pipeline.material_library;
  const Field tissues = top["tissues"];
  s.multi_instance = tissues.defined();
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
  }
  SceneIntegration integration;
  read_solver(top["solver"], s, integration);
  s.solver.gravity = top["gravity"].vec3({0, 0, 0});
  if (std::sqrt(length_squared(s.solver.gravity)) > 1e7)
    top["gravity"].fail("magnitude must be at most 1e7 mm/s² (Earth: 9810)");
  read_stability(top["stability"], s.solver.stability);
  read_loads(top["loads"], s.loads);
  crms::EffectsConfig effects;
  read_effects(top["effects"], effects);
  read_scene_effects(top["effects"], s.effect_regions, s.solver);
  effects.animation = s.solver.effects.animation;
  s.solver.effects = crms::EffectsConfig{};  // each instance's (instance_solver_config)
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
      SceneInstance inst = read_instance(tissues.at(i), file.parent_path(), from_pipeline, s,
                                         integration, effects, library);
      for (const SceneInstance& other : s.instances)
        if (other.name == inst.name)
          tissues.at(i)["name"].fail("'" + inst.name + "' is used twice");
      s.instances.push_back(std::move(inst));
    }
    // Who pushes whom: names that exist, one way (no instance pushed by one it pushes).
    for (std::size_t i = 0; i < s.instances.size(); ++i)
      for (std::size_t k = 0; k < s.instances[i].pushed_by.size(); ++k) {
        const std::string& by = s.instances[i].pushed_by[k];
        const Field key = tissues.at(i)["contact"]["pushed_by"].at(k);
        const auto it = std::find_if(s.instances.begin(), s.instances.end(),
                                     [&](const SceneInstance& o) { return o.name == by; });
        if (it == s.instances.end()) key.fail("no instance named '" + by + "' in tissues");
        if (std::find(it->pushed_by.begin(), it->pushed_by.end(), s.instances[i].name) !=
            it->pushed_by.end())
          key.fail("'" + by + "' is itself pushed by '" + s.instances[i].name +
                   "': contact is one way (the stiffer body pushes)");
      }
    instance_push_order(s);  // longer circles
  } else {
    SceneInstance single;
    single.name = s.name;
    single.integration = integration;
    single.effects = effects;
    read_lattice(top["lattice"], file.parent_path(), single.lattice, from_pipeline);
    // A scene whose pipeline names a library material (tsf run) may leave `material` out: the
    // library material is taken here, once, through the same library as an id in `material:`.
    if (top["material"].defined() || s.pipeline.material.empty()) {
      single.material_id = read_material(top["material"], single.material, library);
    } else {
      const LibraryMaterial m =
          library_material(top["pipeline"]["material"], s.pipeline.material, library);
      single.material = m.crms_material();
      single.material_id = m.id;
    }
    if (top["material"].defined() && !s.pipeline.material.empty())
      top["pipeline"]["material"].fail("give the material once: here or in `material:`");
    read_anchors(top["anchors"], single.anchors);
    read_tissue(top["tissue"], single.tissue, library);
    s.instances.push_back(std::move(single));
  }
  if (s.effect_regions.channels_given)
    for (const SceneInstance& inst : s.instances)
      if (inst.lattice.source != SceneLattice::Source::kVolume)
        top["effects"]["palette"]["channels"].fail(
            "needs lattice.source: volume (the channels are segment's material weights)");
  read_tools(top["tools"], file.parent_path(), s.tools);
  s.script_given = top["script"].defined();
  read_script(top["script"], s.tools, s.script);
  s.outputs_given = top["outputs"].defined();
  read_outputs(top["outputs"], s.outputs);
  s.interactive = !s.tools.empty() || s.script_given || s.multi_instance || top["tissue"].defined();
  if (s.script_given && s.tools.empty() &&
      (!s.script.trajectories.empty() || !s.script.events.empty()))
    top["script"].fail("needs tools (its trajectories and events name them)");
  if (s.interactive && s.steps_given)
    top["solver"][top["solver"]["steps"].defined() ? "steps" : "report_every"].fail(
        "only for a lattice-only scene: a scene with tissue, tools or a script runs for "
        "script.duration (or --duration)");
  if (!s.interactive && s.outputs_given)
    top["outputs"].fail(
        "needs a scene with tissue, tools or a script (a lattice-only scene writes its report "
        "with --report)");
  // Anatomy-relative keys are resolved after the segmentation of `tsf run`: without a pipeline
  // there is no anatomy to place them by.
  for (const SceneInstance& inst : s.instances) {
    if (s.anatomy_key.empty() && inst.lattice.crop_by_anatomy())
      s.anatomy_key = inst.lattice.crop_key;
    for (const SceneAnchor& a : inst.anchors) {
      if (s.anatomy_key.empty() && a.point_anatomy.given()) s.anatomy_key = a.point_anatomy.key;
      if (s.anatomy_key.empty() && !a.normal_direction.empty()) s.anatomy_key = a.normal_key;
    }
  }
  for (const SceneTrajectory& t : s.script.trajectories)
    for (const AnatomyPosition& p : t.anatomy) {
      if (s.anatomy_key.empty() && p.given()) s.anatomy_key = p.key;
      if (s.anatomy_key.empty() && p.rotation_given()) s.anatomy_key = p.rotation_key;
    }
  for (const SceneEvent& e : s.script.events)
    for (const AnatomyPosition* p : {&e.from_anatomy, &e.to_anatomy}) {
      if (s.anatomy_key.empty() && p->given()) s.anatomy_key = p->key;
      if (s.anatomy_key.empty() && p->rotation_given()) s.anatomy_key = p->rotation_key;
    }
  if (!s.anatomy_key.empty() && !s.pipeline.present) place_by_segment_report(s, name);
  // Exposure triggers fire on exposure events: every instance must watch their label.
  for (const SceneCutTrigger& t : s.effect_regions.cut_triggers) {
    if (t.exposure_label == 0) continue;
    for (std::size_t i = 0; i < s.instances.size(); ++i) {
      const SceneTissue& tissue = s.instances[i].tissue;
      const auto& watched = tissue.exposure_labels;
      const bool watches = tissue.exposure_distance_mm > 0.0 &&
                           (watched.empty() ? is_overlay_label(t.exposure_label)
                                            : std::find(watched.begin(), watched.end(),
                                                        t.exposure_label) != watched.end());
      if (!watches)
        throw Error(s.instance_prefix(i) + t.key + ": fires when an edit exposes label '" +
                    tissue_label_name(t.exposure_label) +
                    "', which tissue.exposure does not watch (set tissue.exposure.distance_mm"
                    " and, for a label outside 64..127, list it in tissue.exposure.labels)");
    }
  }
  // Cross-field checks with the library's own messages (they name material.* fields).
  for (std::size_t i = 0; i < s.instances.size(); ++i) {
    try {
      crms::validate_solver_config(instance_solver_config(s, i));
    } catch (const Error& e) {
      throw Error(s.instance_prefix(i) + e.what());
    }
  }
  return s;
}

}  // namespace tsf::app
