#include "tsf/segment/segmentation_report.h"

#include <algorithm>
#include <limits>

#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {

namespace {

/// Accumulates count and index bounding box of the voxels of a region.
struct RegionAccumulator {
  std::size_t voxels = 0;
  std::array<int, 3> lo{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(),
                        std::numeric_limits<int>::max()};
  std::array<int, 3> hi{-1, -1, -1};
  void add(int i, int j, int k) {
    ++voxels;
    lo = {std::min(lo[0], i), std::min(lo[1], j), std::min(lo[2], k)};
    hi = {std::max(hi[0], i), std::max(hi[1], j), std::max(hi[2], k)};
  }
  RegionStatistics finish(const HuImage* grid) const {
    RegionStatistics s;
    s.voxels = voxels;
    const auto& sp = grid->GetSpacing();
    s.ml = static_cast<double>(voxels) * sp[0] * sp[1] * sp[2] / 1000.0;
    if (voxels == 0) return s;
    s.index_min = lo;
    s.index_max = hi;
    for (int a = 0; a < 3; ++a) {
      s.mm_min[a] = std::numeric_limits<double>::max();
      s.mm_max[a] = std::numeric_limits<double>::lowest();
    }
    for (int corner = 0; corner < 8; ++corner) {
      HuImage::IndexType idx;
      for (int a = 0; a < 3; ++a) idx[a] = (corner >> a) & 1 ? hi[a] : lo[a];
      HuImage::PointType p;
      grid->TransformIndexToPhysicalPoint(idx, p);
      for (int a = 0; a < 3; ++a) {
        s.mm_min[a] = std::min(s.mm_min[a], p[a]);
        s.mm_max[a] = std::max(s.mm_max[a], p[a]);
      }
    }
    return s;
  }
};

nlohmann::json region_json(const RegionStatistics& s) {
  nlohmann::json j{{"voxels", s.voxels}, {"ml", s.ml}};
  if (s.voxels > 0) {
    j["bbox_mm"] = {{"min", {s.mm_min.x, s.mm_min.y, s.mm_min.z}},
                    {"max", {s.mm_max.x, s.mm_max.y, s.mm_max.z}}};
    j["bbox_index"] = {{"min", s.index_min}, {"max", s.index_max}};
  }
  return j;
}

}  // namespace

SegmentationStatistics segmentation_statistics(const SegmentationResult& result,
                                               const SegmentPreset& preset) {
  const SegmentationImages& im = result.images;
  const HuImage* grid = im.hu;
  const auto size = grid->GetLargestPossibleRegion().GetSize();
  const int nx = static_cast<int>(size[0]), ny = static_cast<int>(size[1]),
            nz = static_cast<int>(size[2]);
  const unsigned char* labels = im.labels->GetBufferPointer();
  const unsigned char* body = im.body ? im.body->GetBufferPointer() : nullptr;
  const unsigned char* air = im.air_spaces ? im.air_spaces->GetBufferPointer() : nullptr;
  const float* density = im.density->GetBufferPointer();

  std::array<RegionAccumulator, 256> per_label;
  RegionAccumulator body_acc, air_acc, tissue_acc;
  double density_sum = 0.0;
  std::size_t v = 0;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i, ++v) {
        const unsigned char l = labels[v];
        per_label[l].add(i, j, k);
        if (l != kLabelOutside) tissue_acc.add(i, j, k);
        if (body && body[v]) body_acc.add(i, j, k);
        if (air && air[v]) air_acc.add(i, j, k);
        density_sum += static_cast<double>(density[v]);
      }

  SegmentationStatistics stats;
  for (int l = 1; l < 256; ++l) {
    if (per_label[l].voxels == 0) continue;
    ClassStatistics c;
    c.label = static_cast<std::uint8_t>(l);
    c.name = tissue_label_name(c.label);
    for (const auto& r : preset.regions)
      if (r.label == c.label) c.name = r.name;
    c.region = per_label[l].finish(grid);
    stats.classes.push_back(c);
  }
  stats.body = body_acc.finish(grid);
  stats.air_spaces = air_acc.finish(grid);
  stats.tissue = tissue_acc.finish(grid);
  const auto& sp = grid->GetSpacing();
  stats.density_ml = density_sum * sp[0] * sp[1] * sp[2] / 1000.0;
  return stats;
}

double class_ml(const SegmentationStatistics& stats, std::uint8_t label) {
  for (const auto& c : stats.classes)
    if (c.label == label) return c.region.ml;
  return 0.0;
}

nlohmann::json segmentation_report_json(const SegmentationResult& result,
                                        const SegmentationStatistics& stats,
                                        const SegmentPreset& preset) {
  using nlohmann::json;
  const HuImage* grid = result.images.hu;
  const auto size = grid->GetLargestPossibleRegion().GetSize();
  json j;
  json dir = json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) dir.push_back(grid->GetDirection()[r][c]);
  j["grid"] = {{"dims", {size[0], size[1], size[2]}},
               {"voxel_mm", result.voxel_mm},
               {"origin_mm", {grid->GetOrigin()[0], grid->GetOrigin()[1], grid->GetOrigin()[2]}},
               {"direction", dir},
               {"voxel_ml", result.voxel_mm * result.voxel_mm * result.voxel_mm / 1000.0}};
  j["roi_input_index"] = {{"first", {result.roi.first.x, result.roi.first.y, result.roi.first.z}},
                          {"last", {result.roi.last.x, result.roi.last.y, result.roi.last.z}}};
  json classes = json::array();
  for (const auto& c : stats.classes) {
    json e = region_json(c.region);
    e["label"] = c.label;
    e["name"] = c.name;
    classes.push_back(e);
  }
  j["classes"] = classes;
  j["body"] = region_json(stats.body);
  j["air_spaces"] = region_json(stats.air_spaces);
  j["tissue"] = region_json(stats.tissue);
  j["tissue"]["density_integrated_ml"] = stats.density_ml;
  json regions = json::array();
  for (const auto& r : result.regions)
    regions.push_back({{"name", r.name},
                       {"label", r.label},
                       {"grown_voxels", r.grown_voxels},
                       {"labelled_voxels", r.labelled_voxels}});
  j["regions"] = regions;
  json stages = json::array();
  double total = 0.0;
  for (const auto& s : result.stage_times) {
    stages.push_back({{"stage", s.stage}, {"seconds", s.seconds}});
    total += s.seconds;
  }
  j["stage_times"] = stages;
  j["segmentation_seconds"] = total;
  j["parameters"] = preset.to_json();
  return j;
}

}  // namespace tsf::segment
