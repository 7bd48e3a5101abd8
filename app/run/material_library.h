// The tissue material library (materials/tissues.yaml): literature Young's modulus, damping and
// density of each tissue, with its sources, and the CRMS lattice parameters derived from them.
//
//   const MaterialLibrary lib = read_material_library("materials/tissues.yaml");
//   const LibraryMaterial& m = lib.get("cartilage");           // error names the known ids
//   crms::Material lattice_material = m.crms_material();
//   DerivedLatticeParameters d = derive_lattice_parameters(m, 1.0);  // springs at 1 mm
//
// Units: Pa, s, g/mm³ (tissue core units, docs/materials.md).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "tsf/crms/calibration.h"
#include "tsf/crms/spring_constants.h"

namespace tsf::app {

struct MaterialSource {
  std::string citation;  ///< author(s), year, title, journal
  std::string reports;   ///< what was taken from it
};

struct LibraryMaterial {
  std::string id;  ///< key in the library (nasal_mucosa, cartilage, …)
  std::string name;
  std::uint8_t label = 1;        ///< default tissue label (tissue_labels.h)
  double youngs_modulus_pa = 0;  ///< E, Pa
  double shear_modulus_pa = 0;   ///< G, Pa; 0 = E/2
  double damping_time_s = 0;     ///< τ = η/E, s
  double density_g_per_mm3 = 0;  ///< ρ
  double poisson_ratio = 0;      ///< literature ν (the lattice's is 0)
  std::vector<MaterialSource> sources;
  std::string notes;

  /// The CRMS material: E, G, η = E·τ, ρ.
  crms::Material crms_material() const;
};

/// How fast tools remove a tissue label, relative to soft tissue (`removal_rates` of the library):
/// the ablation and the cut rate multiply the tool's removal (interaction/tool_stroke.h).
struct LabelRemovalRates {
  std::uint8_t label = 0;
  double ablation = 1.0;                ///< [0, 1]
  double cut = 1.0;                     ///< [0, 1]
  std::vector<MaterialSource> sources;  ///< literature, where it exists
  std::string assumption;               ///< why the values were chosen, where no source exists
};

struct MaterialLibrary {
  std::filesystem::path file;
  std::vector<LibraryMaterial> materials;        ///< file order
  std::vector<LabelRemovalRates> removal_rates;  ///< file order, each label once
  const LibraryMaterial* find(const std::string& id) const;
  /// Throws tsf::Error naming `id` and the known ids.
  const LibraryMaterial& get(const std::string& id) const;
};

/// Reads and validates a library file. Throws tsf::Error "FILE: key.path: what is wrong".
MaterialLibrary read_material_library(const std::filesystem::path& file);

/// The bundled library: materials/tissues.yaml found from the working directory, the
/// executable's folder or the source tree (TSF_SOURCE_DIR); throws naming where it looked.
std::filesystem::path default_material_library_path();

/// Lattice parameters of a material at a cubic spacing h through the CRMS calibration
/// (tsf/crms/calibration.h), symmetric angular reactions.
struct DerivedLatticeParameters {
  double spacing_mm = 0;
  crms::SpringConstants springs;  ///< ks (µN), kd (µN·s), kθ (µN·mm/rad), cθ (µN·mm·s/rad)
  double node_mass_g = 0;         ///< ρ·h³
  double symplectic_stable_dt_s = 0;  ///< interior node, symplectic Euler (stable_time_step.h)
};
DerivedLatticeParameters derive_lattice_parameters(const LibraryMaterial& material,
                                                   double spacing_mm);

}  // namespace tsf::app
