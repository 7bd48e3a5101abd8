#include <gtest/gtest.h>

#include <itkImage.h>
#include <itkImageFileReader.h>

#include "support/test_data.h"
#include "tsf/import/itk_io_factories.h"

namespace tsf::import {
namespace {

TEST(ItkIoFactories, ReadsBundledCraniumNrrd) {
  register_itk_io_factories();
  using Image = itk::Image<short, 3>;
  auto reader = itk::ImageFileReader<Image>::New();
  reader->SetFileName((test::samples_dir() / "ct-head-cranium" / "cranium.nrrd").string());
  ASSERT_NO_THROW(reader->Update());
  const auto size = reader->GetOutput()->GetLargestPossibleRegion().GetSize();
  EXPECT_EQ(size[0], 256u);
  EXPECT_EQ(size[1], 256u);
  EXPECT_EQ(size[2], 108u);
  EXPECT_NEAR(reader->GetOutput()->GetSpacing()[2], 1.5, 1e-6);
}

}  // namespace
}  // namespace tsf::import
