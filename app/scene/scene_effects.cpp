#include "scene/scene_effects.h"

#include <cmath>
#include <string>

#include "tsf/common/error.h"
#include "tsf/interaction/exposure.h"
#include "tsf/volume/tissue_labels.h"
#include "yaml_field.h"

namespace tsf::app {
namespace {

using Field = YamlField;

SceneRegion read_region(const Field& f) {
  SceneRegion r;
  if (!f.defined()) return r;  // the whole lattice
  f.expect_keys({"box", "labels"});
  if (f["box"].defined() == f["labels"].defined()) f.fail("expected exactly one of box, labels");
  if (const Field box = f["box"]; box.defined()) {
    box.expect_keys({"min", "max"});
    r.kind = SceneRegion::Kind::kBox;
    r.min_mm = box["min"].vec3();
    r.max_mm = box["max"].vec3();
    for (int a = 0; a < 3; ++a)
      if (!(r.max_mm[a] >= r.min_mm[a])) box["max"].fail("must not be below min on any axis");
  } else {
    r.kind = SceneRegion::Kind::kLabels;
    const Field labels = f["labels"];
    for (std::size_t l = 0; l < labels.size(); ++l) r.labels.push_back(parse_label(labels.at(l)));
    if (r.labels.empty()) labels.fail("expected at least one label");
  }
  return r;
}

/// A palette entry by name (`material` = entry 0, the scene's material) or index.
int read_entry(const Field& f, const SceneEffects& e, int materials) {
  if (!f.defined()) f.fail("is required (a palette entry name or index)");
  const std::string t = f.text();
  if (t == "material") return 0;
  for (std::size_t i = 0; i < e.palette_names.size(); ++i)
    if (t == e.palette_names[i]) return static_cast<int>(i) + 1;
  std::string names = "material";
  for (const auto& n : e.palette_names) names += ", " + n;
  if (t.find_first_not_of("0123456789") == std::string::npos)
    return static_cast<int>(f.integer(0, 0, materials - 1));
  f.fail("expected a palette entry (" + names + ") or its index, got '" + t + "'");
}

crms::Material read_palette_material(const Field& f, std::string& name) {
  f.expect_keys({"name", "youngs_modulus", "shear_modulus", "viscosity", "density", "tear_strain",
                 "anisotropy_axis", "anisotropy_factor"});
  name = f["name"].required().text();
  crms::Material m;
  m.youngs_modulus_pa = f["youngs_modulus"].required_number(1.0, 1e11);
  m.shear_modulus_pa = f["shear_modulus"].number(0.0, 0.0, 10.0 * m.youngs_modulus_pa);
  m.viscosity_pa_s = f["viscosity"].number(0.0, 0.0, 1e6);
  m.density_g_per_mm3 = f["density"].number(1e-3, 1e-6, 1e-1);
  m.tear_strain = f["tear_strain"].number(0.0, 0.0, 100.0);
  m.anisotropy_factor = f["anisotropy_factor"].number(0.0, 0.0, 100.0);
  if (m.anisotropy_factor > 0.0) {
    if (m.anisotropy_factor < 0.01) f["anisotropy_factor"].fail("expected 0 (none) or ≥ 0.01");
    m.anisotropy_axis = f["anisotropy_axis"].required().vec3();
    if (!(length_squared(m.anisotropy_axis) > 0)) f["anisotropy_axis"].fail("must not be zero");
  }
  return m;
}

}  // namespace

std::uint8_t parse_label(const YamlField& f) {
  const std::string t = f.text();
  for (int l = 0; l < 256; ++l)
    if (t == tissue_label_name(static_cast<std::uint8_t>(l)) ||
        t == tissue_label_key(static_cast<std::uint8_t>(l)))
      return static_cast<std::uint8_t>(l);
  return static_cast<std::uint8_t>(f.integer(-1, 0, 255));
}

bool SceneRegion::contains(const crms::Lattice& lattice, std::int64_t node) const {
  switch (kind) {
    case Kind::kAll:
      return true;
    case Kind::kBox: {
      const Vec3d p = lattice.geometry().rest_position(node);
      return p.x >= min_mm.x && p.x <= max_mm.x && p.y >= min_mm.y && p.y <= max_mm.y &&
             p.z >= min_mm.z && p.z <= max_mm.z;
    }
    case Kind::kLabels:
      for (std::uint8_t l : labels)
        if (lattice.label(node) == l) return true;
      return false;
  }
  return false;
}

void read_scene_effects(const Field& f, SceneEffects& e, crms::SolverConfig& solver) {
  if (!f.defined()) return;
  if (const Field p = f["palette"]; p.defined()) {
    p.expect_keys({"materials", "channels"});
    const Field list = p["materials"];
    for (std::size_t i = 0; i < list.size(); ++i) {
      std::string name;
      e.palette_materials.push_back(read_palette_material(list.at(i), name));
      if (name == "material") list.at(i)["name"].fail("'material' names entry 0 (the scene's)");
      for (const auto& n : e.palette_names)
        if (n == name) list.at(i)["name"].fail("duplicate palette entry name '" + name + "'");
      e.palette_names.push_back(name);
    }
    if (1 + e.palette_materials.size() > static_cast<std::size_t>(crms::kMaxMaterials))
      list.fail("at most " + std::to_string(crms::kMaxMaterials - 1) +
                " entries besides the scene's material");
    solver.materials.resize(1);
    for (const auto& m : e.palette_materials) solver.materials.push_back(m);
    const auto count = static_cast<int>(solver.materials.size());
    if (const Field ch = p["channels"]; ch.defined()) {
      if (ch.size() != 4) ch.fail("expected 4 entries (segment's material channels)");
      e.channels_given = true;
      for (int c = 0; c < 4; ++c)
        e.channels[static_cast<std::size_t>(c)] =
            read_entry(ch.at(static_cast<std::size_t>(c)), e, count);
    }
  }
  const auto count = static_cast<int>(solver.materials.size());
  if (const Field a = f["animation"]; a.defined()) {
    a.expect_keys(
        {"enabled", "rest_keyframes", "material_tracks", "cut_triggers", "exposure_triggers"});
    e.animation = a["enabled"].boolean(true);
    solver.effects.animation.enabled = e.animation;
    const Field keys = a["rest_keyframes"];
    for (std::size_t i = 0; keys.defined() && i < keys.size(); ++i) {
      const Field k = keys.at(i);
      k.expect_keys({"time", "scale", "about", "region"});
      SceneRestKeyframe key;
      key.time_s = k["time"].required_number(0.0, 1e9);
      if (!e.rest_keyframes.empty() && !(key.time_s > e.rest_keyframes.back().time_s))
        k["time"].fail("keyframe times must increase strictly");
      key.scale = k["scale"].vec3({1, 1, 1});
      for (int ax = 0; ax < 3; ++ax)
        if (!(key.scale[ax] > 0.1 && key.scale[ax] <= 10))
          k["scale"].fail("each factor in (0.1, 10]");
      key.about_mm = k["about"].vec3({0, 0, 0});
      key.region = read_region(k["region"]);
      e.rest_keyframes.push_back(key);
    }
    const Field tracks = a["material_tracks"];
    for (std::size_t i = 0; tracks.defined() && i < tracks.size(); ++i) {
      const Field t = tracks.at(i);
      t.expect_keys({"start", "end", "entry", "region"});
      SceneMaterialTrack track;
      track.start_s = t["start"].required_number(0.0, 1e9);
      track.end_s = t["end"].number(track.start_s, track.start_s, 1e9);
      track.entry = read_entry(t["entry"], e, count);
      track.region = read_region(t["region"]);
      e.material_tracks.push_back(track);
    }
    for (const char* list : {"cut_triggers", "exposure_triggers"}) {
      const bool exposure = std::string(list) == "exposure_triggers";
      const Field triggers = a[list];
      for (std::size_t i = 0; triggers.defined() && i < triggers.size(); ++i) {
        const Field t = triggers.at(i);
        if (exposure)
          t.expect_keys({"name", "label", "entry", "region"});
        else
          t.expect_keys({"name", "entry", "region"});
        SceneCutTrigger trigger;
        trigger.name = t["name"].defined() ? t["name"].text() : "trigger " + std::to_string(i);
        trigger.entry = read_entry(t["entry"], e, count);
        trigger.region = read_region(t["region"]);
        trigger.key = t.path();
        if (exposure) {
          trigger.exposure_label = parse_label(t["label"].required());
          if (trigger.exposure_label == kLabelOutside || trigger.exposure_label == kLabelInvalid)
            t["label"].fail("expected a tissue label (an overlay: vessel, nerve, 64..127)");
        }
        e.cut_triggers.push_back(trigger);
      }
    }
    if ((!e.material_tracks.empty() || !e.cut_triggers.empty()) && count < 2)
      a.fail(
          "material tracks and cut and exposure triggers need effects.palette with at least one "
          "material");
  }
}

void configure_volume_lattice(const SceneEffects& e, const crms::SolverConfig& solver,
                              crms::VolumeLatticeOptions& o) {
  if (!e.channels_given) return;
  o.material_blends = true;
  o.channel_material = e.channels;
  for (std::size_t c = 0; c < 4; ++c)
    o.channel_density_g_per_mm3[c] =
        solver.materials.at(static_cast<std::size_t>(e.channels[c])).density_g_per_mm3;
}

void apply_scene_effects(const SceneEffects& e, const crms::Lattice& lattice,
                         crms::SolverConfig& solver) {
  if (!e.animation) return;
  crms::AnimationConfig& a = solver.effects.animation;
  const std::int64_t count = lattice.node_count();
  auto nodes_in = [&](const SceneRegion& r) {
    std::vector<std::int64_t> nodes;
    for (std::int64_t n = 0; n < count; ++n)
      if (lattice.alive(n) && r.contains(lattice, n)) nodes.push_back(n);
    return nodes;
  };
  a.rest_keyframes.clear();
  for (const SceneRestKeyframe& k : e.rest_keyframes) {
    crms::RestKeyframe key;
    key.time_s = k.time_s;
    key.rest_displacement_mm.assign(static_cast<std::size_t>(count), Vec3f{0, 0, 0});
    for (std::int64_t n = 0; n < count; ++n) {
      if (!k.region.contains(lattice, n)) continue;
      const Vec3d p = lattice.geometry().rest_position(n);
      for (int ax = 0; ax < 3; ++ax)
        key.rest_displacement_mm[static_cast<std::size_t>(n)][ax] =
            static_cast<float>((k.scale[ax] - 1.0) * (p[ax] - k.about_mm[ax]));
    }
    a.rest_keyframes.push_back(std::move(key));
  }
  a.material_tracks.clear();
  for (const SceneMaterialTrack& t : e.material_tracks) {
    crms::MaterialTrack track;
    track.start_s = t.start_s;
    track.end_s = t.end_s;
    track.entry = t.entry;
    track.nodes = nodes_in(t.region);
    a.material_tracks.push_back(std::move(track));
  }
  a.cut_triggers.clear();
  for (const SceneCutTrigger& t : e.cut_triggers) {
    crms::CutTrigger trigger;
    trigger.name = t.name;
    trigger.entry = t.entry;
    trigger.nodes = nodes_in(t.region);
    if (t.exposure_label != 0) trigger.event = interaction::exposure_event_name(t.exposure_label);
    a.cut_triggers.push_back(std::move(trigger));
  }
}

}  // namespace tsf::app
