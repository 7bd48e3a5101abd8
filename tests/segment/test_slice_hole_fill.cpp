#include <gtest/gtest.h>

#include <cmath>

#include "segment_test_images.h"
#include "tsf/segment/filters/slice_hole_fill_image_filter.h"

namespace tsf::segment {
namespace {

using test::at;
using test::blank_image;
using test::paint;

MaskImage::Pointer fill(const MaskImage* mask, unsigned int axis) {
  auto f = SliceHoleFillImageFilter<MaskImage>::New();
  f->SetInput(mask);
  f->SetSliceAxis(axis);
  f->Update();
  return f->GetOutput();
}

/// A tube along k: an annulus in every axial slice (open at both ends in 3-D).
MaskImage::Pointer tube(bool with_gap) {
  auto mask = blank_image<MaskImage>(30, 30, 10, 0);
  paint<MaskImage>(mask, 1, [with_gap](int i, int j, int) {
    const double r = std::hypot(i - 15.0, j - 15.0);
    const bool ring = r >= 8.0 && r < 11.0;
    const bool gap = with_gap && j >= 14 && j <= 16 && i > 15;
    return ring && !gap;
  });
  return mask;
}

TEST(SliceHoleFill, FillsRegionsEnclosedInTheSliceEvenWhenOpenIn3D) {
  const auto filled = fill(tube(false), 2);
  for (int k = 0; k < 10; ++k) EXPECT_EQ(at<MaskImage>(filled, 15, 15, k), 1) << "slice " << k;
  EXPECT_EQ(at<MaskImage>(filled, 1, 1, 5), 0);  // outside stays outside
}

TEST(SliceHoleFill, LeavesRegionsThatReachTheSliceBorder) {
  const auto filled = fill(tube(true), 2);
  EXPECT_EQ(at<MaskImage>(filled, 15, 15, 5), 0);
}

TEST(SliceHoleFill, OnlyFillsAlongTheChosenAxis) {
  // Across the tube's axis the lumen reaches the border (the tube's open ends).
  const auto filled = fill(tube(false), 0);
  EXPECT_EQ(at<MaskImage>(filled, 15, 15, 5), 0);
}

}  // namespace
}  // namespace tsf::segment
