// The bundled head CT (cranium.nrrd, skull base to vertex) segmented with the `sinus` preset.
//
// Plausible ranges, for this scan (it stops at the skull base: no mandible, no neck):
//   body         2.8 .. 4.5 l   an adult head is 3.5-5 l; the missing lower face and neck take
//                               ~0.5-1 l off, the 1 mm margin adds ~0.1 l
//   soft tissue  1.8 .. 3.2 l   brain 1.2-1.5 l + CSF + scalp, face muscles, orbits, mucosa, fat
//   bone         0.4 .. 1.0 l   skull (calvarium + skull base + facial bones), adult ~0.5-0.9 l
//   air spaces    20 .. 200 ml  paranasal sinuses (adult total ~30-80 ml) + nasal cavity
//                               (~15-25 ml) + nasopharynx, as far as the scan reaches
// (Measured values are in docs/segment.md; these bounds fail if a stage breaks, e.g. the table
// joins the body, the sinuses are filled with tissue, or bone is lost to a wrong threshold.)
#include <gtest/gtest.h>

#include <fstream>

#include "support/test_data.h"
#include "tsf/import/tissue_volume_io.h"
#include "tsf/segment/hu_volume_source.h"
#include "tsf/segment/segment_job.h"
#include "tsf/segment/segmentation_pipeline.h"
#include "tsf/segment/segmentation_report.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {
namespace {

class CraniumSinus : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    preset_ = new SegmentPreset(load_segment_preset("sinus"));
    const auto hu = read_hu_volume(tsf::test::samples_dir() / "ct-head-cranium" / "cranium.nrrd");
    result_ = new SegmentationResult(segment_hu_image(hu, *preset_));
    stats_ = new SegmentationStatistics(segmentation_statistics(*result_, *preset_));
  }
  static void TearDownTestSuite() {
    delete stats_;
    delete result_;
    delete preset_;
  }
  static double ml(std::uint8_t label) { return class_ml(*stats_, label); }

  static SegmentPreset* preset_;
  static SegmentationResult* result_;
  static SegmentationStatistics* stats_;
};
SegmentPreset* CraniumSinus::preset_ = nullptr;
SegmentationResult* CraniumSinus::result_ = nullptr;
SegmentationStatistics* CraniumSinus::stats_ = nullptr;

TEST_F(CraniumSinus, AirInsideTheBodyExists) {
  EXPECT_GT(stats_->air_spaces.ml, 20.0);
  EXPECT_LT(stats_->air_spaces.ml, 200.0);
  // The air spaces sit in the lower part of the head (sinuses, nasal cavity), not at the vertex.
  const double body_top = stats_->body.mm_max.z, body_bottom = stats_->body.mm_min.z;
  const double air_centre = 0.5 * (stats_->air_spaces.mm_min.z + stats_->air_spaces.mm_max.z);
  EXPECT_LT(air_centre, body_bottom + 0.6 * (body_top - body_bottom));
}

TEST_F(CraniumSinus, ClassVolumesArePlausibleForAnAdultHead) {
  const double soft = ml(kLabelSoftTissue) + ml(kLabelMucosa) + ml(kLabelFat);
  const double bone = ml(kLabelCancellousBone) + ml(kLabelCorticalBone);
  EXPECT_GT(stats_->body.ml, 2800.0);
  EXPECT_LT(stats_->body.ml, 4500.0);
  EXPECT_GT(soft, 1800.0);
  EXPECT_LT(soft, 3200.0);
  EXPECT_GT(bone, 400.0);
  EXPECT_LT(bone, 1000.0);
  // Mucosa lines the air spaces: present, and a thin layer compared with the soft tissue.
  EXPECT_GT(ml(kLabelMucosa), 5.0);
  EXPECT_LT(ml(kLabelMucosa), 0.1 * soft);
  EXPECT_GT(ml(kLabelFat), 10.0);
}

TEST_F(CraniumSinus, NothingOutsideTheBodyMaskIsTissue) {
  const auto& im = result_->images;
  const std::size_t n = im.labels->GetLargestPossibleRegion().GetNumberOfPixels();
  const unsigned char* body = im.body->GetBufferPointer();
  const unsigned char* labels = im.labels->GetBufferPointer();
  const float* density = im.density->GetBufferPointer();
  std::size_t tissue_outside = 0, dense_outside = 0;
  for (std::size_t v = 0; v < n; ++v)
    if (!body[v]) {
      tissue_outside += labels[v] != kLabelOutside;
      dense_outside += density[v] != 0.0f;
    }
  EXPECT_EQ(tissue_outside, 0u);
  EXPECT_EQ(dense_outside, 0u);
}

TEST_F(CraniumSinus, LabelsAgreeWithDensityAndAirSpacesAreOutsideTheTissue) {
  const auto& im = result_->images;
  const std::size_t n = im.labels->GetLargestPossibleRegion().GetNumberOfPixels();
  const unsigned char* labels = im.labels->GetBufferPointer();
  const unsigned char* air = im.air_spaces->GetBufferPointer();
  const unsigned char* body = im.body->GetBufferPointer();
  const float* density = im.density->GetBufferPointer();
  std::size_t disagree = 0, air_in_tissue = 0, air_outside_body = 0, bad_density = 0;
  for (std::size_t v = 0; v < n; ++v) {
    disagree += (labels[v] != kLabelOutside) != (density[v] >= 0.5f);
    air_in_tissue += air[v] && labels[v] != kLabelOutside;
    air_outside_body += air[v] && !body[v];
    bad_density += !(density[v] >= 0.0f && density[v] <= 1.0f);
  }
  EXPECT_EQ(disagree, 0u);
  EXPECT_EQ(air_in_tissue, 0u);
  EXPECT_EQ(air_outside_body, 0u);
  EXPECT_EQ(bad_density, 0u);
}

TEST_F(CraniumSinus, WeightsSumTo255AndBlendAtClassBoundaries) {
  const auto& im = result_->images;
  const std::size_t n = im.labels->GetLargestPossibleRegion().GetNumberOfPixels();
  const WeightPixel* w = im.weights->GetBufferPointer();
  std::size_t wrong_sum = 0, blended = 0;
  for (std::size_t v = 0; v < n; ++v) {
    wrong_sum += (w[v][0] + w[v][1] + w[v][2] + w[v][3]) != 255;
    int channels = 0;
    for (int c = 0; c < 4; ++c) channels += w[v][c] > 0;
    blended += channels > 1;
  }
  EXPECT_EQ(wrong_sum, 0u);
  EXPECT_GT(blended, n / 100);  // smooth heterogeneity, not stair steps
}

TEST(CraniumSinusJob, WritesVolumesReportAndPreview) {
  const auto dir = tsf::test::scratch_dir("job");
  SegmentJob job;
  job.input = tsf::test::samples_dir() / "ct-head-cranium" / "cranium.nrrd";
  job.preset = load_segment_preset("sinus");
  job.preset.resample.voxel_mm = 2.0;  // coarse: this test is about the files, not accuracy
  job.overrides = {"resample.voxel_mm=2"};
  job.output_prefix = dir / "cranium";
  const SegmentJobResult r = run_segment_job(job);
  for (const auto& p : {r.volume_paths.density, r.volume_paths.labels, r.volume_paths.weights,
                        r.report_path, r.preview_path})
    EXPECT_TRUE(std::filesystem::exists(p)) << p;

  const VoxelVolume volume = tsf::import::read_tissue_volume(r.volume_paths.density);
  EXPECT_TRUE(volume.has_material_weights());
  EXPECT_NO_THROW(volume.validate());

  std::ifstream in(r.report_path);
  const auto report = nlohmann::json::parse(in);
  EXPECT_DOUBLE_EQ(report["grid"]["voxel_mm"].get<double>(), 2.0);
  EXPECT_EQ(report["grid"]["dims"][0].get<int>(), volume.dims().x);
  EXPECT_EQ(report["parameters"]["name"], "sinus");
  EXPECT_EQ(report["overrides"][0], "resample.voxel_mm=2");
  bool has_bone = false;
  for (const auto& c : report["classes"]) {
    EXPECT_GT(c["ml"].get<double>(), 0.0);
    EXPECT_TRUE(c.contains("bbox_mm"));
    has_bone = has_bone || c["name"] == "cortical-bone";
  }
  EXPECT_TRUE(has_bone);
  std::vector<std::string> stages;
  for (const auto& s : report["stage_times"]) stages.push_back(s["stage"]);
  for (const char* s : {"roi", "resample", "body-mask", "density", "classes", "weights"})
    EXPECT_NE(std::find(stages.begin(), stages.end(), s), stages.end()) << s;
}

}  // namespace
}  // namespace tsf::segment
