// Shared set-up of the deform/cut benchmarks (bench_cut_latency, bench_coupler, bench_collision):
// the sample cranium as tissue (HU ramp over −300 ± 100 HU, the IMT benchmarks' density) read by
// the core's NRRD reader (any build, the GPU machine's included); a soft tissue model on it;
// percentiles;
// argument parsing that ignores Google Benchmark's flags (scripts/gpu-check.sh passes them).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "tsf/common/cuda_support.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/io/nrrd_volume.h"
#include "tsf/volume/analytic_volumes.h"

namespace tsf::bench {

struct BenchTissue {
  VoxelVolume volume;
  std::string name;
};

/// The cranium's HU → density ramp and the labels it implies, over a whole volume.
inline void cranium_density_from_hu(const std::int16_t* hu_int, const float* hu_float,
                                    VoxelVolume& v) {
  float* d = v.density_for_tracked_write();
  std::uint8_t* l = v.labels_for_tracked_write();
  for (std::size_t i = 0; i < v.voxel_count(); ++i) {
    const double hu = hu_int ? double(hu_int[i]) : double(hu_float[i]);
    d[i] = static_cast<float>(std::clamp(0.5 + (hu + 300.0) / 200.0, 0.0, 1.0));
    l[i] = d[i] >= 0.5f ? kLabelSoftTissue : kLabelOutside;
  }
  v.mark_all_modified();
}

/// The sample cranium as density through the HU ramp (the core's own NRRD reader, so the GPU
/// machine's build without ITK reads it too), or organ-like blobs when the file is missing.
inline BenchTissue cranium_or_blobs() {
  const std::string path =
      std::string(TSF_SOURCE_DIR) + "/data-samples/ct-head-cranium/cranium.nrrd";
  try {
    const io::NrrdVolume ct = io::read_nrrd(path);
    VoxelVolume v(ct.geometry);
    const std::vector<float> hu = ct.as_float();
    cranium_density_from_hu(nullptr, hu.data(), v);
    return {std::move(v), "cranium 256×256×108 (0.96×0.96×1.5 mm, −300 HU ramp)"};
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cranium not read (%s): %s; using organ-like blobs\n", path.c_str(),
                 e.what());
  }
  return {make_blob_volume(cube_geometry({256, 256, 256}), 7),
          "organ-like blobs 256³ (the sample cranium is missing)"};
}

/// Soft tissue (E 30 kPa, η 5 Pa·s), node spacing k voxels, gravity, the bottom 2 node layers
/// anchored (the skull base holds the face).
inline interaction::TissueModelOptions soft_tissue(int k, crms::Backend backend) {
  interaction::TissueModelOptions o;
  o.lattice.node_spacing_voxels = k;
  o.solver.materials[0].youngs_modulus_pa = 30e3;
  o.solver.materials[0].viscosity_pa_s = 5.0;
  o.solver.gravity = {0, 0, -9810};
  o.solver.backend = backend;
  o.solver.stability.kinetic_damping = 0.01;
  o.anchor = [](crms::Lattice& l) {
    const crms::LatticeGeometry& g = l.geometry();
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, g.origin.z + 1.5 * g.spacing.z});
  };
  return o;
}

inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t i = std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5));
  return v[i];
}

/// "cpu", "cuda" or "auto" → backend; "auto" picks CUDA where a device is usable.
inline crms::Backend parse_backend(const std::string& text) {
  if (text == "cpu") return crms::Backend::kCpu;
  if (text == "cuda") return crms::Backend::kCuda;
  return cuda_status().available ? crms::Backend::kCuda : crms::Backend::kCpu;
}

/// True for arguments the benchmark runner adds that these apps do not use.
inline bool ignorable_argument(const std::string& a) {
  return a.rfind("--benchmark_", 0) == 0;
}

}  // namespace tsf::bench
