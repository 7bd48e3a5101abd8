// Segmentation presets: every parameter of `tsf segment`, read from a YAML file a user can copy
// and edit (segment/presets/*.yaml documents each key).
//
// Validation is strict: an unknown key, a wrong type or a value out of range is a tsf::Error whose
// message names the file, the key path (e.g. `classes.bone.strong_hu`), the line and what was
// expected. Units: lengths in mm, intensities in Hounsfield units (HU), volumes in ml.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tsf/common/vec3.h"
#include "tsf/segment/segment_image_types.h"

namespace tsf::segment {

struct ResampleSettings {
  double voxel_mm = 0.0;  ///< isotropic output spacing; 0 = the finest input spacing
  bool antialias = true;  ///< Gaussian prefilter on axes being coarsened (isotropic_resample.h)
};

enum class RoiMode { kBody, kBox };

/// Region of interest the volume is cropped to before any other stage.
struct RoiSettings {
  RoiMode mode = RoiMode::kBody;
  double margin_mm = 5.0;     ///< kBody: added around the body's bounding box
  Vec3d box_min_mm{0, 0, 0};  ///< kBox: physical (LPS) corners of the box, mm
  Vec3d box_max_mm{0, 0, 0};
};

/// Body mask: threshold, opening (cuts the table and head-rest loose), largest connected
/// component, closing, per-slice hole filling (air spaces inside the head join the body), margin.
struct BodyMaskSettings {
  double threshold_hu = -500.0;
  double opening_radius_mm = 3.0;
  double closing_radius_mm = 2.0;
  bool fill_holes = true;
  /// Dilation so the skin's partial-volume ramp stays inside the mask; at least one voxel
  /// diagonal (√3 · voxel) is always used.
  double margin_mm = 1.0;
};

struct SmoothingSettings {
  double sigma_mm = 0.5;  ///< Gaussian applied to HU before density and classes; 0 = none
};

/// One boundary of the tissue in HU: density = clamp(0.5 ± (HU − threshold_hu)/ramp_hu, 0, 1).
struct DensityBoundary {
  double threshold_hu = -480.0;
  double ramp_hu = 800.0;  ///< HU over which density goes from 0 to 1; 0 = a hard step
};

/// Density: tissue is HU above `lower` (and below `upper` when present). The 0.5 iso-surface of
/// density lies where the smoothed HU crosses a threshold.
struct DensitySettings {
  DensityBoundary lower;
  std::optional<DensityBoundary> upper;
};

/// Bone by hysteresis: voxels >= weak_hu connected to a voxel >= strong_hu.
struct BoneSettings {
  bool enabled = true;
  double weak_hu = 200.0;
  double strong_hu = 400.0;
  double cortical_hu = 1000.0;  ///< bone at or above this is cortical, below cancellous
};

struct FatSettings {
  bool enabled = true;
  double min_hu = -190.0;
  double max_hu = -30.0;
  /// Opening radius: removes the one-voxel shells of fat-range HU that partial volume leaves
  /// at every air/soft-tissue boundary. At least one voxel is always used.
  double opening_radius_mm = 1.0;
};

/// Air spaces inside the body (sinuses, nasal cavity, airway): HU below max_hu, inside the body
/// mask and at least min_depth_mm from the air outside the body.
struct AirSpaceSettings {
  double max_hu = -400.0;
  double min_depth_mm = 4.0;
};

/// Mucosa: soft tissue within lining_mm of an air space inside the body. CT cannot tell mucosa
/// from other soft tissue by HU; this is a geometric label.
struct MucosaSettings {
  bool enabled = true;
  double lining_mm = 3.0;
};

/// Optional region growing (connected threshold on smoothed HU) from seeds, for a structure of
/// interest; grown voxels inside the tissue get `label`.
struct RegionSettings {
  std::string name;
  std::uint8_t label = 0;       ///< a tissue class (1..63) or an overlay (64..127)
  std::vector<Vec3d> seeds_mm;  ///< physical (LPS) positions, mm
  double min_hu = 0.0;
  double max_hu = 0.0;
  double max_volume_ml = 0.0;  ///< a region larger than this has leaked: error
};

/// Material blend weights: channel names (the lattice's palette maps channel -> material) and,
/// per label, how much of each channel the class is made of (fractions summing to 1).
struct MaterialSettings {
  std::array<std::string, kMaterialChannels> channels;
  double blend_sigma_mm = 1.0;  ///< Gaussian blending across class boundaries; 0 = none
  std::map<std::uint8_t, std::array<double, kMaterialChannels>> class_fractions;
};

struct SegmentPreset {
  std::string name;
  std::string description;
  std::filesystem::path source;  ///< file it was read from (empty when parsed from text)
  ResampleSettings resample;
  RoiSettings roi;
  BodyMaskSettings body;
  SmoothingSettings smoothing;
  DensitySettings density;
  BoneSettings bone;
  FatSettings fat;
  AirSpaceSettings air_spaces;
  MucosaSettings mucosa;
  std::vector<RegionSettings> regions;
  MaterialSettings materials;

  /// Checks cross-field rules (ranges are checked while parsing): e.g. weak_hu <= strong_hu,
  /// every label that can occur has a material mapping. Throws tsf::Error naming the key path.
  void validate() const;
  /// The parameters as JSON (for reports), same key paths as the YAML.
  nlohmann::json to_json() const;
};

/// Parses preset YAML text. `source_name` names the origin in error messages.
SegmentPreset parse_segment_preset(const std::string& yaml_text, const std::string& source_name);

/// Loads a preset by file path (anything containing a '/' or ending in .yaml/.yml) or by name
/// (NAME.yaml searched in segment_preset_dirs(), first match wins).
SegmentPreset load_segment_preset(const std::string& name_or_path);

/// Folders searched for presets by name, in order:
///   $TSF_PRESET_DIR (when set), <executable dir>/../share/tsf/presets/segment,
///   the source tree's segment/presets (for builds run in place).
std::vector<std::filesystem::path> segment_preset_dirs();

/// Names of the presets found in segment_preset_dirs() (sorted, unique).
std::vector<std::string> available_segment_presets();

}  // namespace tsf::segment
