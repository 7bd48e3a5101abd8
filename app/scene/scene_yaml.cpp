// Strict YAML reading of a tsf scene (scene.h). yaml-cpp stays in app/: tissue/ never sees it.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>
#include <sstream>
#include <string>

#include "scene/scene.h"
#include "tsf/common/error.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::app {
namespace {

/// A YAML node with its key path, whose accessors check type and range and name the path.
class Field {
 public:
  Field(YAML::Node node, std::string path, const std::string* file)
      : node_(std::move(node)), path_(std::move(path)), file_(file) {}

  [[noreturn]] void fail(const std::string& what) const {
    std::ostringstream s;
    s << *file_ << ": " << (path_.empty() ? "(top level)" : path_) << ": " << what;
    if (node_.IsDefined() && node_.Mark().line >= 0) s << " (line " << node_.Mark().line + 1 << ")";
    throw Error(s.str());
  }
  bool defined() const { return node_.IsDefined() && !node_.IsNull(); }
  const std::string& path() const { return path_; }

  /// Child of a map; `allowed` lists every key this map may hold (checked once per map).
  Field operator[](const std::string& key) const {
    return Field(node_[key], path_.empty() ? key : path_ + "." + key, file_);
  }
  void expect_keys(std::initializer_list<const char*> allowed) const {
    if (!defined()) return;
    if (!node_.IsMap()) fail("expected a mapping of keys");
    std::set<std::string> ok(allowed.begin(), allowed.end());
    for (const auto& kv : node_) {
      const std::string key = kv.first.as<std::string>();
      if (!ok.count(key)) {
        std::string list;
        for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
        Field(kv.first, path_.empty() ? key : path_ + "." + key, file_)
            .fail("unknown key (expected one of: " + list + ")");
      }
    }
  }
  std::string text() const {
    if (!node_.IsScalar()) fail("expected a text value");
    return node_.Scalar();
  }
  double number() const {
    if (!node_.IsScalar()) fail("expected a number");
    try {
      const double v = node_.as<double>();
      if (!std::isfinite(v)) fail("expected a finite number, got '" + node_.Scalar() + "'");
      return v;
    } catch (const YAML::Exception&) {
      fail("expected a number, got '" + node_.Scalar() + "'");
    }
  }
  double number(double fallback, double lo, double hi, bool lo_open = false) const {
    if (!defined()) return fallback;
    const double v = number();
    if ((lo_open ? !(v > lo) : !(v >= lo)) || !(v <= hi)) {
      std::ostringstream s;
      s << "expected a number in " << (lo_open ? "(" : "[") << lo << ", " << hi << "], got " << v;
      fail(s.str());
    }
    return v;
  }
  std::int64_t integer(std::int64_t fallback, std::int64_t lo, std::int64_t hi) const {
    if (!defined()) return fallback;
    const double v = number();
    if (v != std::floor(v) || v < static_cast<double>(lo) || v > static_cast<double>(hi))
      fail("expected a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
           "], got " + node_.Scalar());
    return static_cast<std::int64_t>(v);
  }
  bool boolean(bool fallback) const {
    if (!defined()) return fallback;
    try {
      return node_.as<bool>();
    } catch (const YAML::Exception&) {
      fail("expected true or false, got '" + node_.Scalar() + "'");
    }
  }
  Vec3d vec3(Vec3d fallback) const {
    if (!defined()) return fallback;
    if (!node_.IsSequence() || node_.size() != 3) fail("expected a list of 3 numbers [x, y, z]");
    Vec3d v;
    for (int a = 0; a < 3; ++a)
      v[a] = Field(node_[a], path_ + "[" + std::to_string(a) + "]", file_).number();
    return v;
  }
  template <typename T>
  T choice(T fallback, std::initializer_list<std::pair<const char*, T>> options) const {
    if (!defined()) return fallback;
    const std::string t = text();
    std::string list;
    for (const auto& o : options) {
      if (t == o.first) return o.second;
      list += std::string(list.empty() ? "" : ", ") + o.first;
    }
    fail("expected one of " + list + ", got '" + t + "'");
  }
  std::size_t size() const {
    if (!node_.IsSequence()) fail("expected a list");
    return node_.size();
  }
  Field at(std::size_t i) const {
    return Field(node_[i], path_ + "[" + std::to_string(i) + "]", file_);
  }
  bool is_auto() const { return defined() && node_.IsScalar() && node_.Scalar() == "auto"; }

 private:
  YAML::Node node_;
  std::string path_;
  const std::string* file_;
};

std::uint8_t parse_label(const Field& f) {
  const std::string t = f.text();
  for (int l = 0; l < 256; ++l)
    if (t == tissue_label_name(static_cast<std::uint8_t>(l))) return static_cast<std::uint8_t>(l);
  const std::int64_t v = f.integer(-1, 0, 255);
  return static_cast<std::uint8_t>(v);
}

void read_lattice(const Field& f, const std::filesystem::path& folder, SceneLattice& l) {
  if (!f.defined()) f.fail("is required");
  f.expect_keys({"source", "size", "spacing", "origin", "volume", "node_spacing_voxels",
                 "occupancy_threshold", "mass_floor"});
  l.source = f["source"].choice(
      SceneLattice::Source::kBox,
      {{"box", SceneLattice::Source::kBox}, {"volume", SceneLattice::Source::kVolume}});
  if (l.source == SceneLattice::Source::kBox) {
    for (const char* k : {"volume", "node_spacing_voxels", "occupancy_threshold", "mass_floor"})
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
    if (!f["volume"].defined()) f["volume"].fail("is required for source: volume");
    l.volume = f["volume"].text();
    if (l.volume.is_relative()) l.volume = folder / l.volume;
    l.node_spacing_voxels = static_cast<int>(f["node_spacing_voxels"].integer(2, 1, 64));
    l.occupancy_threshold = f["occupancy_threshold"].number(0.125, 0.0, 1.0, true);
    l.mass_floor = f["mass_floor"].number(0.5, 0.0, 1.0);
  }
}

void read_material(const Field& f, crms::Material& m) {
  if (!f.defined()) f.fail("is required");
  f.expect_keys({"youngs_modulus", "shear_modulus", "viscosity", "density"});
  if (!f["youngs_modulus"].defined()) f["youngs_modulus"].fail("is required (Pa)");
  m.youngs_modulus_pa = f["youngs_modulus"].number(0, 1.0, 1e11);
  m.shear_modulus_pa = f["shear_modulus"].is_auto()
                           ? 0.0
                           : f["shear_modulus"].number(0.0, 0.0, 10.0 * m.youngs_modulus_pa);
  m.viscosity_pa_s = f["viscosity"].number(0.0, 0.0, 1e6);
  m.density_g_per_mm3 = f["density"].number(1e-3, 1e-6, 1e-1);
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

/// `effects:` (tsf/crms/effects_config.h): a listed effect is on unless it says `enabled: false`.
void read_effects(const Field& f, crms::EffectsConfig& e) {
  if (!f.defined()) return;
  f.expect_keys({"plasticity", "anisotropy", "fluid", "tearing"});
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
    t.expect_keys({"enabled", "strain_threshold"});
    e.tearing.enabled = t["enabled"].boolean(true);
    e.tearing.strain_threshold = t["strain_threshold"].number(0.5, 0.0, 100.0, true);
  }
}

}  // namespace

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
  const Field top(root, "", &name);
  if (!top.defined()) top.fail("the scene is empty");
  top.expect_keys({"name", "lattice", "material", "solver", "gravity", "stability", "anchors",
                   "loads", "initial", "effects"});
  Scene s;
  s.file = file;
  s.name = top["name"].defined() ? top["name"].text() : file.stem().string();
  read_lattice(top["lattice"], file.parent_path(), s.lattice);
  read_material(top["material"], s.solver.materials.at(0));
  read_solver(top["solver"], s);
  s.solver.gravity = top["gravity"].vec3({0, 0, 0});
  if (std::sqrt(length_squared(s.solver.gravity)) > 1e7)
    top["gravity"].fail("magnitude must be at most 1e7 mm/s² (Earth: 9810)");
  read_stability(top["stability"], s.solver.stability);
  read_anchors(top["anchors"], s.anchors);
  read_loads(top["loads"], s.loads);
  read_effects(top["effects"], s.solver.effects);
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
  // Cross-field checks with the library's own messages (they name material.* fields).
  try {
    crms::validate_solver_config(s.solver);
  } catch (const Error& e) {
    throw Error(name + ": " + e.what());
  }
  return s;
}

}  // namespace tsf::app
