// The region of interest a segmentation is cropped to, as a box of the input's index space.
//
// RoiMode::kBox: the physical (LPS, mm) box's eight corners mapped into the input's continuous
// index space, bounded, clamped to the image. RoiMode::kBody: the bounding box of the body mask
// (BodyMaskImageFilter with the preset's body settings, computed on the input grid) grown by
// margin_mm. Cropping happens before resampling, so the finer isotropic grid is only allocated
// over the region that is kept.
#pragma once

#include "tsf/common/progress.h"
#include "tsf/segment/isotropic_resample.h"
#include "tsf/segment/segment_preset.h"

namespace tsf::segment {

/// The index axis (0, 1, 2) of `image` closest to the patient's superior-inferior (LPS z) axis:
/// slices normal to it are axial.
unsigned int axial_slice_axis(const HuImage* image);

/// Throws tsf::Error when a box does not overlap the image (naming the box and the image's
/// extent in mm) or no body is found.
IndexBox region_of_interest(const HuImage* input, const RoiSettings& roi,
                            const BodyMaskSettings& body, Progress* progress = nullptr);

}  // namespace tsf::segment
