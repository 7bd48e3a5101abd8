#include "tsf/import/hu_volume_writer.h"

#include <itkImageFileWriter.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>

#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/import/imaging_library_setup.h"
#include "tsf/import/volume_statistics.h"

namespace tsf::import {
namespace fs = std::filesystem;

namespace {

template <typename Image>
void write_image(const fs::path& path, const Image* image, bool compress, int level) {
  write_file_atomically(path, [&](const fs::path& temp) {
    auto writer = itk::ImageFileWriter<Image>::New();
    writer->SetFileName(temp.string());
    writer->SetInput(image);
    writer->SetUseCompression(compress);
    if (compress && level > 0) writer->SetCompressionLevel(level);
    try {
      writer->Update();
    } catch (const itk::ExceptionObject& e) {
      throw Error("cannot write '" + path.string() + "': " + e.GetDescription());
    }
  });
}

}  // namespace

bool is_writable_volume_path(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".nrrd" || ext == ".mha";
}

std::string write_hu_volume(const fs::path& path, const HuImage& image,
                            const HuVolumeWriteOptions& options) {
  setup_imaging_libraries();
  if (!is_writable_volume_path(path))
    throw Error("output '" + path.string() + "': expected a .nrrd or .mha file name");
  const std::size_t n = image.GetLargestPossibleRegion().GetNumberOfPixels();
  const float* values = image.GetBufferPointer();
  const VolumeStatistics stats = volume_statistics(values, n);
  if (stats.non_finite > 0)
    throw Error("refusing to write '" + path.string() + "': " + std::to_string(stats.non_finite) +
                " values are not finite");
  if (!fits_int16(stats)) {
    auto copy = HuImage::New();
    copy->Graft(&image);
    copy->SetMetaDataDictionary(itk::MetaDataDictionary());
    write_image(path, copy.GetPointer(), options.compress, options.compression_level);
    return "float32";
  }
  using ShortImage = itk::Image<std::int16_t, 3>;
  auto stored = ShortImage::New();
  stored->SetRegions(image.GetLargestPossibleRegion());
  stored->SetSpacing(image.GetSpacing());
  stored->SetOrigin(image.GetOrigin());
  stored->SetDirection(image.GetDirection());
  stored->Allocate();
  std::int16_t* out = stored->GetBufferPointer();
  const auto count = static_cast<std::int64_t>(n);
#pragma omp parallel for
  for (std::int64_t i = 0; i < count; ++i) out[i] = static_cast<std::int16_t>(values[i]);
  write_image(path, stored.GetPointer(), options.compress, options.compression_level);
  return "int16";
}

void write_json_atomically(const fs::path& path, const nlohmann::ordered_json& sidecar) {
  write_text_atomically(path, sidecar.dump(2) + "\n");
}

}  // namespace tsf::import
