#include "tsf/segment/hu_volume_source.h"

#include <itkImageRegionConstIterator.h>

#include <cmath>
#include <string>

#include "tsf/common/error.h"
#include "tsf/import/import_volume.h"

namespace tsf::segment {
namespace fs = std::filesystem;

HuVolumeInput import_hu_volume(const fs::path& path, const std::string& series_uid,
                               bool show_progress) {
  if (!fs::exists(path)) throw Error("input volume '" + path.string() + "' does not exist");
  // tsf import does every check (3-D, scalar, sane header before allocating, DICOM geometry,
  // rescale, tilt and uneven spacing) and accepts DICOM folders, files and DICOMDIRs too.
  tsf::import::ImportOptions options;
  options.show_progress = show_progress;
  options.series_uid = series_uid;
  tsf::import::ImportResult imported = tsf::import::import_volume(path, options);
  HuVolumeInput in;
  in.image = imported.image;
  in.warnings = std::move(imported.report.warnings);
  in.kind = imported.report.source.kind;
  in.series_instance_uid = imported.report.series.series_instance_uid;

  itk::ImageRegionConstIterator<HuImage> it(in.image, in.image->GetLargestPossibleRegion());
  for (std::size_t v = 0; !it.IsAtEnd(); ++it, ++v)
    if (!std::isfinite(it.Get()))
      throw Error("input volume '" + path.string() + "': voxel " + std::to_string(v) +
                  " is not a finite number");
  return in;
}

HuImage::Pointer read_hu_volume(const fs::path& path, bool show_progress) {
  return import_hu_volume(path, std::string(), show_progress).image;
}

}  // namespace tsf::segment
