// The segmentation pipeline: HU volume -> density, tissue labels, material weights (ITK images).
//
// Stages, in order (each timed; long ones report progress):
//   roi          region of interest in the input's index space (roi_crop.h)
//   resample     isotropic voxels of preset.resample.voxel_mm over the ROI (isotropic_resample.h)
//   body-mask    BodyMaskImageFilter on the resampled HU
//   smoothing    Gaussian of preset.smoothing.sigma_mm on HU
//   density      HuDensityImageFilter: clamped linear ramp(s) around the tissue threshold(s)
//   bone         HysteresisThresholdImageFilter (weak/strong HU)
//   classes      TissueClassImageFilter (bone, fat, soft tissue inside density >= 0.5)
//   cleanup      fat opening: partial-volume shells of fat-range HU become soft tissue
//   air-spaces   air inside the body (sinuses, nasal cavity, airway); mucosa = soft tissue lining
//   it regions      optional connected-threshold growing from seeds -> region labels weights
//   material blend weights (material_weights.h)
// Crop-then-resample computes the same voxels as resample-then-crop, on less memory.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tsf/segment/isotropic_resample.h"
#include "tsf/segment/segment_image_types.h"
#include "tsf/segment/segment_preset.h"

namespace tsf::segment {

/// The images of one segmentation, all on the same isotropic grid.
struct SegmentationImages {
  HuImage::Pointer hu;            ///< resampled HU (not smoothed), for previews and reports
  MaskImage::Pointer body;        ///< body mask (0/1)
  MaskImage::Pointer air_spaces;  ///< air inside the body (0/1), outside the tissue
  DensityImage::Pointer density;  ///< [0,1], iso-level 0.5 = tissue surface
  LabelImage::Pointer labels;     ///< TissueLabel values; tissue only where density >= 0.5
  WeightImage::Pointer weights;   ///< 4 × uint8 summing to 255
};

struct StageTime {
  std::string stage;
  double seconds = 0.0;
};

struct RegionOutcome {
  std::string name;
  std::uint8_t label = 0;
  std::size_t grown_voxels = 0;     ///< voxels reached by the connected threshold
  std::size_t labelled_voxels = 0;  ///< of those, inside the tissue (density >= 0.5)
};

struct SegmentationResult {
  SegmentationImages images;
  std::vector<StageTime> stage_times;
  double voxel_mm = 0.0;  ///< isotropic spacing used
  IndexBox roi;           ///< region of interest in the input's continuous index space
  std::vector<RegionOutcome> regions;
};

struct SegmentationOptions {
  bool show_progress = false;   ///< progress bars on stderr (only drawn on a terminal)
  bool compute_weights = true;  ///< material weights (the most memory-hungry stage)
};

/// Runs every stage on `hu` with `preset` (already validated). Throws tsf::Error naming the stage
/// and what went wrong (no body found, a seed outside the volume, a region that leaked, …).
SegmentationResult segment_hu_image(const HuImage* hu, const SegmentPreset& preset,
                                    const SegmentationOptions& options = {});

}  // namespace tsf::segment
