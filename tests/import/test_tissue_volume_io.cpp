#include <gtest/gtest.h>

#include <fstream>

#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/import/tissue_volume_io.h"

namespace tsf::import {
namespace {

VoxelVolume make_volume(bool weights) {
  VolumeGeometry g;
  g.dims = {5, 4, 3};
  g.spacing = {0.5, 0.75, 1.25};
  g.origin = {-3, 7, 11};
  g.direction = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  VoxelVolume v(g, weights);
  for (std::size_t i = 0; i < v.voxel_count(); ++i) {
    v.density_data()[i] = static_cast<float>(i % 11) / 10.0f;
    v.label_data()[i] = static_cast<std::uint8_t>(i % 7);
    if (weights)
      v.material_weight_data()[i] = {static_cast<std::uint8_t>(255 - i),
                                     static_cast<std::uint8_t>(i), 0, 0};
  }
  return v;
}

TEST(TissueVolumeIo, RoundTripKeepsValuesAndGeometry) {
  const auto dir = test::scratch_dir("tvio");
  const VoxelVolume a = make_volume(true);
  const auto paths = write_tissue_volume(dir / "case", a);
  ASSERT_TRUE(std::filesystem::exists(paths.weights));
  const VoxelVolume b = read_tissue_volume(paths.density);
  ASSERT_EQ(b.dims(), a.dims());
  EXPECT_EQ(b.density_data(), a.density_data());
  EXPECT_EQ(b.label_data(), a.label_data());
  EXPECT_EQ(b.material_weight_data(), a.material_weight_data());
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(b.geometry().spacing[i], a.geometry().spacing[i], 1e-9);
    EXPECT_NEAR(b.geometry().origin[i], a.geometry().origin[i], 1e-9);
  }
  for (int i = 0; i < 9; ++i)
    EXPECT_NEAR(b.geometry().direction[i], a.geometry().direction[i], 1e-9);
}

TEST(TissueVolumeIo, HuVolumeIsRejectedNamingTheFile) {
  const auto cranium = test::samples_dir() / "ct-head-cranium" / "cranium.nrrd";
  try {
    read_tissue_volume(cranium);
    FAIL() << "a HU volume was accepted as density";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cranium.nrrd"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("[0,1]"), std::string::npos) << e.what();
  }
}

TEST(TissueVolumeIo, MismatchedLabelsAreRefused) {
  const auto dir = test::scratch_dir("tvio2");
  write_tissue_volume(dir / "a", make_volume(false));
  VolumeGeometry g;
  g.dims = {2, 2, 2};
  write_tissue_volume(dir / "b", VoxelVolume(g));
  std::filesystem::copy_file(dir / "b-labels.nrrd", dir / "a-labels.nrrd",
                             std::filesystem::copy_options::overwrite_existing);
  EXPECT_THROW(read_tissue_volume(dir / "a-density.nrrd"), Error);
}

}  // namespace
}  // namespace tsf::import
