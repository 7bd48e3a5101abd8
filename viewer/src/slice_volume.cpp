#include "tsf/viewer/slice_volume.h"

#include <cmath>

#include "tsf/common/error.h"

namespace tsf::viewer {

void SliceVolume::validate() const {
  const auto n = static_cast<std::size_t>(geometry.dims.volume());
  require(n > 0, "slice volume: empty grid");
  require(values.size() == n, "slice volume: " + std::to_string(values.size()) +
                                  " values for a grid of " + std::to_string(n) + " voxels");
  require(labels.empty() || labels.size() == n, "slice volume: " + std::to_string(labels.size()) +
                                                    " labels for " + std::to_string(n) + " voxels");
  require(window_high > window_low, "slice volume: the grey window is empty");
}

SliceVolume slices_from_tissue(const VoxelVolume& volume) {
  SliceVolume s;
  s.geometry = volume.geometry();
  s.values = volume.density_data();
  s.labels = volume.label_data();
  s.window_low = 0.0;  // empty voxels: black, see-through
  s.window_high = 1.1;
  s.description = "tissue density";
  return s;
}

SliceVolume slices_from_ct(const VolumeGeometry& g, std::vector<float> hu,
                           const VoxelVolume* labels, std::string description) {
  SliceVolume s;
  s.geometry = g;
  s.values = std::move(hu);
  s.window_low = -600;
  s.window_high = 1200;
  s.description = std::move(description);
  if (labels != nullptr) {
    const VolumeGeometry& lg = labels->geometry();
    const std::vector<std::uint8_t>& l = labels->label_data();
    s.labels.assign(static_cast<std::size_t>(g.dims.volume()), 0);
    std::size_t i = 0;
    for (int k = 0; k < g.dims.z; ++k)
      for (int j = 0; j < g.dims.y; ++j)
        for (int x = 0; x < g.dims.x; ++x, ++i) {
          const Vec3d p = g.index_to_tissue({double(x), double(j), double(k)});
          const long li = std::lround((p.x - lg.origin.x) / lg.spacing.x);
          const long lj = std::lround((p.y - lg.origin.y) / lg.spacing.y);
          const long lk = std::lround((p.z - lg.origin.z) / lg.spacing.z);
          if (li < 0 || lj < 0 || lk < 0 || li >= lg.dims.x || lj >= lg.dims.y || lk >= lg.dims.z)
            continue;
          s.labels[i] =
              l[labels->index(static_cast<int>(li), static_cast<int>(lj), static_cast<int>(lk))];
        }
  }
  s.validate();
  return s;
}

}  // namespace tsf::viewer
