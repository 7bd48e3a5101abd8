// `tsf run [SCENE]`: the main job (README). Default: the bundled sinus scene on the sample
// cranium CT: import → segment → surface → lattice → scripted interaction → outputs and a report
// (app/run/run_pipeline.h). `tsf run SCENE --ct PATH [--series UID]` runs the scene on another
// patient's CT (docs/patients.md). `tsf run --materials` prints the material library with the
// lattice parameters the CRMS calibration derives from it (docs/materials.md).
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "commands.h"
#include "run/material_library.h"
#include "run/run_pipeline.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::app {
namespace {

struct RunArguments {
  std::string scene;
  std::string ct;
  std::string series;
  std::string output;
  std::string backend;
  double duration_s = -1;
  double voxel_mm = -1;
  bool quiet = false;
  bool force = false;
  bool materials = false;
  std::string library;
  double spacing_mm = 1.0;
};

std::string g(double v, int significant = 3) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*g", significant, v);
  return b;
}

/// The library as a Markdown table with the derived lattice parameters at `spacing_mm`.
void print_materials(const RunArguments& a) {
  const MaterialLibrary lib = read_material_library(
      a.library.empty() ? default_material_library_path() : std::filesystem::path(a.library));
  std::printf("Material library %s, lattice spacing h = %s mm (symmetric angular reactions).\n\n",
              lib.file.string().c_str(), g(a.spacing_mm).c_str());
  std::printf(
      "| id | E (Pa) | τ = η/E (s) | ρ (g/mm³) | ν (lit.) | ks (µN) | kd (µN·s) | kθ (µN·mm/rad) "
      "| cθ (µN·mm·s/rad) | node mass (g) | stable dt, symplectic (s) |\n"
      "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
  for (const LibraryMaterial& m : lib.materials) {
    const DerivedLatticeParameters d = derive_lattice_parameters(m, a.spacing_mm);
    std::printf("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", m.id.c_str(),
                g(m.youngs_modulus_pa).c_str(), g(m.damping_time_s).c_str(),
                g(m.density_g_per_mm3).c_str(), g(m.poisson_ratio).c_str(),
                g(d.springs.ks_linear[0]).c_str(), g(d.springs.kd_linear[0]).c_str(),
                g(d.springs.k_angular[0]).c_str(), g(d.springs.c_angular[0]).c_str(),
                g(d.node_mass_g).c_str(), g(d.symplectic_stable_dt_s).c_str());
  }
  if (lib.removal_rates.empty()) return;
  std::printf(
      "\nTool removal rates per tissue label (scenes: `tissue.removal.rates: library`; labels not "
      "listed: 1):\n\n| label | ablation | cut | basis |\n| --- | ---: | ---: | --- |\n");
  for (const LabelRemovalRates& r : lib.removal_rates) {
    std::string basis;
    for (const MaterialSource& s : r.sources) basis += (basis.empty() ? "" : "; ") + s.citation;
    if (!r.assumption.empty())
      basis += (basis.empty() ? "assumption: " : "; assumption: ") + r.assumption;
    std::printf("| %s | %s | %s | %s |\n", tissue_label_key(r.label).c_str(), g(r.ablation).c_str(),
                g(r.cut).c_str(), basis.c_str());
  }
}

}  // namespace

void add_run_command(CLI::App& app) {
  auto args = std::make_shared<RunArguments>();
  CLI::App* sub = app.add_subcommand(
      "run",
      "The main job: run a scene end to end (default: the bundled sinus scene on the sample "
      "cranium CT): import, segment, surface, lattice, scripted interaction, meshes and a report");
  sub->add_option("scene", args->scene,
                  "scene file (YAML, docs/scenes.md); default: scenes/sinus.yaml of the checkout");
  sub->add_option("--ct", args->ct,
                  "another patient's CT for this run: a DICOM folder, DICOMDIR or file, or a "
                  "NRRD/MHA/NIfTI volume; replaces the scene's pipeline.source.ct and its series "
                  "(docs/patients.md)")
      ->check(CLI::ExistingPath);
  sub->add_option("--series", args->series,
                  "DICOM SeriesInstanceUID to use when the CT folder holds several (`tsf info "
                  "FOLDER` lists them); replaces pipeline.source.series");
  sub->add_option("-o,--output", args->output,
                  "output folder: everything the run writes goes here (default: "
                  "pipeline.outputs.folder of the scene, else out/<scene name>); must be new or "
                  "empty, see --force");
  sub->add_option("--duration", args->duration_s,
                  "simulated seconds of the script (overrides script.duration; short CI runs)")
      ->check(CLI::Range(0.0, 3600.0));
  sub->add_option("--voxel-mm", args->voxel_mm,
                  "isotropic voxel size of the segmentation, mm (overrides the scene)")
      ->check(CLI::Range(0.05, 10.0));
  sub->add_option("--backend", args->backend, "CRMS backend: cpu, cuda or auto (default: scene)");
  sub->add_flag("--force", args->force,
                "replace the files of an earlier tsf run in the output folder (a folder of other "
                "files is never emptied)");
  sub->add_flag("-q,--quiet", args->quiet, "no progress or summary on the terminal");
  sub->add_flag("--materials", args->materials,
                "print the material library with its derived lattice parameters and exit");
  sub->add_option("--library", args->library,
                  "material library file for --materials (default: materials/tissues.yaml)");
  sub->add_option("--spacing", args->spacing_mm, "lattice spacing for --materials, mm")
      ->check(CLI::Range(0.01, 100.0));
  sub->callback([args] {
    if (args->materials) {
      print_materials(*args);
      return;
    }
    RunOptions o;
    o.scene = args->scene.empty() ? default_scene_path() : std::filesystem::path(args->scene);
    o.output_folder = args->output;
    o.ct = args->ct;
    o.series = args->series;
    if (args->duration_s >= 0) o.duration_s = args->duration_s;
    if (args->voxel_mm > 0) o.voxel_mm = args->voxel_mm;
    o.backend = args->backend;
    o.quiet = args->quiet;
    o.force = args->force;
    if (!o.quiet) std::printf("tsf run: scene %s\n", o.scene.string().c_str());
    run_pipeline(o);
  });
}

}  // namespace tsf::app
