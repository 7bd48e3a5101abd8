// Material weights: exact inside a class, blended smoothly across class boundaries, sum 255.
#include <gtest/gtest.h>

#include "segment_test_images.h"
#include "tsf/common/error.h"
#include "tsf/segment/material_weights.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {
namespace {

using test::at;
using test::blank_image;
using test::paint;

/// Soft tissue for i < 20, cortical bone for 20 <= i < 40, outside beyond.
LabelImage::Pointer two_classes() {
  auto labels = blank_image<LabelImage>(60, 8, 8, kLabelOutside);
  paint<LabelImage>(labels, kLabelSoftTissue, [](int i, int, int) { return i < 20; });
  paint<LabelImage>(labels, kLabelCorticalBone, [](int i, int, int) { return i >= 20 && i < 40; });
  return labels;
}

MaterialSettings settings(double sigma) {
  MaterialSettings m;
  m.channels = {"soft", "mucosa", "cartilage", "bone"};
  m.blend_sigma_mm = sigma;
  m.class_fractions[kLabelSoftTissue] = {1, 0, 0, 0};
  m.class_fractions[kLabelCorticalBone] = {0, 0, 0, 1};
  return m;
}

int sum(const WeightPixel& w) {
  return w[0] + w[1] + w[2] + w[3];
}

TEST(MaterialWeights, WithoutBlendingEachVoxelGetsItsClass) {
  const auto w = material_weights(two_classes(), settings(0.0));
  EXPECT_EQ(at<WeightImage>(w, 19, 4, 4)[0], 255);
  EXPECT_EQ(at<WeightImage>(w, 20, 4, 4)[3], 255);
  EXPECT_EQ(at<WeightImage>(w, 50, 4, 4)[0], 255);  // outside: channel 0
}

TEST(MaterialWeights, BlendingIsSmoothAcrossTheBoundaryAndExactFarFromIt) {
  const auto w = material_weights(two_classes(), settings(1.5));
  for (int k = 0; k < 8; ++k)
    for (int j = 0; j < 8; ++j)
      for (int i = 0; i < 60; ++i) ASSERT_EQ(sum(at<WeightImage>(w, i, j, k)), 255);
  EXPECT_EQ(at<WeightImage>(w, 5, 4, 4)[0], 255);   // deep in soft tissue
  EXPECT_EQ(at<WeightImage>(w, 30, 4, 4)[3], 255);  // deep in bone
  // Near the boundary both materials are present, and bone rises monotonically across it.
  const int at19 = at<WeightImage>(w, 19, 4, 4)[3], at20 = at<WeightImage>(w, 20, 4, 4)[3];
  EXPECT_GT(at19, 20);
  EXPECT_LT(at20, 235);
  int previous = -1;
  for (int i = 10; i < 30; ++i) {
    const int bone = at<WeightImage>(w, i, 4, 4)[3];
    EXPECT_GE(bone, previous) << "at i = " << i;
    previous = bone;
  }
  // The air is never mixed in: bone's outer face keeps pure bone.
  EXPECT_EQ(at<WeightImage>(w, 39, 4, 4)[3], 255);
  // Just outside the tissue the nearby tissue's weights extend; far away, channel 0.
  EXPECT_EQ(at<WeightImage>(w, 41, 4, 4)[3], 255);
  EXPECT_EQ(at<WeightImage>(w, 59, 4, 4)[0], 255);
}

TEST(MaterialWeights, LabelWithoutAMappingIsAnErrorNamingIt) {
  auto labels = two_classes();
  paint<LabelImage>(labels, kLabelVessel, [](int i, int, int) { return i == 10; });
  try {
    material_weights(labels, settings(1.0));
    FAIL() << "an unmapped label was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("vessel"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tsf::segment
