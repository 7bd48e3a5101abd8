#include "tsf/segment/roi_crop.h"

#include <itkImageRegionConstIteratorWithIndex.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "tsf/common/error.h"
#include "tsf/segment/filters/body_mask_image_filter.h"
#include "tsf/segment/itk_progress_bridge.h"

namespace tsf::segment {

namespace {

std::string format_point(const Vec3d& p) {
  std::ostringstream s;
  s.precision(5);
  s << "(" << p.x << ", " << p.y << ", " << p.z << ")";
  return s.str();
}

/// Physical bounding box of the image's voxel centres, mm.
void physical_extent(const HuImage* image, Vec3d& lo, Vec3d& hi) {
  const IndexBox full = full_index_box(image);
  lo = {std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
        std::numeric_limits<double>::max()};
  hi = -lo;
  for (int corner = 0; corner < 8; ++corner) {
    itk::ContinuousIndex<double, 3> c;
    for (int a = 0; a < 3; ++a) c[a] = (corner >> a) & 1 ? full.last[a] : full.first[a];
    HuImage::PointType p;
    image->TransformContinuousIndexToPhysicalPoint(c, p);
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
}

IndexBox clamp_to_image(const HuImage* image, IndexBox box) {
  const IndexBox full = full_index_box(image);
  for (int a = 0; a < 3; ++a) {
    box.first[a] = std::max(box.first[a], full.first[a]);
    box.last[a] = std::min(box.last[a], full.last[a]);
  }
  return box;
}

}  // namespace

unsigned int axial_slice_axis(const HuImage* image) {
  const auto& d = image->GetDirection();
  unsigned int best = 2;
  double best_z = -1.0;
  for (unsigned int c = 0; c < 3; ++c)
    if (std::abs(d[2][c]) > best_z) {
      best_z = std::abs(d[2][c]);
      best = c;
    }
  return best;
}

IndexBox region_of_interest(const HuImage* input, const RoiSettings& roi,
                            const BodyMaskSettings& body, Progress* progress) {
  if (roi.mode == RoiMode::kBox) {
    IndexBox box;
    for (int a = 0; a < 3; ++a) {
      box.first[a] = std::numeric_limits<double>::max();
      box.last[a] = std::numeric_limits<double>::lowest();
    }
    for (int corner = 0; corner < 8; ++corner) {
      HuImage::PointType p;
      for (int a = 0; a < 3; ++a) p[a] = (corner >> a) & 1 ? roi.box_max_mm[a] : roi.box_min_mm[a];
      const auto c = input->TransformPhysicalPointToContinuousIndex<double, double>(p);
      for (int a = 0; a < 3; ++a) {
        box.first[a] = std::min(box.first[a], c[a]);
        box.last[a] = std::max(box.last[a], c[a]);
      }
    }
    const IndexBox clamped = clamp_to_image(input, box);
    for (int a = 0; a < 3; ++a)
      if (!(clamped.first[a] <= clamped.last[a])) {
        Vec3d lo, hi;
        physical_extent(input, lo, hi);
        throw Error("region of interest " + format_point(roi.box_min_mm) + " .. " +
                    format_point(roi.box_max_mm) +
                    " mm does not overlap the volume, whose voxel "
                    "centres span " +
                    format_point(lo) + " .. " + format_point(hi) + " mm");
      }
    if (progress) progress->set_fraction(1.0);
    return clamped;
  }

  // Body: the mask's bounding box on the input grid, grown by the margin.
  auto mask = BodyMaskImageFilter<HuImage, MaskImage>::New();
  mask->SetInput(input);
  mask->SetThresholdHu(body.threshold_hu);
  mask->SetOpeningRadiusMm(body.opening_radius_mm);
  mask->SetClosingRadiusMm(0.0);
  mask->SetFillHoles(false);  // the bounding box does not depend on holes
  mask->SetMarginMm(0.0);
  mask->SetSliceAxis(axial_slice_axis(input));
  forward_itk_progress(mask, progress);
  try {
    mask->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error(std::string("region of interest: ") + e.GetDescription());
  }
  IndexBox box;
  for (int a = 0; a < 3; ++a) {
    box.first[a] = std::numeric_limits<double>::max();
    box.last[a] = std::numeric_limits<double>::lowest();
  }
  const MaskImage* m = mask->GetOutput();
  itk::ImageRegionConstIteratorWithIndex<MaskImage> it(m, m->GetLargestPossibleRegion());
  for (; !it.IsAtEnd(); ++it) {
    if (it.Get() == 0) continue;
    const auto idx = it.GetIndex();
    for (int a = 0; a < 3; ++a) {
      box.first[a] = std::min(box.first[a], static_cast<double>(idx[a]));
      box.last[a] = std::max(box.last[a], static_cast<double>(idx[a]));
    }
  }
  const auto& spacing = input->GetSpacing();
  for (int a = 0; a < 3; ++a) {
    const double grow = std::ceil(roi.margin_mm / spacing[a]);
    box.first[a] -= grow;
    box.last[a] += grow;
  }
  return clamp_to_image(input, box);
}

}  // namespace tsf::segment
