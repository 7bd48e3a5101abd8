// Scenes placed by anatomy: the crop, anchor planes and tool positions a scene gives relative to
// the patient's anatomy (`crop: {region: nasal-cavity, margin_mm: 10}`, `position: {landmark:
// nose-tip, offset_mm: {anterior: 5}}`) are resolved here into tissue-space millimetres, from the
// `anatomy` section of the segment report `tsf run` writes (segment/sinus_anatomy.h). The run
// calls it right after segmentation (app/run/run_pipeline.cpp, segment_stage); a scene with such
// keys and no pipeline section is refused when it is read (scene_yaml.cpp).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "scene/scene.h"

namespace tsf::app {

/// Names a scene may place by: landmarks (nose-tip, nostril-left, nostril-right, midsagittal)
/// and the regions' centroids.
const std::vector<std::string>& anatomy_landmark_names();
/// Regions a crop may take: nasal-cavity and the paranasal air spaces.
const std::vector<std::string>& anatomy_region_names();
/// Patient directions an offset or a plane normal may name: left, right, anterior, posterior,
/// superior, inferior. Returns false for another word; `v` is (left, anterior, superior).
bool anatomy_direction(const std::string& word, Vec3d& v);

/// PREFIX-report.json beside a tsf segment volume PREFIX-density.nrrd; empty when `density` is
/// not named so (the file may not exist).
std::filesystem::path segment_report_beside(const std::filesystem::path& density);

/// The patient's directions a segment report's anatomy found (LPS unit vectors: left, anterior as
/// the face was detected, superior) and whether the CT recorded its orientation (else left/right
/// is unknown). Empty when the report has no anatomy section.
struct AnatomyAxes {
  Vec3d left{1, 0, 0}, anterior{0, -1, 0}, superior{0, 0, 1};
  bool orientation_recorded = false;
  double facing_confidence = 0.0;
};
std::optional<AnatomyAxes> anatomy_axes(const nlohmann::json& segment_report);

/// What every mesh exported from a CT without a recorded patient orientation says beside its
/// frame (the model may be mirrored).
extern const char* const kLeftRightUnknown;
/// kLeftRightUnknown when the segment report beside `density` says the CT recorded no patient
/// orientation; else empty (also when there is no report).
std::string frame_warning_beside(const std::filesystem::path& density);

/// Resolves every anatomy-relative key of `scene` from a segment report's `anatomy` and `grid`
/// sections. Throws tsf::Error naming the key when the anatomy it uses was not found; returns
/// the warnings for anatomy used with a confidence below 0.5 (and the finder's own warnings).
std::vector<std::string> place_scene_by_anatomy(Scene& scene, const nlohmann::json& segment_report);

}  // namespace tsf::app
