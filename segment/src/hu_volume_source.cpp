#include "tsf/segment/hu_volume_source.h"

#include <itkImageFileReader.h>
#include <itkImageIOBase.h>
#include <itkImageRegionConstIterator.h>

#include <cmath>
#include <string>

#include "tsf/common/error.h"
#include "tsf/import/itk_io_factories.h"

namespace tsf::segment {
namespace fs = std::filesystem;

HuImage::Pointer read_hu_volume(const fs::path& path) {
  if (!fs::exists(path)) throw Error("input volume '" + path.string() + "' does not exist");
  if (fs::is_directory(path))
    throw Error("input '" + path.string() +
                "' is a folder; `tsf segment` reads a HU volume file (NRRD, MHA, NIfTI). For a "
                "DICOM series run `tsf import FOLDER -o volume.nrrd` first");
  tsf::import::register_itk_io_factories();

  // Check the dimension before reading: ITK would silently read a 2-D image into a 3-D one.
  itk::ImageIOBase::Pointer io =
      itk::ImageIOFactory::CreateImageIO(path.string().c_str(), itk::IOFileModeEnum::ReadMode);
  if (!io)
    throw Error("input volume '" + path.string() +
                "' is not an image format tsf reads (expected NRRD, MetaImage .mha/.mhd or "
                "NIfTI .nii/.nii.gz)");
  try {
    io->SetFileName(path.string());
    io->ReadImageInformation();
  } catch (const itk::ExceptionObject& e) {
    throw Error("cannot read the header of '" + path.string() + "': " + e.GetDescription());
  }
  if (io->GetNumberOfDimensions() != 3)
    throw Error("input volume '" + path.string() + "' has " +
                std::to_string(io->GetNumberOfDimensions()) + " dimensions, expected 3");
  if (io->GetNumberOfComponents() != 1)
    throw Error("input volume '" + path.string() + "' has " +
                std::to_string(io->GetNumberOfComponents()) +
                " components per voxel, expected one (Hounsfield units)");

  auto reader = itk::ImageFileReader<HuImage>::New();
  reader->SetFileName(path.string());
  try {
    reader->Update();
  } catch (const itk::ExceptionObject& e) {
    throw Error("cannot read input volume '" + path.string() + "': " + e.GetDescription());
  }
  HuImage::Pointer image = reader->GetOutput();
  image->DisconnectPipeline();

  const auto& spacing = image->GetSpacing();
  for (unsigned int a = 0; a < 3; ++a)
    if (!(spacing[a] > 0.0) || !std::isfinite(spacing[a]))
      throw Error("input volume '" + path.string() + "': spacing along axis " + std::to_string(a) +
                  " is " + std::to_string(spacing[a]) + " mm, expected a positive value");
  itk::ImageRegionConstIterator<HuImage> it(image, image->GetLargestPossibleRegion());
  for (std::size_t v = 0; !it.IsAtEnd(); ++it, ++v)
    if (!std::isfinite(it.Get()))
      throw Error("input volume '" + path.string() + "': voxel " + std::to_string(v) +
                  " is not a finite number");
  return image;
}

}  // namespace tsf::segment
