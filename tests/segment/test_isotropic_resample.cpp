// Resampling to isotropic voxels keeps the physical frame: origin, direction and extent.
#include <gtest/gtest.h>

#include <itkImageRegionIteratorWithIndex.h>

#include <cmath>

#include "tsf/common/error.h"
#include "tsf/segment/isotropic_resample.h"

namespace tsf::segment {
namespace {

/// Anisotropic, rotated image whose HU is a linear function of the physical position.
HuImage::Pointer linear_field_image() {
  auto image = HuImage::New();
  HuImage::SizeType size;
  size[0] = 37;
  size[1] = 29;
  size[2] = 13;
  image->SetRegions(HuImage::RegionType(size));
  HuImage::SpacingType spacing;
  spacing[0] = 0.7;
  spacing[1] = 0.9;
  spacing[2] = 2.5;
  image->SetSpacing(spacing);
  HuImage::PointType origin;
  origin[0] = -12.3;
  origin[1] = 4.5;
  origin[2] = 100.0;
  image->SetOrigin(origin);
  HuImage::DirectionType direction;  // 30° about z
  const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
  direction.SetIdentity();
  direction[0][0] = c;
  direction[0][1] = -s;
  direction[1][0] = s;
  direction[1][1] = c;
  image->SetDirection(direction);
  image->Allocate();
  itk::ImageRegionIteratorWithIndex<HuImage> it(image, image->GetLargestPossibleRegion());
  for (; !it.IsAtEnd(); ++it) {
    HuImage::PointType p;
    image->TransformIndexToPhysicalPoint(it.GetIndex(), p);
    it.Set(static_cast<float>(3.0 * p[0] - 2.0 * p[1] + 0.5 * p[2]));
  }
  return image;
}

TEST(IsotropicResample, PreservesOriginDirectionAndPhysicalExtent) {
  const auto input = linear_field_image();
  for (double voxel : {0.5, 0.7, 1.3}) {
    SCOPED_TRACE("voxel " + std::to_string(voxel) + " mm");
    const auto out = resample_isotropic(input, voxel, full_index_box(input));
    for (int a = 0; a < 3; ++a) {
      EXPECT_DOUBLE_EQ(out->GetSpacing()[a], voxel);
      EXPECT_NEAR(out->GetOrigin()[a], input->GetOrigin()[a], 1e-9);
    }
    EXPECT_EQ(out->GetDirection(), input->GetDirection());
    // Extent of voxel centres along each axis: never beyond the input's, short by < one voxel.
    const auto in_size = input->GetLargestPossibleRegion().GetSize();
    const auto out_size = out->GetLargestPossibleRegion().GetSize();
    for (int a = 0; a < 3; ++a) {
      const double in_extent = (in_size[a] - 1) * input->GetSpacing()[a];
      const double out_extent = (out_size[a] - 1) * voxel;
      EXPECT_LE(out_extent, in_extent + 1e-9);
      EXPECT_GT(out_extent, in_extent - voxel);
    }
  }
}

TEST(IsotropicResample, SamplesEachOutputVoxelAtItsPhysicalPosition) {
  // Linear interpolation reproduces a linear field exactly, so every output voxel must hold the
  // field's value at its own physical position: a wrong origin, direction or spacing shows.
  const auto input = linear_field_image();
  const auto out = resample_isotropic(input, 0.6, full_index_box(input));
  itk::ImageRegionIteratorWithIndex<HuImage> it(out, out->GetLargestPossibleRegion());
  double worst = 0.0;
  for (; !it.IsAtEnd(); ++it) {
    HuImage::PointType p;
    out->TransformIndexToPhysicalPoint(it.GetIndex(), p);
    const double expected = 3.0 * p[0] - 2.0 * p[1] + 0.5 * p[2];
    worst = std::max(worst, std::abs(static_cast<double>(it.Get()) - expected));
  }
  EXPECT_LT(worst, 1e-3);
}

TEST(IsotropicResample, SubBoxStartsAtItsFirstCorner) {
  const auto input = linear_field_image();
  IndexBox box{{3.5, 2.0, 1.25}, {20.0, 17.0, 9.0}};
  const auto out = resample_isotropic(input, 0.5, box);
  itk::ContinuousIndex<double, 3> first;
  for (int a = 0; a < 3; ++a) first[a] = box.first[a];
  HuImage::PointType expected;
  input->TransformContinuousIndexToPhysicalPoint(first, expected);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(out->GetOrigin()[a], expected[a], 1e-9);
}

TEST(IsotropicResample, FinestSpacingIsTheDefaultVoxel) {
  EXPECT_DOUBLE_EQ(finest_spacing(linear_field_image()), 0.7);
}

TEST(IsotropicResample, RejectsNonPositiveVoxelSize) {
  const auto input = linear_field_image();
  EXPECT_THROW(resample_isotropic(input, 0.0, full_index_box(input)), Error);
  EXPECT_THROW(resample_isotropic(input, -1.0, full_index_box(input)), Error);
}

}  // namespace
}  // namespace tsf::segment
