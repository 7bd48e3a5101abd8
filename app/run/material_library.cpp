// Strict reading of the material library and the derived lattice parameters (material_library.h).
#include "run/material_library.h"

#include "run/repo_paths.h"
#include "tsf/common/error.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/crms/solver.h"
#include "tsf/volume/tissue_labels.h"
#include "yaml_field.h"

namespace tsf::app {
namespace fs = std::filesystem;

crms::Material LibraryMaterial::crms_material() const {
  crms::Material m;
  m.youngs_modulus_pa = youngs_modulus_pa;
  m.shear_modulus_pa = shear_modulus_pa;
  m.viscosity_pa_s = youngs_modulus_pa * damping_time_s;
  m.density_g_per_mm3 = density_g_per_mm3;
  return m;
}

const LibraryMaterial* MaterialLibrary::find(const std::string& id) const {
  for (const auto& m : materials)
    if (m.id == id) return &m;
  return nullptr;
}

const LibraryMaterial& MaterialLibrary::get(const std::string& id) const {
  if (const LibraryMaterial* m = find(id)) return *m;
  std::string known;
  for (const auto& m : materials) known += (known.empty() ? "" : ", ") + m.id;
  throw Error("no material '" + id + "' in " + file.string() + " (known: " + known + ")");
}

namespace {

std::uint8_t parse_label(const YamlField& f) {
  const std::string t = f.text();
  for (int l = 0; l < 255; ++l)
    if (t == tissue_label_name(static_cast<std::uint8_t>(l))) return static_cast<std::uint8_t>(l);
  return static_cast<std::uint8_t>(f.integer(0, 1, 254));
}

std::vector<MaterialSource> read_sources(const YamlField& sources) {
  std::vector<MaterialSource> out;
  for (std::size_t i = 0; i < sources.size(); ++i) {
    const YamlField s = sources.at(i);
    s.expect_keys({"citation", "reports"});
    out.push_back({s["citation"].required().text(), s["reports"].required().text()});
  }
  return out;
}

/// `removal_rates: {LABEL: {ablation, cut, sources | assumption}}`.
void read_removal_rates(const YamlField& f, std::vector<LabelRemovalRates>& rates) {
  if (!f.defined()) return;
  for (const std::string& key : f.keys()) {
    const YamlField r = f[key];
    r.expect_keys({"ablation", "cut", "sources", "assumption"});
    LabelRemovalRates entry;
    entry.label = parse_label(YamlField(YAML::Node(key), r.path(), r.file()));
    for (const LabelRemovalRates& other : rates)
      if (other.label == entry.label)
        r.fail("names the same tissue label as '" + std::string(tissue_label_name(other.label)) +
               "'");
    entry.ablation = r["ablation"].required_number(0.0, 1.0);
    entry.cut = r["cut"].required_number(0.0, 1.0);
    if (r["sources"].defined()) {
      entry.sources = read_sources(r["sources"]);
      if (entry.sources.empty()) r["sources"].fail("needs at least one source (citation, reports)");
    }
    entry.assumption = r["assumption"].text("");
    if (entry.sources.empty() && entry.assumption.empty())
      r.fail(
          "needs sources (citation, reports) or, where none exists, an assumption saying why "
          "the values were chosen");
    rates.push_back(std::move(entry));
  }
}

}  // namespace

MaterialLibrary read_material_library(const fs::path& file) {
  const YamlField root(load_yaml_file(file.string()), "", file.string());
  root.expect_keys({"format", "materials", "removal_rates"});
  if (root["format"].required().text() != "tsf-materials-1")
    root["format"].fail("expected tsf-materials-1, got '" + root["format"].text() + "'");
  const YamlField list = root["materials"].required();
  MaterialLibrary lib;
  lib.file = file;
  for (const std::string& id : list.keys()) {
    const YamlField f = list[id];
    f.expect_keys({"name", "label", "youngs_modulus_pa", "shear_modulus_pa", "damping_time_s",
                   "density_g_per_mm3", "poisson_ratio", "sources", "notes"});
    for (char c : id)
      if (!(std::islower(static_cast<unsigned char>(c)) ||
            std::isdigit(static_cast<unsigned char>(c)) || c == '_'))
        f.fail("material ids use a-z, 0-9 and _ only");
    LibraryMaterial m;
    m.id = id;
    m.name = f["name"].required().text();
    m.label = f["label"].defined() ? parse_label(f["label"])
                                   : static_cast<std::uint8_t>(kLabelSoftTissue);
    m.youngs_modulus_pa = f["youngs_modulus_pa"].required().number(0, 1, 1e11);
    m.shear_modulus_pa =
        f["shear_modulus_pa"].number(0.0, 0.0, 10.0 * m.youngs_modulus_pa, /*lo_open=*/true);
    m.damping_time_s = f["damping_time_s"].required().number(0, 0, 1.0);
    m.density_g_per_mm3 = f["density_g_per_mm3"].required().number(0, 1e-6, 1e-1);
    m.poisson_ratio = f["poisson_ratio"].number(0.0, 0.0, 0.5);
    const YamlField sources = f["sources"].required();
    if (sources.size() == 0) sources.fail("needs at least one source (citation and reports)");
    m.sources = read_sources(sources);
    m.notes = f["notes"].text("");
    // The solver's own validation (ranges of E, G, η, ρ) as a last check, with this key path.
    try {
      crms::validate_material(m.crms_material(), (f.path()).c_str());
    } catch (const Error& e) {
      throw Error(file.string() + ": " + e.what());
    }
    lib.materials.push_back(std::move(m));
  }
  if (lib.materials.empty()) list.fail("lists no material");
  read_removal_rates(root["removal_rates"], lib.removal_rates);
  return lib;
}

fs::path default_material_library_path() {
  return find_bundled_path("materials/tissues.yaml");
}

DerivedLatticeParameters derive_lattice_parameters(const LibraryMaterial& material,
                                                   double spacing_mm) {
  DerivedLatticeParameters d;
  d.spacing_mm = spacing_mm;
  const crms::Material m = material.crms_material();
  d.springs = crms::calibrate_springs(m, {spacing_mm, spacing_mm, spacing_mm}, true);
  d.node_mass_g = material.density_g_per_mm3 * spacing_mm * spacing_mm * spacing_mm;
  // The stable step of an interior node: a 5³ block has one (surface nodes are less stiff).
  crms::BoxLatticeOptions box;
  box.size_mm = {5 * spacing_mm, 5 * spacing_mm, 5 * spacing_mm};
  box.spacing_mm = spacing_mm;
  box.density_g_per_mm3 = material.density_g_per_mm3;
  crms::SolverConfig config;
  config.backend = crms::Backend::kCpu;
  config.materials = {m};
  const crms::Solver solver(crms::build_box_lattice(box), config);
  d.symplectic_stable_dt_s = solver.stable_time_step().symplectic_euler_s;
  return d;
}

}  // namespace tsf::app
