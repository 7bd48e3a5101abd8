#include "tsf/segment/isotropic_resample.h"

#include <itkIdentityTransform.h>
#include <itkLinearInterpolateImageFunction.h>
#include <itkRegionOfInterestImageFilter.h>
#include <itkResampleImageFilter.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "tsf/common/error.h"
#include "tsf/segment/gaussian_smoothing.h"
#include "tsf/segment/itk_progress_bridge.h"

namespace tsf::segment {

IndexBox full_index_box(const HuImage* image) {
  const auto size = image->GetLargestPossibleRegion().GetSize();
  const auto start = image->GetLargestPossibleRegion().GetIndex();
  IndexBox box;
  for (int a = 0; a < 3; ++a) {
    box.first[a] = static_cast<double>(start[a]);
    box.last[a] = static_cast<double>(start[a]) + static_cast<double>(size[a]) - 1.0;
  }
  return box;
}

double finest_spacing(const HuImage* image) {
  const auto& s = image->GetSpacing();
  return std::min({s[0], s[1], s[2]});
}

HuImage::Pointer make_isotropic_grid(const HuImage* input, double voxel_mm, const IndexBox& box) {
  if (!(voxel_mm > 0.0) || !std::isfinite(voxel_mm))
    throw Error("isotropic voxel size must be positive, got " + std::to_string(voxel_mm) + " mm");
  const auto& spacing = input->GetSpacing();
  HuImage::SizeType size;
  double count = 1.0;
  for (int a = 0; a < 3; ++a) {
    if (!(box.last[a] >= box.first[a]))
      throw Error("resampling box is empty along axis " + std::to_string(a));
    // The small epsilon keeps an exact multiple (e.g. 1.5 mm over 0.5 mm voxels) from losing its
    // last sample to rounding.
    const double steps = std::floor((box.last[a] - box.first[a]) * spacing[a] / voxel_mm + 1e-6);
    size[a] = static_cast<itk::SizeValueType>(steps) + 1;
    count *= static_cast<double>(size[a]);
  }
  if (count > 2147483647.0)
    throw Error("isotropic grid of " + std::to_string(voxel_mm) + " mm would hold " +
                std::to_string(static_cast<long long>(count)) +
                " voxels (over 2^31); choose a larger voxel size (--voxel-mm) or a smaller ROI");

  HuImage::PointType origin;
  itk::ContinuousIndex<double, 3> first;
  for (int a = 0; a < 3; ++a) first[a] = box.first[a];
  input->TransformContinuousIndexToPhysicalPoint(first, origin);
  HuImage::SpacingType iso;
  iso.Fill(voxel_mm);

  auto grid = HuImage::New();
  grid->SetRegions(HuImage::RegionType(size));
  grid->SetOrigin(origin);
  grid->SetSpacing(iso);
  grid->SetDirection(input->GetDirection());
  return grid;
}

std::array<double, 3> antialias_sigma_mm(const HuImage* input, double voxel_mm) {
  std::array<double, 3> sigma{};
  for (int a = 0; a < 3; ++a) {
    const double s = input->GetSpacing()[a];
    sigma[a] = voxel_mm > s ? std::sqrt((voxel_mm * voxel_mm - s * s) / 12.0) : 0.0;
  }
  return sigma;
}

HuImage::Pointer resample_isotropic(const HuImage* input, double voxel_mm, const IndexBox& box,
                                    bool antialias, Progress* progress) {
  const HuImage::Pointer grid = make_isotropic_grid(input, voxel_mm, box);

  // Prefilter the box's neighbourhood (4σ + 1 voxels around it) when coarsening.
  HuImage::ConstPointer source = input;
  const std::array<double, 3> sigma =
      antialias ? antialias_sigma_mm(input, voxel_mm) : std::array<double, 3>{};
  if (sigma[0] > 0.0 || sigma[1] > 0.0 || sigma[2] > 0.0) {
    const IndexBox full = full_index_box(input);
    HuImage::IndexType start;
    HuImage::SizeType size;
    for (int a = 0; a < 3; ++a) {
      const double pad = std::ceil(4.0 * sigma[a] / input->GetSpacing()[a]) + 1.0;
      const double lo = std::max(full.first[a], std::floor(box.first[a]) - pad);
      const double hi = std::min(full.last[a], std::ceil(box.last[a]) + pad);
      start[a] = static_cast<itk::IndexValueType>(lo);
      size[a] = static_cast<itk::SizeValueType>(hi - lo + 1.0);
    }
    auto crop = itk::RegionOfInterestImageFilter<HuImage, HuImage>::New();
    crop->SetInput(input);
    crop->SetRegionOfInterest(HuImage::RegionType(start, size));
    try {
      crop->Update();
    } catch (const itk::ExceptionObject& e) {
      throw Error(std::string("resampling: cropping the region of interest failed: ") +
                  e.GetDescription());
    }
    source = gaussian_smooth(crop->GetOutput(), sigma, progress, 0.0, 0.5);
  }

  auto resample = itk::ResampleImageFilter<HuImage, HuImage, double>::New();
  resample->SetInput(source);
  resample->SetTransform(itk::IdentityTransform<double, 3>::New());
  resample->SetInterpolator(itk::LinearInterpolateImageFunction<HuImage, double>::New());
  resample->SetOutputParametersFromImage(grid);
  // Every output sample lies inside the input's sample hull; air is the safe value regardless.
  resample->SetDefaultPixelValue(-1000.0f);
  forward_itk_progress(resample, progress, source == input ? 0.0 : 0.5, 1.0);
  try {
    resample->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("resampling to isotropic voxels failed: ") + e.GetDescription());
  }
  HuImage::Pointer out = resample->GetOutput();
  out->DisconnectPipeline();
  return out;
}

}  // namespace tsf::segment
