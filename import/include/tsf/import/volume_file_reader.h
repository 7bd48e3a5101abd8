// NRRD, MetaImage and NIfTI volumes through ITK, with the header checked before any voxel
// memory is allocated: a header that claims more voxels than allowed, or more voxel bytes than
// the file can hold, is refused with the numbers.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>

#include "tsf/common/vec3.h"
#include "tsf/import/import_volume.h"

namespace tsf::import {

/// .nrrd .nhdr .mha .mhd .nii .nii.gz (case-insensitive).
bool is_volume_file_path(const std::filesystem::path& path);

struct VolumeFileHeader {
  std::string format;          ///< "nrrd", "metaimage" or "nifti"
  std::string component_type;  ///< as stored: "short", "float", ...
  int dimensions = 0;          ///< 2 or 3
  Int3 dims;
  Vec3d spacing;
  Vec3d origin;
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};  ///< row-major, columns = axes
  std::uint64_t voxel_bytes = 0;      ///< bytes of voxel data the header declares
  std::uint64_t available_bytes = 0;  ///< bytes of (possibly compressed) data on disk
  bool compressed = false;
  bool has_patient_orientation = true;  ///< NRRD: a "space" / "space directions" field exists
};

/// Reads and checks the header only. Throws tsf::Error naming the file and the field when the
/// header is unreadable, not a scalar 2-D/3-D volume, claims more than `max_voxels` voxels or
/// more data than the file holds, or has non-positive spacing or a non-orthonormal direction.
VolumeFileHeader inspect_volume_file(const std::filesystem::path& path, std::int64_t max_voxels);

/// Reads the volume (values as float, NIfTI scl_slope/scl_inter applied by ITK) and fills the
/// report's source, acquisition, output and rescale fields.
HuImage::Pointer read_volume_file(const std::filesystem::path& path, const ImportOptions& options,
                                  ImportReport& report);

}  // namespace tsf::import
