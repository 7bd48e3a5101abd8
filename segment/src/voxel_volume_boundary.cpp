#include "tsf/segment/voxel_volume_boundary.h"

#include <algorithm>
#include <string>

#include "tsf/common/error.h"

namespace tsf::segment {

namespace {

template <typename A, typename B>
bool same_grid(const A* a, const B* b) {
  return a->GetLargestPossibleRegion() == b->GetLargestPossibleRegion() &&
         a->GetSpacing() == b->GetSpacing() && a->GetOrigin() == b->GetOrigin() &&
         a->GetDirection() == b->GetDirection();
}

}  // namespace

VoxelVolume to_voxel_volume(const SegmentationImages& images) {
  require(images.density && images.labels,
          "segmentation has no density or label image to convert to a voxel volume");
  const DensityImage* density = images.density;
  require(same_grid(density, images.labels.GetPointer()),
          "segmentation: the label image's grid differs from the density image's");
  const bool with_weights = images.weights;
  if (with_weights)
    require(same_grid(density, images.weights.GetPointer()),
            "segmentation: the weight image's grid differs from the density image's");

  VolumeGeometry g;
  const auto region = density->GetLargestPossibleRegion();
  for (int a = 0; a < 3; ++a) {
    g.dims[a] = static_cast<int>(region.GetSize()[a]);
    g.spacing[a] = density->GetSpacing()[a];
    g.origin[a] = density->GetOrigin()[a];
  }
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.direction[r * 3 + c] = density->GetDirection()[r][c];

  VoxelVolume volume(g, with_weights);
  const std::size_t n = volume.voxel_count();
  std::copy(density->GetBufferPointer(), density->GetBufferPointer() + n,
            volume.density_data().begin());
  std::copy(images.labels->GetBufferPointer(), images.labels->GetBufferPointer() + n,
            volume.label_data().begin());
  if (with_weights) {
    const WeightPixel* w = images.weights->GetBufferPointer();
    auto& dst = volume.material_weight_data();
    for (std::size_t v = 0; v < n; ++v) dst[v] = {w[v][0], w[v][1], w[v][2], w[v][3]};
  }
  volume.validate();
  return volume;
}

}  // namespace tsf::segment
