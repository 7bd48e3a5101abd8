// The one boundary between ITK files and the tissue core's VoxelVolume.
//
// A tissue volume on disk is up to three NRRD (or MHA) files sharing a prefix:
//   PREFIX-density.nrrd   float32, values in [0,1]; iso-level 0.5 is the tissue surface
//   PREFIX-labels.nrrd    uint8 TissueLabel per voxel (tsf/volume/tissue_labels.h)
//   PREFIX-weights.nrrd   4 × uint8 per voxel, material blend weights summing to 255
// Geometry (spacing, origin, direction) is the image's; all three files must share it.
#pragma once

#include <filesystem>

#include "tsf/volume/voxel_volume.h"

namespace tsf::import {

struct TissueVolumePaths {
  std::filesystem::path density, labels, weights;
  /// PREFIX -> PREFIX-density.nrrd, PREFIX-labels.nrrd, PREFIX-weights.nrrd.
  static TissueVolumePaths from_prefix(const std::filesystem::path& prefix);
};

/// Reads a density volume (any scalar pixel type, values must lie in [0,1]). When `density_path`
/// is named PREFIX-density.*, the labels and weights files beside it are read too if present;
/// without a labels file, voxels with density >= 0.5 get kLabelSoftTissue, others kLabelOutside.
/// Throws tsf::Error naming the file and what is wrong (missing, out of range, geometry mismatch).
VoxelVolume read_tissue_volume(const std::filesystem::path& density_path);

/// Writes density, labels and (when present) weights files for `prefix`, each atomically.
/// Returns the paths written.
TissueVolumePaths write_tissue_volume(const std::filesystem::path& prefix,
                                      const VoxelVolume& volume);

}  // namespace tsf::import
