#include <gtest/gtest.h>

#include <itkImageFileReader.h>
#include <itkPNGImageIO.h>
#include <itkRGBPixel.h>

#include "support/test_data.h"
#include "tsf/segment/segmentation_pipeline.h"
#include "tsf/segment/segmentation_report.h"
#include "tsf/segment/slice_preview.h"
#include "tsf/segment/sphere_phantom.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::segment {
namespace {

TEST(SlicePreview, WritesAPngWithTintedTissueOverGreyCt) {
  SpherePhantom phantom;
  phantom.dims = 40;
  phantom.radius_mm = 12.0;
  const SegmentPreset preset = load_segment_preset("sinus");
  const auto result = segment_hu_image(make_sphere_phantom(phantom), preset);
  const auto stats = segmentation_statistics(result, preset);
  const auto png = tsf::test::scratch_dir("preview") / "sphere-preview.png";
  SlicePreviewOptions options;
  options.scale = 3;
  const SlicePreviewInfo info = write_slice_preview(png, result.images, stats, options);
  ASSERT_TRUE(std::filesystem::exists(png));

  using Rgb = itk::Image<itk::RGBPixel<unsigned char>, 2>;
  auto reader = itk::ImageFileReader<Rgb>::New();
  reader->SetImageIO(itk::PNGImageIO::New());
  reader->SetFileName(png.string());
  reader->Update();
  const auto size = reader->GetOutput()->GetLargestPossibleRegion().GetSize();
  EXPECT_EQ(static_cast<int>(size[0]), info.width);
  EXPECT_EQ(static_cast<int>(size[1]), info.height);

  // The axial panel's pixel over the sphere's centre voxel: soft-tissue tint, not grey.
  const auto dims = result.images.hu->GetLargestPossibleRegion().GetSize();
  Rgb::IndexType centre;
  centre[0] = 10 + 3 * static_cast<long>(dims[0] / 2);
  centre[1] = 10 + 22 + 3 * static_cast<long>(dims[1] / 2);
  const auto pixel = reader->GetOutput()->GetPixel(centre);
  EXPECT_GT(pixel.GetRed(), pixel.GetBlue() + 20) << "not tinted as soft tissue";
  // The corner of the panel is air: grey (black) and untinted.
  Rgb::IndexType corner;
  corner[0] = 10;
  corner[1] = 32;
  const auto air = reader->GetOutput()->GetPixel(corner);
  EXPECT_EQ(air.GetRed(), air.GetBlue());
}

TEST(SlicePreview, EveryLabelHasAColour) {
  EXPECT_NE(label_preview_colour(kLabelSoftTissue), label_preview_colour(kLabelMucosa));
  EXPECT_NE(label_preview_colour(kLabelCancellousBone), label_preview_colour(kLabelCorticalBone));
  EXPECT_NE(label_preview_colour(70), label_preview_colour(71));
}

}  // namespace
}  // namespace tsf::segment
