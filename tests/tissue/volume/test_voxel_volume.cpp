#include <gtest/gtest.h>

#include "tsf/common/error.h"
#include "tsf/volume/voxel_volume.h"

namespace tsf {
namespace {

TEST(VoxelVolume, IndexToPhysicalRoundTripsWithDirection) {
  VolumeGeometry g;
  g.dims = {4, 5, 6};
  g.spacing = {0.5, 0.75, 2.0};
  g.origin = {-10, 20, 3};
  // 90° about z: i axis -> +y, j axis -> -x.
  g.direction = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  const Vec3d ijk{1.5, 2.0, 3.25};
  const Vec3d p = g.index_to_physical(ijk);
  EXPECT_NEAR(p.x, -10 - 2.0 * 0.75, 1e-12);
  EXPECT_NEAR(p.y, 20 + 1.5 * 0.5, 1e-12);
  const Vec3d back = g.physical_to_index(p);
  EXPECT_NEAR(back.x, ijk.x, 1e-12);
  EXPECT_NEAR(back.y, ijk.y, 1e-12);
  EXPECT_NEAR(back.z, ijk.z, 1e-12);
  EXPECT_FALSE(g.identity_direction());
}

TEST(VoxelVolume, ValidateNamesOutOfRangeDensity) {
  VolumeGeometry g;
  g.dims = {2, 2, 2};
  VoxelVolume v(g);
  v.validate();
  v.density_data()[5] = 1.5f;
  try {
    v.validate();
    FAIL() << "validate accepted density 1.5";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("voxel 5"), std::string::npos) << e.what();
  }
}

TEST(VoxelVolume, RejectsEmptyDimensions) {
  VolumeGeometry g;
  g.dims = {0, 3, 3};
  EXPECT_THROW(VoxelVolume{g}, Error);
}

}  // namespace
}  // namespace tsf
