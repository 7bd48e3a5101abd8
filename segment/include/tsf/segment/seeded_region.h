// Region growing from seeds for a structure of interest (a vessel, a polyp, the septum…):
// the voxels connected (6-neighbourhood) to a seed through HU within [min_hu, max_hu].
#pragma once

#include "tsf/segment/segment_image_types.h"
#include "tsf/segment/segment_preset.h"

namespace tsf::segment {

/// Grows `region` on `hu` (smoothed). Throws tsf::Error naming the region and seed when a seed
/// lies outside the volume or its HU is outside the region's range.
MaskImage::Pointer grow_seeded_region(const HuImage* hu, const RegionSettings& region);

}  // namespace tsf::segment
