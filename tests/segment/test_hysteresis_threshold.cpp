#include <gtest/gtest.h>

#include "segment_test_images.h"
#include "tsf/segment/filters/hysteresis_threshold_image_filter.h"

namespace tsf::segment {
namespace {

using test::at;
using test::blank_image;
using test::paint;

TEST(HysteresisThreshold, KeepsWeakVoxelsConnectedToStrongOnes) {
  auto hu = blank_image<HuImage>(40, 10, 10, 40.0f);
  // A thin weak wall (250 HU) attached to a strong block (800 HU).
  paint<HuImage>(hu, 800.0f, [](int i, int j, int k) { return i < 6 && j < 6 && k < 6; });
  paint<HuImage>(hu, 250.0f,
                 [](int i, int j, int k) { return i >= 6 && i < 20 && j == 2 && k == 2; });
  // A weak speck on its own and a strong speck on its own.
  paint<HuImage>(hu, 250.0f, [](int i, int j, int k) { return i == 30 && j == 5 && k == 5; });
  paint<HuImage>(hu, 900.0f, [](int i, int j, int k) { return i == 35 && j == 5 && k == 5; });
  auto f = HysteresisThresholdImageFilter<HuImage, MaskImage>::New();
  f->SetInput(hu);
  f->SetWeakThreshold(200.0);
  f->SetStrongThreshold(400.0);
  f->Update();
  const MaskImage* out = f->GetOutput();
  EXPECT_EQ(at<MaskImage>(out, 3, 3, 3), 1);
  EXPECT_EQ(at<MaskImage>(out, 19, 2, 2), 1);  // far end of the thin wall
  EXPECT_EQ(at<MaskImage>(out, 30, 5, 5), 0);  // isolated weak speck
  EXPECT_EQ(at<MaskImage>(out, 35, 5, 5), 1);  // strong alone is bone
  EXPECT_EQ(at<MaskImage>(out, 25, 5, 5), 0);  // soft tissue
}

TEST(HysteresisThreshold, RejectsWeakAboveStrong) {
  auto hu = blank_image<HuImage>(4, 4, 4, 0.0f);
  auto f = HysteresisThresholdImageFilter<HuImage, MaskImage>::New();
  f->SetInput(hu);
  f->SetWeakThreshold(500.0);
  f->SetStrongThreshold(400.0);
  EXPECT_THROW(f->Update(), itk::ExceptionObject);
}

}  // namespace
}  // namespace tsf::segment
