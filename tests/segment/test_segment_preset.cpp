// Presets: the bundled ones load; every validation error names the key path (and the line).
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/segment/segment_preset.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {
namespace {

/// The message of the tsf::Error that parsing `yaml` throws ("" when it does not throw).
std::string parse_error(const std::string& yaml) {
  try {
    parse_segment_preset(yaml, "test.yaml");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_ERROR_NAMES(yaml, key)                                          \
  do {                                                                         \
    const std::string message = parse_error(yaml);                             \
    EXPECT_NE(message.find(std::string("'") + (key) + "'"), std::string::npos) \
        << "error does not name '" << (key)                                    \
        << "': " << (message.empty() ? "(no error)" : message);                \
    EXPECT_NE(message.find("test.yaml"), std::string::npos) << message;        \
  } while (0)

TEST(SegmentPreset, BundledPresetsLoadByName) {
  for (const char* name : {"sinus", "head-bone", "soft-tissue"}) {
    SCOPED_TRACE(name);
    const SegmentPreset p = load_segment_preset(name);
    EXPECT_EQ(p.name, name);
    EXPECT_TRUE(std::filesystem::exists(p.source));
    EXPECT_NO_THROW(p.validate());
  }
  const auto names = available_segment_presets();
  for (const char* name : {"sinus", "head-bone", "soft-tissue"})
    EXPECT_NE(std::find(names.begin(), names.end(), name), names.end()) << name;
}

TEST(SegmentPreset, SinusKeepsAirOutsideAndBoneInside) {
  const SegmentPreset p = load_segment_preset("sinus");
  EXPECT_LT(p.density.lower.threshold_hu, -300.0);  // air is below the tissue boundary
  EXPECT_FALSE(p.density.upper.has_value());        // bone is tissue
  EXPECT_TRUE(p.bone.enabled);
  EXPECT_TRUE(p.mucosa.enabled);
  const SegmentPreset soft = load_segment_preset("soft-tissue");
  ASSERT_TRUE(soft.density.upper.has_value());  // bone is outside the soft tissue
  EXPECT_FALSE(soft.bone.enabled);
}

TEST(SegmentPreset, LoadsByPathAndEmptyFileUsesDefaults) {
  const auto dir = test::scratch_dir("preset");
  const auto file = dir / "mine.yaml";
  std::ofstream(file) << "smoothing: {sigma_mm: 1.25}\n";
  const SegmentPreset p = load_segment_preset(file.string());
  EXPECT_EQ(p.name, "mine");
  EXPECT_DOUBLE_EQ(p.smoothing.sigma_mm, 1.25);
  EXPECT_DOUBLE_EQ(p.density.lower.threshold_hu, -480.0);
  EXPECT_EQ(p.materials.class_fractions.at(kLabelCorticalBone)[3], 1.0);
}

TEST(SegmentPreset, UnknownKeyIsNamedWithItsPath) {
  EXPECT_ERROR_NAMES("classes:\n  bone:\n    strongg_hu: 300\n", "classes.bone.strongg_hu");
  EXPECT_ERROR_NAMES("smoothingg: {sigma_mm: 1}\n", "smoothingg");
  EXPECT_ERROR_NAMES("density:\n  lower: {threshold: -480}\n", "density.lower.threshold");
  EXPECT_ERROR_NAMES("regions:\n  - {name: a, label: vessel, seeds_mm: [[0,0,0]], colour: red}\n",
                     "regions[0].colour");
}

TEST(SegmentPreset, UnknownKeyErrorGivesTheLineAndTheExpectedKeys) {
  const std::string message =
      parse_error("name: x\nbody:\n  threshold_hu: -500\n  fil_holes: true\n");
  EXPECT_NE(message.find("line 4"), std::string::npos) << message;
  EXPECT_NE(message.find("fill_holes"), std::string::npos) << message;
}

TEST(SegmentPreset, OutOfRangeValueIsNamedWithItsPath) {
  EXPECT_ERROR_NAMES("classes: {bone: {strong_hu: 50000}}\n", "classes.bone.strong_hu");
  EXPECT_ERROR_NAMES("resample: {voxel_mm: -1}\n", "resample.voxel_mm");
  EXPECT_ERROR_NAMES("resample: {voxel_mm: 0.01}\n", "resample.voxel_mm");
  EXPECT_ERROR_NAMES("smoothing: {sigma_mm: 11}\n", "smoothing.sigma_mm");
  EXPECT_ERROR_NAMES("materials: {blend_sigma_mm: -0.5}\n", "materials.blend_sigma_mm");
  EXPECT_ERROR_NAMES("density: {lower: {ramp_hu: .nan}}\n", "density.lower.ramp_hu");
  const std::string message = parse_error("classes: {bone: {strong_hu: 50000}}\n");
  EXPECT_NE(message.find("50000"), std::string::npos) << message;
  EXPECT_NE(message.find("4000"), std::string::npos) << message;  // the allowed maximum
}

TEST(SegmentPreset, WrongTypeIsNamedWithItsPath) {
  EXPECT_ERROR_NAMES("smoothing: {sigma_mm: lots}\n", "smoothing.sigma_mm");
  EXPECT_ERROR_NAMES("body: {fill_holes: maybe}\n", "body.fill_holes");
  EXPECT_ERROR_NAMES("roi: {mode: box, box_min_mm: [1, 2], box_max_mm: [3, 4, 5]}\n",
                     "roi.box_min_mm");
  EXPECT_ERROR_NAMES("roi: {mode: sphere}\n", "roi.mode");
  EXPECT_ERROR_NAMES("classes: [bone]\n", "classes");
}

TEST(SegmentPreset, CrossFieldRulesNameTheKey) {
  EXPECT_ERROR_NAMES("classes: {bone: {weak_hu: 500, strong_hu: 300}}\n", "classes.bone.weak_hu");
  EXPECT_ERROR_NAMES("classes: {fat: {min_hu: -20, max_hu: -100}}\n", "classes.fat.max_hu");
  EXPECT_ERROR_NAMES("density: {upper: {threshold_hu: -600}}\n", "density.upper.threshold_hu");
  EXPECT_ERROR_NAMES("roi: {mode: box, box_min_mm: [0,0,0], box_max_mm: [10, -5, 10]}\n",
                     "roi.box_max_mm");
  EXPECT_ERROR_NAMES("roi: {mode: box, box_min_mm: [0,0,0]}\n", "roi.box_max_mm");
}

TEST(SegmentPreset, MaterialMappingErrorsNameTheKey) {
  EXPECT_ERROR_NAMES("materials: {classes: {soft-tissue: muscle}}\n",
                     "materials.classes.soft-tissue");
  EXPECT_ERROR_NAMES("materials: {classes: {gristle: soft}}\n", "materials.classes.gristle");
  EXPECT_ERROR_NAMES("materials: {classes: {cortical-bone: {bone: 0.5, soft: 0.2}}}\n",
                     "materials.classes.cortical-bone");
  // A mapping that leaves out a class the preset can produce.
  EXPECT_ERROR_NAMES("materials: {classes: {soft-tissue: soft, mucosa: mucosa, fat: soft}}\n",
                     "materials.classes.cancellous-bone");
  EXPECT_ERROR_NAMES("materials: {channels: [a, b, a, d]}\n", "materials.channels");
}

TEST(SegmentPreset, RegionErrorsNameTheKey) {
  EXPECT_ERROR_NAMES("regions:\n  - {name: v, label: 200, seeds_mm: [[0,0,0]]}\n",
                     "regions[0].label");
  EXPECT_ERROR_NAMES("regions:\n  - {name: v, label: vessel, seeds_mm: []}\n",
                     "regions[0].seeds_mm");
  EXPECT_ERROR_NAMES(
      "regions:\n  - {name: v, label: vessel, seeds_mm: [[0,0,0]], min_hu: 300, max_hu: 100}\n",
      "regions[0].max_hu");
  EXPECT_ERROR_NAMES(
      "regions:\n  - {name: v, label: vessel, seeds_mm: [[0,0,0]]}\n"
      "  - {name: v, label: nerve, seeds_mm: [[1,1,1]]}\n",
      "regions[1].name");
}

TEST(SegmentPreset, RegionWithOverlayLabelNeedsAMaterial) {
  const std::string ok =
      "regions:\n  - {name: carotid, label: vessel, seeds_mm: [[1, 2, 3]], min_hu: 150, "
      "max_hu: 600, max_volume_ml: 20}\n";
  const SegmentPreset p = parse_segment_preset(ok, "test.yaml");
  ASSERT_EQ(p.regions.size(), 1u);
  EXPECT_EQ(p.regions[0].label, kLabelVessel);
  EXPECT_DOUBLE_EQ(p.regions[0].seeds_mm[0].z, 3.0);
  EXPECT_ERROR_NAMES("regions:\n  - {name: r, label: 70, seeds_mm: [[0,0,0]]}\n",
                     "materials.classes.overlay-70");
}

TEST(SegmentPreset, InvalidYamlSaysWhereAndUnknownNameListsPresets) {
  const std::string message = parse_error("body: {threshold_hu: -500\nsmoothing: [\n");
  EXPECT_NE(message.find("not valid YAML"), std::string::npos) << message;
  try {
    load_segment_preset("no-such-preset");
    FAIL() << "an unknown preset name was accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("no-such-preset"), std::string::npos) << m;
    EXPECT_NE(m.find("sinus"), std::string::npos) << m;  // lists what is available
  }
  EXPECT_THROW(load_segment_preset("/no/such/file.yaml"), Error);
}

TEST(SegmentPreset, ParametersRoundTripThroughJson) {
  const SegmentPreset p = load_segment_preset("sinus");
  const auto j = p.to_json();
  EXPECT_EQ(j["name"], "sinus");
  EXPECT_DOUBLE_EQ(j["density"]["lower"]["threshold_hu"].get<double>(),
                   p.density.lower.threshold_hu);
  EXPECT_DOUBLE_EQ(j["classes"]["bone"]["strong_hu"].get<double>(), p.bone.strong_hu);
  EXPECT_DOUBLE_EQ(j["materials"]["classes"]["cancellous-bone"]["bone"].get<double>(), 0.7);
}

}  // namespace
}  // namespace tsf::segment
