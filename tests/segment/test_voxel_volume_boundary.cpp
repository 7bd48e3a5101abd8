#include <gtest/gtest.h>

#include "segment_test_images.h"
#include "tsf/common/error.h"
#include "tsf/segment/voxel_volume_boundary.h"

namespace tsf::segment {
namespace {

using test::blank_image;

TEST(VoxelVolumeBoundary, CopiesValuesAndGeometry) {
  SegmentationImages images;
  images.density = blank_image<DensityImage>(5, 4, 3, 0.25f, 0.5, 0.5, 0.5);
  HuImage::PointType origin;
  origin[0] = -10;
  origin[1] = 20;
  origin[2] = 5.5;
  HuImage::DirectionType direction;
  direction.Fill(0.0);
  direction[0][1] = -1;
  direction[1][0] = 1;
  direction[2][2] = 1;
  images.density->SetOrigin(origin);
  images.density->SetDirection(direction);
  images.labels = blank_image<LabelImage>(5, 4, 3, 2, 0.5, 0.5, 0.5);
  images.labels->CopyInformation(images.density);
  images.weights = blank_image<WeightImage>(5, 4, 3, WeightPixel(), 0.5, 0.5, 0.5);
  images.weights->CopyInformation(images.density);
  WeightPixel w;
  w[0] = 100;
  w[1] = 55;
  w[2] = 0;
  w[3] = 100;
  images.weights->FillBuffer(w);
  images.density->GetBufferPointer()[7] = 0.75f;

  const VoxelVolume v = to_voxel_volume(images);
  EXPECT_EQ(v.dims(), (Int3{5, 4, 3}));
  EXPECT_DOUBLE_EQ(v.geometry().spacing.x, 0.5);
  EXPECT_DOUBLE_EQ(v.geometry().origin.y, 20.0);
  EXPECT_DOUBLE_EQ(v.geometry().direction[1], -1.0);  // row 0, column 1
  EXPECT_DOUBLE_EQ(v.geometry().direction[3], 1.0);   // row 1, column 0
  EXPECT_FLOAT_EQ(v.density_data()[7], 0.75f);
  EXPECT_EQ(v.label_data()[0], 2);
  EXPECT_EQ(v.material_weight_data()[11], (std::array<std::uint8_t, 4>{100, 55, 0, 100}));
}

TEST(VoxelVolumeBoundary, MismatchedGridsAreRejected) {
  SegmentationImages images;
  images.density = blank_image<DensityImage>(5, 4, 3, 0.0f);
  images.labels = blank_image<LabelImage>(5, 4, 4, 0);
  EXPECT_THROW(to_voxel_volume(images), Error);
  images.labels = blank_image<LabelImage>(5, 4, 3, 0, 1.0, 1.0, 2.0);
  EXPECT_THROW(to_voxel_volume(images), Error);
  images.labels = nullptr;
  EXPECT_THROW(to_voxel_volume(images), Error);
}

}  // namespace
}  // namespace tsf::segment
