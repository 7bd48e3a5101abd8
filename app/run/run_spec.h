// The `pipeline:` section of a scene: what `tsf run` does before the scene's simulation —
// where the CT comes from, how it is segmented, which library material the tissue gets, and
// which outputs it writes. Read strictly (unknown key, wrong type or out-of-range value = error
// naming the key path); schema in docs/scenes.md.
//
//   pipeline:
//     source: {ct: ../data-samples/ct-head-cranium/cranium.nrrd}   # volume file or DICOM folder
//     # source: {ct: /scans/patient-17, series: 1.2.840.113619.2.55.3}  # one DICOM series of many
//     segmentation: {preset: sinus, voxel_mm: 0}
//     material: turbinate_soft_tissue          # id in the material library
//     outputs: {folder: ../out/sinus, report: true, meshes: true, plots: true, energy_every: 1}
#pragma once

#include <filesystem>
#include <string>

namespace tsf::app {

struct RunSpec {
  bool present = false;
  // source
  std::filesystem::path ct;  ///< CT volume (NRRD, MetaImage, NIfTI) or DICOM folder/DICOMDIR
  /// DICOM SeriesInstanceUID when the folder holds several series (import's series_uid); empty
  /// = the only usable series. `tsf run --ct/--series` replace ct and series for one run.
  std::string series;
  // segmentation
  std::string preset = "sinus";  ///< preset name or YAML path (tsf segment --preset)
  double voxel_mm = 0;           ///< isotropic voxel size; 0 = the preset's
  double smoothing_mm = -1;      ///< Gaussian sigma on HU; < 0 = the preset's
  // materials
  std::filesystem::path material_library;  ///< empty = the bundled materials/tissues.yaml
  std::string material;                    ///< library id; empty = the scene's `material:`
  // outputs
  std::filesystem::path folder;  ///< empty = out/<scene name> under the working directory
  bool report = true;            ///< run-report.md (+ PNG plots) and run-report.json
  bool plots = true;             ///< gnuplot PNGs in the report
  bool meshes = true;            ///< rest and final surface meshes (PLY; + export formats if built)
  int energy_every = 1;          ///< record energy every N frames (1 = each frame)
};

/// Reads the `pipeline` section of a scene file (absent: present = false). Relative paths
/// resolve against the scene's folder. Throws tsf::Error "FILE: pipeline.key: what is wrong".
RunSpec read_run_spec(const std::filesystem::path& scene_file);

}  // namespace tsf::app
