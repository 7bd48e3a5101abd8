// Writing a HU volume (.nrrd or .mha) and its JSON sidecar, each atomically (temporary file, then
// rename: a failed write leaves nothing half-written).
//
// Stored pixel type: int16 when every value is a whole number in [-32768, 32767] (CT HU always
// are, and resampled CT is rounded to whole HU by import_volume), else float32. The file carries
// geometry only: no DICOM attributes, so nothing identifying reaches it.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "tsf/import/import_volume.h"

namespace tsf::import {

struct HuVolumeWriteOptions {
  bool compress = true;  ///< gzip (NRRD) / zlib (MetaImage) voxel data
  /// zlib level 1..9; 0 = ITK's default (fast). On the samples level 9 writes files 4 % smaller
  /// in 7-10× the time, so the default is kept.
  int compression_level = 0;
};

/// True for .nrrd and .mha (single-file formats; detached headers are not written).
bool is_writable_volume_path(const std::filesystem::path& path);

/// Writes `image`; returns the stored pixel type ("int16" or "float32"). Throws tsf::Error
/// naming the path.
std::string write_hu_volume(const std::filesystem::path& path, const HuImage& image,
                            const HuVolumeWriteOptions& options = {});

/// Writes `sidecar` as indented JSON.
void write_json_atomically(const std::filesystem::path& path,
                           const nlohmann::ordered_json& sidecar);

}  // namespace tsf::import
