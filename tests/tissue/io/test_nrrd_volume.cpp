// The core's NRRD reader (tsf/io/nrrd_volume.h): geometry as ITK gives it (spacing = length of a
// space direction, direction = its unit vector, RAS turned into LPS), every scalar type and both
// endiannesses, raw and gzip data, tissue volumes with their labels and weights, and clear errors
// naming the file and field for everything else. The sample CT and, where present, the committed
// segmented cranium are read too.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "gzip_test_helpers.h"
#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/io/nrrd_volume.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;
using test::as_bytes;
using test::write_nrrd;

std::string error_of(const fs::path& p, bool tissue = false) {
  try {
    if (tissue)
      (void)io::read_tissue_volume_nrrd(p);
    else
      (void)io::read_nrrd(p);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(NrrdVolume, ObliqueLpsGeometryIsReadAsItkReadsIt) {
  const fs::path dir = test::scratch_dir("nrrd-oblique");
  // Axis i along (0.6, 0.8, 0)·2 mm, j along (−0.8, 0.6, 0)·1.5 mm, k along z·3 mm.
  const std::string header =
      "type: float\ndimension: 3\nspace: left-posterior-superior\nsizes: 3 2 2\n"
      "space directions: (1.2,1.6,0) (-1.2,0.9,0) (0,0,3)\nspace origin: (10,-20,30.5)\n"
      "kinds: domain domain domain\nendian: little\n";
  std::vector<float> values(12);
  for (int i = 0; i < 12; ++i) values[i] = 0.05f * i;
  for (bool gzip : {false, true}) {
    write_nrrd(dir / "v.nrrd", header, as_bytes(values), gzip);
    const io::NrrdVolume v = io::read_nrrd(dir / "v.nrrd");
    EXPECT_EQ(v.geometry.dims, (Int3{3, 2, 2}));
    EXPECT_NEAR(v.geometry.spacing.x, 2.0, 1e-12);
    EXPECT_NEAR(v.geometry.spacing.y, 1.5, 1e-12);
    EXPECT_NEAR(v.geometry.spacing.z, 3.0, 1e-12);
    EXPECT_EQ(v.geometry.origin, (Vec3d{10, -20, 30.5}));
    const std::array<double, 9> d = {0.6, -0.8, 0, 0.8, 0.6, 0, 0, 0, 1};
    for (int e = 0; e < 9; ++e) EXPECT_NEAR(v.geometry.direction[e], d[e], 1e-12) << e;
    EXPECT_TRUE(v.has_space);
    EXPECT_EQ(v.as_float(), values);
  }
}

TEST(NrrdVolume, RasSpaceIsTurnedIntoLps) {
  const fs::path dir = test::scratch_dir("nrrd-ras");
  write_nrrd(dir / "v.nrrd",
             "type: uint8\ndimension: 3\nspace: right-anterior-superior\nsizes: 2 2 2\n"
             "space directions: (-1,0,0) (0,-1,0) (0,0,1)\nspace origin: (5,6,7)\n",
             std::vector<std::uint8_t>(8, 1), false);
  const io::NrrdVolume v = io::read_nrrd(dir / "v.nrrd");
  EXPECT_EQ(v.geometry.origin, (Vec3d{-5, -6, 7}));
  const std::array<double, 9> identity = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  for (int e = 0; e < 9; ++e) EXPECT_DOUBLE_EQ(v.geometry.direction[e], identity[e]);
}

TEST(NrrdVolume, EveryScalarTypeAndBothEndiannessesGiveTheSameValues) {
  const fs::path dir = test::scratch_dir("nrrd-types");
  const std::vector<double> expect = {0, 1, 2, 3, 4, 5, 6, 7};
  auto check = [&](const std::string& type, std::vector<std::uint8_t> bytes, std::size_t size) {
    for (bool big : {false, true}) {
      std::vector<std::uint8_t> b = bytes;
      if (big)
        for (std::size_t i = 0; i < b.size(); i += size)
          std::reverse(b.begin() + i, b.begin() + i + size);
      write_nrrd(dir / "t.nrrd",
                 "type: " + type + "\ndimension: 3\nsizes: 2 2 2\nspacings: 1 1 1\nendian: " +
                     (big ? "big" : "little") + "\n",
                 b, big);
      const io::NrrdVolume v = io::read_nrrd(dir / "t.nrrd");
      ASSERT_EQ(v.value_count(), 8u) << type;
      for (std::size_t i = 0; i < 8; ++i) EXPECT_EQ(v.value(i), expect[i]) << type << " " << big;
      EXPECT_FALSE(v.has_space);
    }
  };
  check("signed char", as_bytes(std::vector<std::int8_t>{0, 1, 2, 3, 4, 5, 6, 7}), 1);
  check("uchar", as_bytes(std::vector<std::uint8_t>{0, 1, 2, 3, 4, 5, 6, 7}), 1);
  check("short", as_bytes(std::vector<std::int16_t>{0, 1, 2, 3, 4, 5, 6, 7}), 2);
  check("unsigned short", as_bytes(std::vector<std::uint16_t>{0, 1, 2, 3, 4, 5, 6, 7}), 2);
  check("int", as_bytes(std::vector<std::int32_t>{0, 1, 2, 3, 4, 5, 6, 7}), 4);
  check("uint32", as_bytes(std::vector<std::uint32_t>{0, 1, 2, 3, 4, 5, 6, 7}), 4);
  check("int64", as_bytes(std::vector<std::int64_t>{0, 1, 2, 3, 4, 5, 6, 7}), 8);
  check("float", as_bytes(std::vector<float>{0, 1, 2, 3, 4, 5, 6, 7}), 4);
  check("double", as_bytes(std::vector<double>{0, 1, 2, 3, 4, 5, 6, 7}), 8);
}

TEST(NrrdVolume, TissueVolumeReadsLabelsAndWeightsBesideTheDensity) {
  const fs::path dir = test::scratch_dir("nrrd-tissue");
  const std::string geometry =
      "dimension: 3\nspace: left-posterior-superior\nsizes: 4 3 2\n"
      "space directions: (0.5,0,0) (0,0.5,0) (0,0,1)\nspace origin: (1,2,3)\nendian: little\n";
  std::vector<float> density(24);
  std::vector<std::uint8_t> labels(24), weights(96);
  for (int i = 0; i < 24; ++i) {
    density[i] = i / 23.0f;
    labels[i] = static_cast<std::uint8_t>(i % 7);
    weights[4 * i] = static_cast<std::uint8_t>(255 - i);
    weights[4 * i + 1] = static_cast<std::uint8_t>(i);
  }
  write_nrrd(dir / "p-density.nrrd", "type: float\n" + geometry, as_bytes(density), true);
  write_nrrd(dir / "p-labels.nrrd", "type: unsigned char\n" + geometry, labels, true);
  write_nrrd(dir / "p-weights.nrrd",
             "type: unsigned char\ndimension: 4\nspace: left-posterior-superior\nsizes: 4 4 3 2\n"
             "space directions: none (0.5,0,0) (0,0.5,0) (0,0,1)\nspace origin: (1,2,3)\n"
             "kinds: vector domain domain domain\nendian: little\n",
             weights, true);
  const VoxelVolume v = io::read_tissue_volume_nrrd(dir / "p-density.nrrd");
  EXPECT_EQ(v.dims(), (Int3{4, 3, 2}));
  EXPECT_EQ(v.density_data(), density);
  EXPECT_EQ(v.label_data(), labels);
  ASSERT_TRUE(v.has_material_weights());
  for (int i = 0; i < 24; ++i) {
    EXPECT_EQ(v.material_weight_data()[i][0], 255 - i);
    EXPECT_EQ(v.material_weight_data()[i][1], i);
  }

  // Without labels: the density decides (≥ 0.5 soft tissue).
  fs::remove(dir / "p-labels.nrrd");
  fs::remove(dir / "p-weights.nrrd");
  const VoxelVolume w = io::read_tissue_volume_nrrd(dir / "p-density.nrrd");
  for (int i = 0; i < 24; ++i)
    EXPECT_EQ(w.label_data()[i], density[i] >= 0.5f ? kLabelSoftTissue : kLabelOutside);
  EXPECT_FALSE(w.has_material_weights());

  // Labels of another geometry are refused, naming both files.
  write_nrrd(dir / "p-labels.nrrd",
             "type: uchar\ndimension: 3\nspace: left-posterior-superior\nsizes: 4 3 2\n"
             "space directions: (0.5,0,0) (0,0.5,0) (0,0,1)\nspace origin: (1,2,9)\n",
             labels, false);
  const std::string e = error_of(dir / "p-density.nrrd", true);
  EXPECT_NE(e.find("p-labels.nrrd"), std::string::npos) << e;
  EXPECT_NE(e.find("p-density.nrrd"), std::string::npos) << e;
}

TEST(NrrdVolume, BadFilesAreRefusedNamingTheFileAndField) {
  const fs::path dir = test::scratch_dir("nrrd-bad");
  const std::vector<std::uint8_t> eight(8, 1);
  struct Case {
    std::string header;
    std::vector<std::uint8_t> data;
    bool tissue;
    std::string expect;
  };
  const std::string ok = "dimension: 3\nsizes: 2 2 2\nspacings: 1 1 1\n";
  const std::vector<Case> cases = {
      {"type: quaternion\n" + ok, eight, false, "type"},
      {"type: uchar\ndimension: 2\nsizes: 2 2\nspacings: 1 1\n", eight, false, "dimension"},
      {"type: uchar\ndimension: 3\nsizes: 2 2\nspacings: 1 1 1\n", eight, false, "sizes"},
      {"type: uchar\ndimension: 3\nsizes: 2 2 0\nspacings: 1 1 1\n", eight, false, "sizes"},
      {"type: uchar\ndimension: 3\nsizes: 2 2 2\n", eight, false, "spacings"},
      {"type: uchar\ndimension: 3\nsizes: 2 2 2\nspacings: 1 -1 1\n", eight, false, "spacings"},
      {"type: uchar\n" + ok, std::vector<std::uint8_t>(7, 1), false, "truncated"},
      {"type: short\n" + ok, std::vector<std::uint8_t>(16, 0), false, "endian"},
      {"type: uchar\nspace: scanner-xyz\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n" + ok, eight,
       false, "space"},
      {"type: uchar\nsizes: 100000 100000 100000\ndimension: 3\nspacings: 1 1 1\n", eight, false,
       "GiB"},
      {"type: uchar\ndata file: missing.raw\n" + ok, {}, false, "missing.raw"},
      {"type: uchar\n" + ok, std::vector<std::uint8_t>(8, 2), true, "[0,1]"},
  };
  for (std::size_t c = 0; c < cases.size(); ++c) {
    const fs::path p = dir / ("case" + std::to_string(c) + "-density.nrrd");
    write_nrrd(p, cases[c].header, cases[c].data, false);
    const std::string e = error_of(p, cases[c].tissue);
    EXPECT_NE(e.find(p.filename().string()), std::string::npos) << c << ": " << e;
    EXPECT_NE(e.find(cases[c].expect), std::string::npos) << c << ": " << e;
  }
  // Not a NRRD at all; a missing file.
  std::ofstream(dir / "text.nrrd") << "hello\n";
  EXPECT_NE(error_of(dir / "text.nrrd").find("not a NRRD"), std::string::npos);
  EXPECT_NE(error_of(dir / "none.nrrd").find("cannot open"), std::string::npos);
}

TEST(NrrdVolume, DetachedDataFileIsReadBesideTheHeader) {
  const fs::path dir = test::scratch_dir("nrrd-detached");
  std::ofstream(dir / "v.raw", std::ios::binary).write("\x00\x01\x02\x03\x04\x05\x06\x07", 8);
  std::ofstream(dir / "v.nhdr") << "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\n"
                                   "spacings: 1 1 1\nencoding: raw\ndata file: v.raw\n";
  const io::NrrdVolume v = io::read_nrrd(dir / "v.nhdr");
  for (std::size_t i = 0; i < 8; ++i) EXPECT_EQ(v.value(i), double(i));
}

TEST(NrrdVolume, TheSampleCtReadsWithItsHeadersGeometry) {
  const io::NrrdVolume v = io::read_nrrd(test::samples_dir() / "ct-head-cranium" / "cranium.nrrd");
  EXPECT_EQ(v.geometry.dims, (Int3{256, 256, 108}));
  EXPECT_NEAR(v.geometry.spacing.x, 0.9570312, 1e-9);
  EXPECT_NEAR(v.geometry.spacing.z, 1.5, 1e-12);
  EXPECT_EQ(v.type, io::NrrdType::kInt16);
  EXPECT_FALSE(v.has_space);  // the sample records no orientation
  // Air around the head and bone inside it: the HU span of a head CT.
  double lo = 1e9, hi = -1e9;
  for (std::size_t i = 0; i < v.value_count(); ++i) {
    lo = std::min(lo, v.value(i));
    hi = std::max(hi, v.value(i));
  }
  EXPECT_LE(lo, -900);
  EXPECT_GE(hi, 1000);
}

TEST(NrrdVolume, TheSegmentedSampleReadsWithItsLabelsAndWeights) {
  // data-samples/ct-head-cranium/segmented: tsf segment's output, cropped to the face
  // (scripts/segmented-sample.sh); the GPU machine's build reads it this way.
  const fs::path density =
      test::samples_dir() / "ct-head-cranium" / "segmented" / "cranium-density.nrrd";
  const VoxelVolume v = io::read_tissue_volume_nrrd(density);
  EXPECT_EQ(v.dims(), (Int3{73, 75, 84}));
  EXPECT_NEAR(v.geometry().spacing.x, 0.9570312, 1e-6);
  EXPECT_NEAR(v.geometry().origin.x, 88.0468704, 1e-6);
  EXPECT_NEAR(v.geometry().origin.y, 167.48046, 1e-6);
  ASSERT_TRUE(v.has_material_weights());
  std::size_t tissue = 0, bone = 0, weighted = 0;
  for (std::size_t i = 0; i < v.voxel_count(); ++i) {
    tissue += is_tissue_label(v.label_data()[i]);
    bone += is_bone_label(v.label_data()[i]);
    const auto& w = v.material_weight_data()[i];
    weighted += (w[0] + w[1] + w[2] + w[3]) == 255;
  }
  EXPECT_GT(tissue, v.voxel_count() / 10);  // the face fills a good part of the crop
  EXPECT_GT(bone, 1000u);                   // the maxilla and nasal bones
  EXPECT_GT(weighted, v.voxel_count() / 10);
}

}  // namespace
}  // namespace tsf
