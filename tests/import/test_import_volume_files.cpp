// NRRD, MetaImage and NIfTI volumes, and the HU volume writer (pixel type, atomicity).
#include <gtest/gtest.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>

#include <algorithm>
#include <fstream>

#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/import/hu_volume_writer.h"
#include "tsf/import/imaging_library_setup.h"
#include "tsf/import/import_report_json.h"
#include "tsf/import/import_volume.h"
#include "tsf/import/volume_file_reader.h"

namespace tsf::import {
namespace {
namespace fs = std::filesystem;

fs::path cranium() {
  return test::samples_dir() / "ct-head-cranium" / "cranium.nrrd";
}

ImportOptions quiet() {
  ImportOptions o;
  o.show_progress = false;
  return o;
}

bool same_values(const HuImage& a, const HuImage& b) {
  const std::size_t n = a.GetLargestPossibleRegion().GetNumberOfPixels();
  return n == b.GetLargestPossibleRegion().GetNumberOfPixels() &&
         std::equal(a.GetBufferPointer(), a.GetBufferPointer() + n, b.GetBufferPointer());
}

void expect_same_geometry(const HuImage& a, const HuImage& b) {
  EXPECT_EQ(a.GetLargestPossibleRegion().GetSize(), b.GetLargestPossibleRegion().GetSize());
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(a.GetSpacing()[i], b.GetSpacing()[i], 1e-6);
    EXPECT_NEAR(a.GetOrigin()[i], b.GetOrigin()[i], 1e-4);
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(a.GetDirection()[i][j], b.GetDirection()[i][j], 1e-6);
  }
}

TEST(ImportVolumeFiles, CraniumNrrdHasItsDocumentedGeometry) {
  const ImportResult r = import_volume(cranium(), quiet());
  const auto size = r.image->GetLargestPossibleRegion().GetSize();
  EXPECT_EQ(size[0], 256u);
  EXPECT_EQ(size[1], 256u);
  EXPECT_EQ(size[2], 108u);
  EXPECT_NEAR(r.image->GetSpacing()[0], 0.957, 5e-4);
  EXPECT_NEAR(r.image->GetSpacing()[1], 0.957, 5e-4);
  EXPECT_NEAR(r.image->GetSpacing()[2], 1.5, 1e-9);
  EXPECT_EQ(r.report.source.kind, "nrrd");
  EXPECT_TRUE(r.report.output.integral_values);
  EXPECT_LE(r.report.output.min_value, -1000.0f) << "air";
  EXPECT_GT(r.report.output.max_value, 700.0f) << "bone";
  ASSERT_EQ(r.report.warnings.size(), 1u);
  EXPECT_NE(r.report.warnings[0].find("no 'space'"), std::string::npos);

  // Same values as a plain ITK read of the file.
  setup_imaging_libraries();
  auto reader = itk::ImageFileReader<HuImage>::New();
  reader->SetFileName(cranium().string());
  reader->Update();
  EXPECT_TRUE(same_values(*r.image, *reader->GetOutput()));
}

TEST(ImportVolumeFiles, WrittenVolumesReadBackIdenticallyInEveryFormat) {
  const ImportResult r = import_volume(cranium(), quiet());
  const fs::path dir = test::scratch_dir("formats");
  for (const char* name : {"c.nrrd", "c.mha"}) {
    EXPECT_EQ(write_hu_volume(dir / name, *r.image), "int16") << name;
    const ImportResult back = import_volume(dir / name, quiet());
    EXPECT_TRUE(same_values(*back.image, *r.image)) << name;
    expect_same_geometry(*back.image, *r.image);
    EXPECT_TRUE(back.report.warnings.empty()) << name << ": the written header records LPS";
  }
  // NIfTI (RAS on disk) through ITK's writer: LPS geometry survives the round trip.
  auto writer = itk::ImageFileWriter<HuImage>::New();
  writer->SetInput(r.image);
  writer->SetFileName((dir / "c.nii").string());
  writer->Update();
  const ImportResult nifti = import_volume(dir / "c.nii", quiet());
  EXPECT_EQ(nifti.report.source.kind, "nifti");
  EXPECT_TRUE(same_values(*nifti.image, *r.image));
  expect_same_geometry(*nifti.image, *r.image);
}

TEST(ImportVolumeFiles, NonIntegralValuesAreWrittenAsFloat) {
  auto image = HuImage::New();
  HuImage::RegionType region;
  region.SetSize({4, 3, 2});
  image->SetRegions(region);
  image->Allocate();
  for (std::size_t i = 0; i < 24; ++i)
    image->GetBufferPointer()[i] = -1000.5f + static_cast<float>(i);
  const fs::path dir = test::scratch_dir("float");
  EXPECT_EQ(write_hu_volume(dir / "f.nrrd", *image), "float32");
  EXPECT_EQ(inspect_volume_file(dir / "f.nrrd", 1000).component_type, "float");
  // Whole numbers beyond int16 are float too.
  for (std::size_t i = 0; i < 24; ++i) image->GetBufferPointer()[i] = 40000.0f;
  EXPECT_EQ(write_hu_volume(dir / "big.mha", *image), "float32");
  // Whole numbers in range are int16.
  for (std::size_t i = 0; i < 24; ++i) image->GetBufferPointer()[i] = -1024.0f + 3.0f * i;
  EXPECT_EQ(write_hu_volume(dir / "i.nrrd", *image), "int16");
  EXPECT_EQ(inspect_volume_file(dir / "i.nrrd", 1000).component_type, "short");
}

TEST(ImportVolumeFiles, FailedWritesLeaveNothingBehind) {
  const ImportResult r = import_volume(cranium(), quiet());
  const fs::path dir = test::scratch_dir("atomic");
  fs::create_directories(dir / "taken.nrrd");  // a directory where the file should go
  EXPECT_THROW(write_hu_volume(dir / "taken.nrrd", *r.image), Error);
  EXPECT_THROW(write_hu_volume(dir / "volume.vtk", *r.image), Error) << "only .nrrd and .mha";
  std::vector<fs::path> left;
  for (const auto& e : fs::recursive_directory_iterator(dir)) left.push_back(e.path());
  EXPECT_EQ(left.size(), 1u) << "only the directory itself: no temporary files";
}

TEST(ImportVolumeFiles, SidecarJsonRoundTrips) {
  const ImportResult r = import_volume(cranium(), quiet());
  const fs::path path = test::scratch_dir("json") / "c.json";
  write_json_atomically(path, import_report_to_json(r.report));
  std::ifstream in(path);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("format"), kImportSidecarFormat);
  EXPECT_EQ(j.at("output").at("dims"), nlohmann::json({256, 256, 108}));
  EXPECT_EQ(j.at("source").at("kind"), "nrrd");
  EXPECT_TRUE(j.at("series").is_null());
  EXPECT_GE(j.at("seconds").at("total").get<double>(), 0.0);
}

TEST(ImportVolumeFiles, HeaderProblemsAreNamed) {
  const fs::path dir = test::scratch_dir("headers");
  auto write = [&](const char* name, const std::string& text) {
    std::ofstream(dir / name, std::ios::binary) << text;
    return dir / name;
  };
  auto message = [&](const fs::path& p) {
    try {
      import_volume(p, quiet());
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  const std::string two_d = message(
      write("slice.nrrd",
            "NRRD0004\ntype: int16\ndimension: 2\nsizes: 4 4\nendian: little\nencoding: raw\n\n" +
                std::string(32, '\0')));
  EXPECT_NE(two_d.find("single slice"), std::string::npos) << two_d;
  const std::string rgb = message(
      write("rgb.nrrd",
            "NRRD0004\ntype: uint8\ndimension: 4\nsizes: 3 4 4 4\nkinds: RGB-color domain domain "
            "domain\nencoding: raw\n\n" +
                std::string(192, '\0')));
  EXPECT_NE(rgb.find("components per voxel"), std::string::npos) << rgb;
  const std::string sheared = message(
      write("shear.nrrd",
            "NRRD0004\ntype: int16\ndimension: 3\nspace: left-posterior-superior\nsizes: 4 4 4\n"
            "space directions: (1,0,0) (0,1,0) (0,0.5,1)\nendian: little\nencoding: raw\n\n" +
                std::string(128, '\0')));
  EXPECT_NE(sheared.find("not orthonormal"), std::string::npos) << sheared;
  EXPECT_NE(sheared.find("shear.nrrd"), std::string::npos) << sheared;
  const std::string nan =
      message(write("nan.nrrd",
                    "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nendian: "
                    "little\n\n" +
                        std::string(28, '\0') + std::string("\x00\x00\xc0\x7f", 4)));
  EXPECT_NE(nan.find("NaN"), std::string::npos) << nan;
}

}  // namespace
}  // namespace tsf::import
