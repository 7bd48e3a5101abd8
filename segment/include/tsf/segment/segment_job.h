// `tsf segment` as a library call: read -> segment -> write volumes, report and preview.
//
// Outputs for PREFIX:
//   PREFIX-density.nrrd  PREFIX-labels.nrrd  PREFIX-weights.nrrd (tsf::import::write_tissue_volume)
//   PREFIX-report.json   grid, class volumes (ml) and bounding boxes (mm), stage times, parameters,
//                        `anatomy` (sinus_anatomy.h: landmarks and regions in LPS with
//                        confidences), and `warnings`: what the import said (resampling, tilt, no
//                        orientation)
//   PREFIX-preview.png   labelled axial/coronal/sagittal slices (unless write_preview is false)
// Every file is written atomically (temporary then rename); on an error nothing half-written is
// left behind.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tsf/import/tissue_volume_io.h"
#include "tsf/segment/segment_preset.h"

namespace tsf::segment {

struct SegmentJob {
  std::filesystem::path input;          ///< HU volume file or DICOM folder (import_hu_volume)
  std::string series_uid;               ///< DICOM series to import; empty = the only usable one
  SegmentPreset preset;                 ///< with command-line overrides applied
  std::vector<std::string> overrides;   ///< what the command line changed, for the report
  std::filesystem::path output_prefix;  ///< PREFIX
  bool write_preview = true;
  bool show_progress = false;
};

struct SegmentJobResult {
  tsf::import::TissueVolumePaths volume_paths;
  std::filesystem::path report_path;
  std::filesystem::path preview_path;  ///< empty when no preview was written
  nlohmann::json report;
};

SegmentJobResult run_segment_job(const SegmentJob& job);

}  // namespace tsf::segment
