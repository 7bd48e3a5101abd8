// The body mask keeps the patient, drops the table, and takes in air spaces inside the head.
#include <gtest/gtest.h>

#include <cmath>

#include "segment_test_images.h"
#include "tsf/segment/filters/body_mask_image_filter.h"

namespace tsf::segment {
namespace {

using test::at;
using test::blank_image;
using test::paint;

/// A head (ellipsoid, 40 HU) with an air cavity that opens downward (along −k) through a
/// "nostril" channel, lying 3 mm above a table (0 HU) touched only by a thin strap.
HuImage::Pointer head_on_table() {
  auto hu = blank_image<HuImage>(80, 80, 64, -1000.0f);
  auto in_head = [](int i, int j, int k) {
    const double x = (i - 40) / 25.0, y = (j - 32) / 30.0, z = (k - 34) / 24.0;
    return x * x + y * y + z * z <= 1.0;
  };
  paint<HuImage>(hu, 40.0f, in_head);
  paint<HuImage>(hu, -1000.0f, [](int i, int j, int k) {
    const bool cavity = std::pow(i - 40, 2) + std::pow(j - 20, 2) + std::pow(k - 30, 2) <= 36.0;
    const bool channel = std::hypot(i - 40.0, j - 20.0) <= 1.5 && k < 30;
    return cavity || channel;
  });
  paint<HuImage>(hu, 0.0f, [](int, int j, int) { return j >= 65 && j <= 70; });  // table
  paint<HuImage>(hu, 0.0f, [](int i, int j, int k) {                             // strap
    return i >= 39 && i <= 40 && j >= 60 && j < 65 && k >= 33 && k <= 34;
  });
  return hu;
}

MaskImage::Pointer body_mask(const HuImage* hu, bool fill_holes) {
  auto f = BodyMaskImageFilter<HuImage, MaskImage>::New();
  f->SetInput(hu);
  f->SetFillHoles(fill_holes);
  f->SetSliceAxis(2);
  f->Update();
  return f->GetOutput();
}

TEST(BodyMask, DropsTheTableKeepsTheHead) {
  const auto mask = body_mask(head_on_table(), true);
  int table_voxels = 0;
  for (int k = 0; k < 64; ++k)
    for (int j = 68; j <= 70; ++j)
      for (int i = 0; i < 80; ++i) table_voxels += at<MaskImage>(mask, i, j, k);
  EXPECT_EQ(table_voxels, 0);
  EXPECT_EQ(at<MaskImage>(mask, 40, 32, 34), 1);  // centre of the head
  EXPECT_EQ(at<MaskImage>(mask, 40, 3, 34), 1);   // its edge (j = 2 is on the surface)
  EXPECT_EQ(at<MaskImage>(mask, 2, 2, 2), 0);     // air outside
}

TEST(BodyMask, AirSpaceInsideTheHeadJoinsTheBodyThroughSliceFilling) {
  const auto hu = head_on_table();
  const auto filled = body_mask(hu, true);
  EXPECT_EQ(at<MaskImage>(filled, 40, 20, 30), 1);  // cavity centre
  EXPECT_EQ(at<MaskImage>(filled, 40, 20, 15), 1);  // inside the channel
  // Without filling the cavity stays outside: it opens to the air through the channel.
  const auto open = body_mask(hu, false);
  EXPECT_EQ(at<MaskImage>(open, 40, 20, 30), 0);
}

TEST(BodyMask, MarginGrowsTheMaskByItsRadius) {
  const auto hu = head_on_table();
  auto f = BodyMaskImageFilter<HuImage, MaskImage>::New();
  f->SetInput(hu);
  f->SetMarginMm(0.0);
  f->Update();
  const auto tight = f->GetOutput();
  EXPECT_EQ(at<MaskImage>(tight, 40, 32, 9), 0);  // 1 voxel below the head's lowest point (k=10)
  f->SetMarginMm(1.0);
  f->Update();
  EXPECT_EQ(at<MaskImage>(f->GetOutput(), 40, 32, 9), 1);
}

TEST(BodyMask, NoBodyIsAnErrorThatSaysSo) {
  auto air = blank_image<HuImage>(10, 10, 10, -1000.0f);
  auto f = BodyMaskImageFilter<HuImage, MaskImage>::New();
  f->SetInput(air);
  try {
    f->Update();
    FAIL() << "an empty image produced a body";
  } catch (const itk::ExceptionObject& e) {
    EXPECT_NE(std::string(e.GetDescription()).find("no body found"), std::string::npos)
        << e.GetDescription();
  }
}

}  // namespace
}  // namespace tsf::segment
