// Where `tsf segment` gets its Hounsfield-unit volume from: the single place that reads input.
//
// Today it reads one image file (NRRD, MetaImage, NIfTI: the output of `tsf import`, or a HU
// volume such as data-samples/ct-head-cranium/cranium.nrrd) with ITK. Swapping this body for
// tsf::import::import_volume() makes `tsf segment` accept DICOM series folders too.
#pragma once

#include <filesystem>

#include "tsf/segment/segment_image_types.h"

namespace tsf::segment {

/// Reads `path` as a 3-D HU volume (any scalar pixel type, converted to float). Throws tsf::Error
/// naming the path when it is missing, a folder (a DICOM series: run `tsf import` first), not a
/// readable image, not 3-D, or holds non-finite values.
HuImage::Pointer read_hu_volume(const std::filesystem::path& path);

}  // namespace tsf::segment
