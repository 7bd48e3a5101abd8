// Region growing from seeds: a contrast-filled vessel inside soft tissue gets its overlay label.
#include <gtest/gtest.h>

#include <cmath>

#include "segment_test_images.h"
#include "tsf/common/error.h"
#include "tsf/segment/segmentation_pipeline.h"
#include "tsf/segment/segmentation_report.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {
namespace {

using test::blank_image;
using test::paint;

/// A soft-tissue ball (40 HU, radius 15 mm) crossed by a vessel along i (300 HU, radius 2 mm).
HuImage::Pointer ball_with_vessel() {
  auto hu = blank_image<HuImage>(48, 48, 48, -1000.0f);
  paint<HuImage>(hu, 40.0f, [](int i, int j, int k) {
    return std::pow(i - 24, 2) + std::pow(j - 24, 2) + std::pow(k - 24, 2) <= 225.0;
  });
  paint<HuImage>(hu, 300.0f, [](int i, int j, int k) {
    return std::hypot(j - 24.0, k - 24.0) <= 2.0 &&
           std::pow(i - 24, 2) + std::pow(j - 24, 2) + std::pow(k - 24, 2) <= 225.0;
  });
  return hu;
}

SegmentPreset vessel_preset(double max_ml, Vec3d seed) {
  SegmentPreset p = parse_segment_preset("name: vessel-test\n", "vessel-test");
  p.bone.enabled = false;  // the vessel's HU would otherwise pass for thin bone
  p.smoothing.sigma_mm = 0.0;
  RegionSettings r;
  r.name = "test-vessel";
  r.label = kLabelVessel;
  r.seeds_mm = {seed};
  r.min_hu = 150.0;
  r.max_hu = 600.0;
  r.max_volume_ml = max_ml;
  p.regions.push_back(r);
  return p;
}

TEST(SeededRegion, GrowsTheVesselAndLabelsItAsAnOverlay) {
  const SegmentPreset p = vessel_preset(5.0, {24, 24, 24});
  const auto result = segment_hu_image(ball_with_vessel(), p);
  ASSERT_EQ(result.regions.size(), 1u);
  const auto& outcome = result.regions[0];
  // The vessel: a cylinder of radius 2 (13 voxels per slice) over ~29 slices.
  EXPECT_GT(outcome.labelled_voxels, 300u);
  EXPECT_LT(outcome.labelled_voxels, 450u);
  const auto stats = segmentation_statistics(result, p);
  bool named = false;
  for (const auto& c : stats.classes)
    if (c.label == kLabelVessel) named = c.name == "test-vessel";
  EXPECT_TRUE(named);
  EXPECT_GT(class_ml(stats, kLabelSoftTissue) + class_ml(stats, kLabelMucosa), 10.0);
}

TEST(SeededRegion, LeakBeyondMaxVolumeIsAnErrorNamingTheRegion) {
  SegmentPreset p = vessel_preset(0.1, {24, 24, 24});
  try {
    segment_hu_image(ball_with_vessel(), p);
    FAIL() << "a leaking region was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("test-vessel"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("max_volume_ml"), std::string::npos) << e.what();
  }
}

TEST(SeededRegion, SeedOutsideTheVolumeOrTheRangeIsAnError) {
  EXPECT_THROW(segment_hu_image(ball_with_vessel(), vessel_preset(5.0, {500, 24, 24})), Error);
  try {
    segment_hu_image(ball_with_vessel(), vessel_preset(5.0, {24, 34, 24}));  // in soft tissue
    FAIL() << "a seed outside the HU range was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("HU"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tsf::segment
