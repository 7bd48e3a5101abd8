// What the viewer's slice planes cut: a scalar volume shown in grey through a window, with the
// tissue labels overlaid in their colours (label_colours.h). Usually the CT (HU) the tissue was
// segmented from, with the segmentation's labels resampled onto the CT grid; without a CT, the
// tissue's own density. Tissue space, axis-aligned, mm.
//   values  #voxels (x fastest), any unit (HU for a CT, 0..1 for a density)
//   labels  #voxels or empty (no overlay)
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tsf/volume/voxel_volume.h"

namespace tsf::viewer {

struct SliceVolume {
  VolumeGeometry geometry;
  std::vector<float> values;
  std::vector<std::uint8_t> labels;
  double window_low = 0, window_high = 1;  ///< values at black and white
  std::string description;                 ///< e.g. "CT cranium.nrrd (HU)", for the HUD

  /// Throws tsf::Error when the arrays do not match the geometry or the window is empty.
  void validate() const;
};

/// The tissue volume's density (0..1) with its labels.
SliceVolume slices_from_tissue(const VoxelVolume& volume);

/// A CT (HU, x fastest) with `labels`' labels resampled onto it (nearest voxel by tissue-space
/// position; outside `labels`' grid: none). Window: −600 … 1200 HU (air black, soft tissue grey,
/// bone white: a sinus window).
SliceVolume slices_from_ct(const VolumeGeometry& ct_geometry, std::vector<float> hu,
                           const VoxelVolume* labels, std::string description);

}  // namespace tsf::viewer
