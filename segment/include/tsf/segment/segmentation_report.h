// What a segmentation produced, in numbers: per class voxel count, volume (ml) and bounding box
// (mm), plus the body, the air spaces and the tissue as a whole. Written as PREFIX-report.json.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tsf/common/vec3.h"
#include "tsf/segment/segmentation_pipeline.h"

namespace tsf::segment {

/// Voxels of one label or mask. Bounding boxes span voxel centres: index (inclusive) and
/// physical LPS mm (the box of the index box's eight corners).
struct RegionStatistics {
  std::size_t voxels = 0;
  double ml = 0.0;
  std::array<int, 3> index_min{}, index_max{};
  Vec3d mm_min, mm_max;
};

struct ClassStatistics {
  std::uint8_t label = 0;
  std::string name;  ///< tissue_label_name(), or the region's name for region labels
  RegionStatistics region;
};

struct SegmentationStatistics {
  std::vector<ClassStatistics> classes;  ///< every label present except outside, ascending
  RegionStatistics body;                 ///< body mask
  RegionStatistics air_spaces;           ///< air inside the body
  RegionStatistics tissue;               ///< labels != outside (density >= 0.5)
  double density_ml = 0.0;               ///< Σ density · voxel volume (partial-volume aware)
};

SegmentationStatistics segmentation_statistics(const SegmentationResult& result,
                                               const SegmentPreset& preset);

/// ml of a class by label (0 when absent).
double class_ml(const SegmentationStatistics& stats, std::uint8_t label);

/// The report body: grid, ROI, classes, totals, regions, stage times, parameters (preset JSON).
nlohmann::json segmentation_report_json(const SegmentationResult& result,
                                        const SegmentationStatistics& stats,
                                        const SegmentPreset& preset);

}  // namespace tsf::segment
