// Gaussian smoothing with σ in mm (discrete Gaussian kernel, separable, image spacing honoured).
//
// The kernel is ITK's discrete Gaussian (itk::GaussianOperator, Lindeberg's e^{−t}·I_n(t)), the
// one itk::DiscreteGaussianImageFilter uses; unlike the recursive (Deriche) approximation it stays
// exact for σ below one voxel, where HU smoothing for sub-voxel surfaces lives. The passes are our
// own row-wise loops (contiguous inner loop over x, parallel over rows or slices): the same result
// as the ITK filter, which bench_segment --peers times it against.
#pragma once

#include <array>

#include "tsf/common/progress.h"
#include "tsf/segment/segment_image_types.h"

namespace tsf::segment {

/// Returns a smoothed copy of `image`; σ <= 0 returns an unsmoothed copy. The kernel is cut where
/// its tail falls below 1% of its mass (ITK's MaximumError 0.01), near 5σ wide.
HuImage::Pointer gaussian_smooth(const HuImage* image, double sigma_mm,
                                 Progress* progress = nullptr, double progress_from = 0.0,
                                 double progress_to = 1.0);

/// Per-axis σ (mm, index axes i, j, k); an axis with σ <= 0 is left alone.
HuImage::Pointer gaussian_smooth(const HuImage* image, const std::array<double, 3>& sigma_mm,
                                 Progress* progress = nullptr, double progress_from = 0.0,
                                 double progress_to = 1.0);

}  // namespace tsf::segment
