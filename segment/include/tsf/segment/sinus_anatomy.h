// Sinus anatomy found per patient from the sinus preset's outputs: the nasal cavity, the nose tip,
// the nostrils, the midsagittal plane and, as far as the CT allows, the paranasal air spaces.
// Every result is in patient coordinates (LPS, mm) with a confidence in [0, 1] and a one-line
// reason; what cannot be found is reported with confidence 0 and a warning naming it.
//
// Method (docs/patients.md, "Anatomy found per patient"):
//   midsagittal  the left-right mirror plane of the bone (else the tissue): the offset and the yaw
//                about the vertical (±30°) that maximise the mirrored overlap
//   facing       which end of the index axis closest to patient y the face is at: the nose
//                protrudes (a small cap of body at that end) and the air spaces lie in front;
//                compared with the recorded (or assumed) frame, where anterior is −y
//   nasal cavity the air spaces reached from the air outside the body through openings at the
//                front, near the midline (the nostrils), within the band |x − mid| ≤ 15 mm
//   nose tip     the most anterior tissue voxel within 15 mm of the midline, at the nostrils'
//                height (above the mouth)
//   nostrils     the centroids of the openings left and right of the midline
//   paranasal    the other air spaces, by position relative to the midline and the nasal cavity
//                (maxillary lateral and low, frontal above and in front, sphenoid behind and
//                high, ethmoid medial and high): geometric rules, not walls.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tsf/common/vec3.h"
#include "tsf/segment/segmentation_pipeline.h"

namespace tsf::segment {

struct AnatomyLandmark {
  std::string name;  ///< "nose-tip", "nostril-left", "nostril-right"
  bool found = false;
  Vec3d position_mm;  ///< LPS
  double confidence = 0.0;
  std::string reason;
};

struct AnatomyRegion {
  std::string name;  ///< "nasal-cavity", "maxillary-left", …
  bool found = false;
  Vec3d min_mm, max_mm;  ///< LPS bounding box of the voxel centres
  Vec3d centroid_mm;
  double ml = 0.0;
  double confidence = 0.0;
  std::string reason;
};

struct AnatomyPlane {
  std::string name;  ///< "midsagittal"
  bool found = false;
  Vec3d point_mm, normal;  ///< LPS; the normal points toward patient left (+x as recorded)
  double confidence = 0.0;
  std::string reason;
};

/// Patient directions as unit vectors in LPS. `left` is the midsagittal plane's normal (+x turned
/// by the head's yaw), `anterior` the detected facing within that plane, `superior` the frame's.
struct AnatomyFrame {
  Vec3d left{1, 0, 0}, anterior{0, -1, 0}, superior{0, 0, 1};
  bool orientation_recorded = true;
  bool facing_agrees = true;  ///< the detected face is at −y (LPS anterior)
  double facing_confidence = 0.0;
  std::string facing_reason;
};

struct SinusAnatomy {
  AnatomyFrame frame;
  AnatomyPlane midsagittal;
  std::vector<AnatomyRegion> regions;      ///< nasal-cavity first, then the paranasal spaces
  std::vector<AnatomyLandmark> landmarks;  ///< nose-tip, nostril-left, nostril-right
  std::vector<std::string> warnings;

  const AnatomyRegion* region(const std::string& name) const;
  const AnatomyLandmark* landmark(const std::string& name) const;
};

struct SinusAnatomyOptions {
  /// false when the CT records no patient frame (an NRRD without `space`): L/R is unknown.
  bool orientation_recorded = true;
};

/// Finds the anatomy in a segmentation (needs hu, body, air_spaces and labels).
SinusAnatomy find_sinus_anatomy(const SegmentationImages& images,
                                const SinusAnatomyOptions& options = {});

/// The report's `anatomy` section (docs/segment.md).
nlohmann::json sinus_anatomy_json(const SinusAnatomy& anatomy);

}  // namespace tsf::segment
