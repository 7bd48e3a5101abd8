#include "tsf/segment/seeded_region.h"

#include <itkConnectedThresholdImageFilter.h>

#include <sstream>

#include "tsf/common/error.h"

namespace tsf::segment {

MaskImage::Pointer grow_seeded_region(const HuImage* hu, const RegionSettings& region) {
  auto grow = itk::ConnectedThresholdImageFilter<HuImage, MaskImage>::New();
  grow->SetInput(hu);
  grow->SetLower(static_cast<float>(region.min_hu));
  grow->SetUpper(static_cast<float>(region.max_hu));
  grow->SetReplaceValue(1);
  grow->SetConnectivity(itk::ConnectedThresholdImageFilter<HuImage, MaskImage>::FaceConnectivity);
  for (std::size_t i = 0; i < region.seeds_mm.size(); ++i) {
    const Vec3d& s = region.seeds_mm[i];
    HuImage::PointType p;
    p[0] = s.x;
    p[1] = s.y;
    p[2] = s.z;
    HuImage::IndexType index;
    std::ostringstream where;
    where << "region '" << region.name << "': seed " << i << " at (" << s.x << ", " << s.y << ", "
          << s.z << ") mm";
    if (!hu->TransformPhysicalPointToIndex(p, index))
      throw Error(where.str() + " lies outside the segmented volume (after the ROI crop)");
    const float value = hu->GetPixel(index);
    if (static_cast<double>(value) < region.min_hu || static_cast<double>(value) > region.max_hu) {
      where << " has " << value << " HU (smoothed), outside the region's range " << region.min_hu
            << " .. " << region.max_hu << " HU";
      throw Error(where.str());
    }
    grow->AddSeed(index);
  }
  try {
    grow->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error("region '" + region.name + "': region growing failed: " + e.GetDescription());
  }
  MaskImage::Pointer mask = grow->GetOutput();
  mask->DisconnectPipeline();
  return mask;
}

}  // namespace tsf::segment
