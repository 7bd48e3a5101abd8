// End to end on a real DICOM series: the bundled GE HiSpeed head CT (28 slices, gantry tilt
// 18.5°, uneven slice spacing 4 mm / 7 mm) imported by `tsf import` (tilt and spacing resolved by
// resampling onto an orthogonal grid) and segmented with the `sinus` preset at 1 mm voxels. The
// pipeline must find a body, soft tissue, bone and the air of the sinuses (slices 1-11), with
// volumes of the right order for the ~140 mm of head covered (GE_SERIES_RANGES below).
#include <gtest/gtest.h>

#include "support/test_data.h"
#include "tsf/segment/hu_volume_source.h"
#include "tsf/segment/segmentation_pipeline.h"
#include "tsf/segment/segmentation_report.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {
namespace {

TEST(GeSeriesSegmentation, SinusPresetFindsBodySoftTissueBoneAndSinusAir) {
  const auto dir = tsf::test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
  const HuImage::Pointer hu = read_hu_volume(dir, /*show_progress=*/false);
  // Resampled onto an orthogonal grid: more slices than the 28 acquired, identity direction.
  EXPECT_GT(hu->GetLargestPossibleRegion().GetSize()[2], 28u);
  EXPECT_NEAR(hu->GetDirection()[2][2], 1.0, 1e-9);

  SegmentPreset preset = load_segment_preset("sinus");
  preset.resample.voxel_mm = 1.0;  // 0.49 mm pixels would be 8× the voxels for the same check
  const SegmentationResult result = segment_hu_image(hu, preset);
  const SegmentationStatistics stats = segmentation_statistics(result, preset);

  // GE_SERIES_RANGES: ~140 mm of an adult head from the maxilla up; soft tissue and bone of that
  // slab are litres and hundreds of ml; sinus air tens of ml.
  const double soft = class_ml(stats, kLabelSoftTissue) + class_ml(stats, kLabelMucosa) +
                      class_ml(stats, kLabelFat);
  const double bone = class_ml(stats, kLabelCancellousBone) + class_ml(stats, kLabelCorticalBone);
  EXPECT_GT(stats.body.ml, 1500.0);
  EXPECT_LT(stats.body.ml, 6000.0);
  EXPECT_GT(soft, 1000.0);
  EXPECT_GT(bone, 150.0);
  EXPECT_LT(bone, soft);
  EXPECT_GT(stats.air_spaces.ml, 5.0);
  EXPECT_GT(class_ml(stats, kLabelMucosa), 1.0);

  // Nothing outside the body is tissue; densities in [0,1]; weights sum to 255.
  const auto& im = result.images;
  const std::size_t n = im.labels->GetLargestPossibleRegion().GetNumberOfPixels();
  std::size_t bad = 0;
  for (std::size_t v = 0; v < n; ++v) {
    const float d = im.density->GetBufferPointer()[v];
    const auto& w = im.weights->GetBufferPointer()[v];
    bad += (!im.body->GetBufferPointer()[v] && im.labels->GetBufferPointer()[v] != kLabelOutside);
    bad += !(d >= 0.0f && d <= 1.0f);
    bad += (w[0] + w[1] + w[2] + w[3]) != 255;
  }
  EXPECT_EQ(bad, 0u);
}

}  // namespace
}  // namespace tsf::segment
