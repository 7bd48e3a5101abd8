#include <gtest/gtest.h>

#include <itkImageFileWriter.h>

#include <fstream>

#include "segment_test_images.h"
#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/import/itk_io_factories.h"
#include "tsf/segment/hu_volume_source.h"

namespace tsf::segment {
namespace {

std::string read_error(const std::filesystem::path& p) {
  try {
    read_hu_volume(p);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(HuVolumeSource, ReadsTheBundledCraniumInHounsfieldUnits) {
  const auto hu = read_hu_volume(tsf::test::samples_dir() / "ct-head-cranium" / "cranium.nrrd");
  const auto size = hu->GetLargestPossibleRegion().GetSize();
  EXPECT_EQ(size[0], 256u);
  EXPECT_EQ(size[2], 108u);
  EXPECT_NEAR(hu->GetSpacing()[2], 1.5, 1e-6);
  float lo = 1e9f, hi = -1e9f;
  const float* p = hu->GetBufferPointer();
  for (std::size_t v = 0; v < hu->GetLargestPossibleRegion().GetNumberOfPixels(); ++v) {
    lo = std::min(lo, p[v]);
    hi = std::max(hi, p[v]);
  }
  EXPECT_LE(lo, -1000.0f);  // air
  EXPECT_GE(hi, 1500.0f);   // dense bone
}

TEST(HuVolumeSource, ErrorsNameThePathAndWhatIsExpected) {
  const auto dir = tsf::test::scratch_dir("source");
  EXPECT_NE(read_error(dir / "missing.nrrd").find("missing.nrrd"), std::string::npos);
  EXPECT_NE(read_error(dir).find(dir.filename().string()), std::string::npos);
  std::ofstream(dir / "notes.txt") << "not an image";
  EXPECT_NE(read_error(dir / "notes.txt").find("notes.txt"), std::string::npos);

  // A 2-D image is not a volume.
  tsf::import::register_itk_io_factories();
  using Slice = itk::Image<short, 2>;
  auto slice = Slice::New();
  Slice::SizeType size;
  size.Fill(8);
  slice->SetRegions(Slice::RegionType(size));
  slice->Allocate();
  slice->FillBuffer(0);
  auto writer = itk::ImageFileWriter<Slice>::New();
  writer->SetFileName((dir / "slice.nrrd").string());
  writer->SetInput(slice);
  writer->Update();
  const std::string message = read_error(dir / "slice.nrrd");
  EXPECT_NE(message.find("slice.nrrd"), std::string::npos) << message;
  EXPECT_NE(message.find("expected a volume"), std::string::npos) << message;
}

}  // namespace
}  // namespace tsf::segment
