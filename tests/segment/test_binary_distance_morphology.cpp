// Euclidean ball morphology through distance maps matches a brute-force ball, in mm.
#include <gtest/gtest.h>

#include <cmath>

#include "segment_test_images.h"
#include "tsf/segment/filters/binary_distance_morphology_image_filter.h"

namespace tsf::segment {
namespace {

using test::at;
using test::blank_image;
using test::paint;
using Morphology = BinaryDistanceMorphologyImageFilter<MaskImage>;

MaskImage::Pointer apply(const MaskImage* mask, MorphologyOperation op, double radius,
                         bool border_is_background = false) {
  auto f = Morphology::New();
  f->SetInput(mask);
  f->SetOperation(op);
  f->SetRadiusMm(radius);
  f->SetBorderIsBackground(border_is_background);
  f->Update();
  return f->GetOutput();
}

TEST(BinaryDistanceMorphology, DilationOfAVoxelIsTheBallInMillimetres) {
  // Anisotropic spacing: the ball must be round in mm, not in voxels.
  auto mask = blank_image<MaskImage>(21, 21, 11, 0, 1.0, 1.0, 2.0);
  paint<MaskImage>(mask, 1, [](int i, int j, int k) { return i == 10 && j == 10 && k == 5; });
  const double r = 4.3;
  const auto out = apply(mask, MorphologyOperation::kDilate, r);
  int mismatches = 0, inside = 0;
  for (int k = 0; k < 11; ++k)
    for (int j = 0; j < 21; ++j)
      for (int i = 0; i < 21; ++i) {
        const double d = std::sqrt((i - 10.0) * (i - 10.0) + (j - 10.0) * (j - 10.0) +
                                   4.0 * (k - 5.0) * (k - 5.0));
        const bool expected = d <= r;
        inside += expected;
        mismatches += expected != (at<MaskImage>(out, i, j, k) != 0);
      }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(inside, 100);
}

TEST(BinaryDistanceMorphology, ErosionKeepsVoxelsFartherThanTheRadiusFromBackground) {
  auto mask = blank_image<MaskImage>(30, 30, 30, 0);
  paint<MaskImage>(mask, 1, [](int i, int j, int k) {
    return i >= 5 && i < 25 && j >= 5 && j < 25 && k >= 8 && k < 22;
  });
  const auto out = apply(mask, MorphologyOperation::kErode, 2.5);
  // Brute force: nearest background voxel of the box is straight across a face.
  int mismatches = 0;
  for (int k = 0; k < 30; ++k)
    for (int j = 0; j < 30; ++j)
      for (int i = 0; i < 30; ++i) {
        const bool in_box = i >= 5 && i < 25 && j >= 5 && j < 25 && k >= 8 && k < 22;
        const int to_bg = std::min({i - 4, 25 - i, j - 4, 25 - j, k - 7, 22 - k});
        const bool expected = in_box && to_bg > 2.5;
        mismatches += expected != (at<MaskImage>(out, i, j, k) != 0);
      }
  EXPECT_EQ(mismatches, 0);
}

TEST(BinaryDistanceMorphology, OpeningRemovesThinBridgesAndClosingFillsThinGaps) {
  auto mask = blank_image<MaskImage>(40, 20, 20, 0);
  // Two blocks joined by a 2-voxel bridge.
  paint<MaskImage>(mask, 1, [](int i, int j, int k) {
    const bool blocks = (i < 15 || i >= 25) && j >= 3 && j < 17 && k >= 3 && k < 17;
    const bool bridge = i >= 15 && i < 25 && j >= 9 && j < 11 && k >= 9 && k < 11;
    return blocks || bridge;
  });
  const auto opened = apply(mask, MorphologyOperation::kOpen, 2.0);
  EXPECT_EQ(at<MaskImage>(opened, 20, 9, 9), 0);   // bridge gone
  EXPECT_EQ(at<MaskImage>(opened, 7, 10, 10), 1);  // blocks stay
  EXPECT_EQ(at<MaskImage>(opened, 32, 10, 10), 1);
  const auto closed = apply(mask, MorphologyOperation::kClose, 6.0);
  EXPECT_EQ(at<MaskImage>(closed, 20, 6, 6), 1);  // gap beside the bridge filled
}

TEST(BinaryDistanceMorphology, BorderCountsAsBackgroundOnlyWhenAsked) {
  auto full = blank_image<MaskImage>(12, 12, 12, 1);
  const auto kept = apply(full, MorphologyOperation::kErode, 2.0);
  EXPECT_EQ(at<MaskImage>(kept, 0, 0, 0), 1);
  const auto eroded = apply(full, MorphologyOperation::kErode, 2.0, true);
  EXPECT_EQ(at<MaskImage>(eroded, 1, 6, 6), 0);  // 2 mm from the outside voxel at i = -1
  EXPECT_EQ(at<MaskImage>(eroded, 2, 6, 6), 1);  // 3 mm
  EXPECT_EQ(at<MaskImage>(eroded, 6, 6, 6), 1);
}

TEST(BinaryDistanceMorphology, ZeroRadiusAndEmptyMasksAreHandled) {
  auto mask = blank_image<MaskImage>(8, 8, 8, 0);
  paint<MaskImage>(mask, 7, [](int i, int, int) { return i < 3; });
  const auto same = apply(mask, MorphologyOperation::kDilate, 0.0);
  EXPECT_EQ(at<MaskImage>(same, 2, 4, 4), 1);  // binarised
  EXPECT_EQ(at<MaskImage>(same, 3, 4, 4), 0);
  auto empty = blank_image<MaskImage>(8, 8, 8, 0);
  EXPECT_EQ(at<MaskImage>(apply(empty, MorphologyOperation::kDilate, 3.0), 4, 4, 4), 0);
  EXPECT_EQ(at<MaskImage>(apply(empty, MorphologyOperation::kClose, 3.0), 4, 4, 4), 0);
}

}  // namespace
}  // namespace tsf::segment
