// The anatomy finder (segment/sinus_anatomy.h) on the bundled cranium, a copy of it with another
// origin, and phantoms without a nasal cavity.
//
// Where the shipped scenes put the anatomy of the cranium (scenes/sinus-ci.yaml, tissue space =
// the file's frame, origin 0): the nose tip at about (123, 232, 34) mm, the wand's path into the
// nostril along y at x 123, z 33 (y 226..236), the crop [98, 180, 10]..[148, 236, 70] around the
// nose and nasal cavity. The face points toward +y, which is posterior if the axes were truly
// L, P, S: the finder must say so.
#include <gtest/gtest.h>

#include <itkImageFileWriter.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "support/test_data.h"
#include "tsf/segment/hu_volume_source.h"
#include "tsf/segment/segmentation_pipeline.h"
#include "tsf/segment/sinus_anatomy.h"
#include "tsf/segment/sphere_phantom.h"

namespace tsf::segment {
namespace {

SinusAnatomy anatomy_of(const HuImage* hu, double voxel_mm, bool orientation_recorded) {
  SegmentPreset preset = load_segment_preset("sinus");
  preset.resample.voxel_mm = voxel_mm;
  SegmentationOptions options;
  options.compute_weights = false;
  const SegmentationResult r = segment_hu_image(hu, preset, options);
  SinusAnatomyOptions ao;
  ao.orientation_recorded = orientation_recorded;
  return find_sinus_anatomy(r.images, ao);
}

std::string all_warnings(const SinusAnatomy& a) {
  std::string out;
  for (const std::string& w : a.warnings) out += w + "\n";
  return out;
}

double distance(const Vec3d& a, const Vec3d& b) {
  return std::sqrt(length_squared(a - b));
}

class SegmentAnatomyCranium : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    hu_ = read_hu_volume(tsf::test::samples_dir() / "ct-head-cranium" / "cranium.nrrd");
    anatomy_ = new SinusAnatomy(anatomy_of(hu_, 2.0, false));
  }
  static void TearDownTestSuite() {
    delete anatomy_;
    hu_ = nullptr;
  }
  static HuImage::Pointer hu_;
  static SinusAnatomy* anatomy_;
};
HuImage::Pointer SegmentAnatomyCranium::hu_;
SinusAnatomy* SegmentAnatomyCranium::anatomy_ = nullptr;

TEST_F(SegmentAnatomyCranium, NoseTipIsWhereTheShippedScenesPutIt) {
  const AnatomyLandmark* tip = anatomy_->landmark("nose-tip");
  ASSERT_NE(tip, nullptr);
  ASSERT_TRUE(tip->found) << tip->reason;
  EXPECT_NEAR(tip->position_mm.y, 232.0, 3.0);
  EXPECT_NEAR(tip->position_mm.x, 123.0, 4.0);
  EXPECT_NEAR(tip->position_mm.z, 34.0, 5.0);
  EXPECT_GE(tip->confidence, 0.5) << tip->reason;
}

TEST_F(SegmentAnatomyCranium, NasalCavityHoldsTheWandPathAndLiesInTheScenesCrop) {
  const AnatomyRegion* nc = anatomy_->region("nasal-cavity");
  ASSERT_NE(nc, nullptr);
  ASSERT_TRUE(nc->found) << nc->reason;
  EXPECT_GE(nc->confidence, 0.5) << nc->reason;
  // The wand ablates along y at x 123, z 33 from y 236 to 226: inside the cavity's box (+2 mm).
  const Vec3d wand{123, 224, 33};
  for (int a = 0; a < 3; ++a) {
    EXPECT_LE(nc->min_mm[a] - 2.0, wand[a]) << a;
    EXPECT_GE(nc->max_mm[a] + 2.0, wand[a]) << a;
  }
  const Vec3d crop_lo{98, 180, 10}, crop_hi{148, 236, 70};
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(nc->centroid_mm[a], crop_lo[a]) << a;
    EXPECT_LE(nc->centroid_mm[a], crop_hi[a]) << a;
  }
  // Nostrils: either side of the midline, behind the tip, within a few cm of it.
  const AnatomyLandmark* l = anatomy_->landmark("nostril-left");
  const AnatomyLandmark* r = anatomy_->landmark("nostril-right");
  ASSERT_TRUE(l->found && r->found) << l->reason << " / " << r->reason;
  EXPECT_GT(l->position_mm.x, r->position_mm.x);
  EXPECT_LT(distance(l->position_mm, anatomy_->landmark("nose-tip")->position_mm), 30.0);
  // Midsagittal plane through the nose, normal along x.
  EXPECT_TRUE(anatomy_->midsagittal.found);
  EXPECT_NEAR(anatomy_->midsagittal.point_mm.x, 123.0, 4.0);
  EXPECT_NEAR(std::abs(anatomy_->midsagittal.normal.x), 1.0, 1e-3);  // within 2.5° of yaw
}

TEST_F(SegmentAnatomyCranium, FacingTowardPlusYIsDetectedAndWarnedAbout) {
  EXPECT_GT(anatomy_->frame.anterior.y, 0.9);
  EXPECT_FALSE(anatomy_->frame.facing_agrees);
  EXPECT_GE(anatomy_->frame.facing_confidence, 0.5);
  const std::string w = all_warnings(*anatomy_);
  EXPECT_NE(w.find("the face points toward +y"), std::string::npos) << w;
  EXPECT_NE(w.find("left/right is unknown"), std::string::npos) << w;
  const nlohmann::json j = sinus_anatomy_json(*anatomy_);
  EXPECT_EQ(j["frame"], "patient (LPS), mm");
  EXPECT_EQ(j["landmarks"][0]["name"], "nose-tip");
  EXPECT_EQ(j["regions"][0]["name"], "nasal-cavity");
  EXPECT_TRUE(j["regions"][0].contains("bbox_mm"));
  for (const auto& r : j["regions"]) EXPECT_FALSE(r["reason"].get<std::string>().empty()) << r;
}

TEST_F(SegmentAnatomyCranium, AShiftedOriginShiftsEveryLandmarkByTheSameAmount) {
  // Write a copy with another `space origin` and read it back as a file.
  const Vec3d shift{-120.5, 37.25, -300.0};
  auto moved = HuImage::New();
  moved->Graft(hu_);
  HuImage::PointType origin = hu_->GetOrigin();
  for (int a = 0; a < 3; ++a) origin[a] += shift[a];
  moved->SetOrigin(origin);
  const auto path = tsf::test::scratch_dir("segment-anatomy-shifted") / "cranium-shifted.nrrd";
  auto writer = itk::ImageFileWriter<HuImage>::New();
  writer->SetInput(moved);
  writer->SetFileName(path.string());
  writer->Update();
  const HuImage::Pointer back = read_hu_volume(path);
  ASSERT_NEAR(back->GetOrigin()[2], hu_->GetOrigin()[2] + shift.z, 1e-3);
  const SinusAnatomy shifted = anatomy_of(back, 2.0, true);
  for (const AnatomyLandmark& l : anatomy_->landmarks) {
    const AnatomyLandmark* s = shifted.landmark(l.name);
    ASSERT_EQ(s->found, l.found) << l.name;
    if (l.found) {
      EXPECT_LT(distance(s->position_mm, l.position_mm + shift), 2.0) << l.name;
    }
  }
  const AnatomyRegion* a = anatomy_->region("nasal-cavity");
  const AnatomyRegion* b = shifted.region("nasal-cavity");
  ASSERT_TRUE(b->found);
  EXPECT_LT(distance(b->centroid_mm, a->centroid_mm + shift), 2.0);
  EXPECT_LT(distance(b->min_mm, a->min_mm + shift), 2.0);
  EXPECT_LT(distance(b->max_mm, a->max_mm + shift), 2.0);
  EXPECT_LT(distance(shifted.midsagittal.point_mm, anatomy_->midsagittal.point_mm + shift), 2.0);
}

TEST(SegmentAnatomyPhantom, ASphereHasNoNasalCavityAndSaysSo) {
  SpherePhantom p;
  p.dims = 80;
  p.spacing_mm = 2.0;
  p.radius_mm = 60.0;
  const SinusAnatomy a = anatomy_of(make_sphere_phantom(p), 2.0, true);
  EXPECT_FALSE(a.region("nasal-cavity")->found);
  EXPECT_FALSE(a.landmark("nose-tip")->found);
  for (const AnatomyRegion& r : a.regions) EXPECT_FALSE(r.found) << r.name;
  const std::string w = all_warnings(a);
  EXPECT_NE(w.find("no nasal cavity"), std::string::npos) << w;
  EXPECT_NE(w.find("nose tip, nostrils and paranasal air spaces are not found"), std::string::npos)
      << w;
}

TEST(SegmentAnatomyPhantom, AnEmptySkullsAirIsNotReportedAsAirSpaces) {
  // A bone shell (radius 70 mm, 10 mm thick) around air: the body mask fills the inside, whose
  // air must not become "sinuses".
  SpherePhantom outer;
  outer.dims = 84;
  outer.spacing_mm = 2.0;
  outer.radius_mm = 70.0;
  outer.inside_hu = 1200.0;
  SpherePhantom inner = outer;
  inner.radius_mm = 60.0;
  inner.inside_hu = -1000.0;
  inner.outside_hu = 1200.0;
  const HuImage::Pointer shell = make_sphere_phantom(outer);
  const HuImage::Pointer cavity = make_sphere_phantom(inner);
  float* s = shell->GetBufferPointer();
  const float* c = cavity->GetBufferPointer();
  const std::size_t n = shell->GetLargestPossibleRegion().GetNumberOfPixels();
  for (std::size_t v = 0; v < n; ++v) s[v] = std::min(s[v], c[v]);
  const SinusAnatomy a = anatomy_of(shell, 2.0, true);
  for (const AnatomyRegion& r : a.regions) EXPECT_FALSE(r.found) << r.name << ": " << r.reason;
  const std::string w = all_warnings(a);
  EXPECT_NE(w.find("no nasal cavity"), std::string::npos) << w;
}

}  // namespace
}  // namespace tsf::segment
