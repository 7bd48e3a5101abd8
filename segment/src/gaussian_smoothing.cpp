#include "tsf/segment/gaussian_smoothing.h"

#include <itkDiscreteGaussianImageFilter.h>
#include <itkImageDuplicator.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "tsf/common/error.h"
#include "tsf/segment/itk_progress_bridge.h"

namespace tsf::segment {

HuImage::Pointer gaussian_smooth(const HuImage* image, double sigma_mm, Progress* progress,
                                 double progress_from, double progress_to) {
  if (!(sigma_mm > 0.0)) {
    auto copy = itk::ImageDuplicator<HuImage>::New();
    copy->SetInputImage(image);
    copy->Update();
    return copy->GetOutput();
  }
  auto smooth = itk::DiscreteGaussianImageFilter<HuImage, HuImage>::New();
  smooth->SetInput(image);
  smooth->SetVariance(sigma_mm * sigma_mm);
  smooth->SetUseImageSpacing(true);
  smooth->SetMaximumError(0.01);
  // Kernel width cap in voxels: 8σ on the finest axis (the 1% cut lands near 5σ), odd, >= 3.
  const auto& spacing = image->GetSpacing();
  const double finest = std::min({spacing[0], spacing[1], spacing[2]});
  const int width = std::max(3, 2 * static_cast<int>(std::ceil(4.0 * sigma_mm / finest)) + 1);
  smooth->SetMaximumKernelWidth(static_cast<unsigned int>(width));
  forward_itk_progress(smooth, progress, progress_from, progress_to);
  try {
    smooth->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error("Gaussian smoothing (sigma " + std::to_string(sigma_mm) +
                " mm) failed: " + e.GetDescription());
  }
  HuImage::Pointer out = smooth->GetOutput();
  out->DisconnectPipeline();
  return out;
}

}  // namespace tsf::segment
