// Gaussian smoothing with σ in mm (sampled discrete Gaussian, separable, image spacing honoured).
//
// itk::DiscreteGaussianImageFilter rather than the recursive (Deriche) approximation: the latter is
// inaccurate for σ below about one voxel, which is where HU smoothing for sub-voxel surfaces lives.
#pragma once

#include "tsf/common/progress.h"
#include "tsf/segment/segment_image_types.h"

namespace tsf::segment {

/// Returns a smoothed copy of `image`; σ <= 0 returns an unsmoothed copy. The kernel is cut where
/// its tail falls below 1% of its mass (ITK's MaximumError 0.01), near 5σ wide.
HuImage::Pointer gaussian_smooth(const HuImage* image, double sigma_mm,
                                 Progress* progress = nullptr, double progress_from = 0.0,
                                 double progress_to = 1.0);

}  // namespace tsf::segment
