#include "tsf/segment/isotropic_resample.h"

#include <itkIdentityTransform.h>
#include <itkLinearInterpolateImageFunction.h>
#include <itkResampleImageFilter.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "tsf/common/error.h"
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

HuImage::Pointer resample_isotropic(const HuImage* input, double voxel_mm, const IndexBox& box,
                                    Progress* progress) {
  const HuImage::Pointer grid = make_isotropic_grid(input, voxel_mm, box);
  auto resample = itk::ResampleImageFilter<HuImage, HuImage, double>::New();
  resample->SetInput(input);
  resample->SetTransform(itk::IdentityTransform<double, 3>::New());
  resample->SetInterpolator(itk::LinearInterpolateImageFunction<HuImage, double>::New());
  resample->SetOutputParametersFromImage(grid);
  // Every output sample lies inside the input's sample hull; air is the safe value regardless.
  resample->SetDefaultPixelValue(-1000.0f);
  forward_itk_progress(resample, progress);
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
