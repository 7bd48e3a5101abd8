// NRRD volumes read by the core itself, without ITK: the CT samples (int16 HU) and the tissue
// volumes that `tsf segment` writes (docs/segment.md):
//   PREFIX-density.nrrd   float32 in [0,1]; iso-level 0.5 is the tissue surface
//   PREFIX-labels.nrrd    uint8 TissueLabel per voxel
//   PREFIX-weights.nrrd   4 × uint8 per voxel (a leading vector axis), blend weights
// so that a build with the ITK module off (the GPU machine's, scripts/gpu-check.sh) simulates,
// benchmarks and tests the segmented cranium. Encodings raw and gzip (inflate.h); any scalar type
// of 1–8 bytes, either endianness; attached data or a single detached `data file`.
//
// Geometry (docs/design.md, "Frames"), as ITK's NRRD reader gives it, so the ITK and the ITK-free
// builds build the same tissue from the same file: with `space directions`, the spacing of axis a
// is the length of its direction vector and the direction matrix's column a that vector over its
// length; `space origin` is the position of voxel (0,0,0); a right-anterior-superior (or
// left-anterior-superior) space is turned into LPS by negating the axes that differ. Without a
// `space`, `spacings` give the spacing and the axes are taken as L, P, S with the origin at 0
// (what the header cannot say is said by `has_space`).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "tsf/volume/voxel_volume.h"

namespace tsf::io {

enum class NrrdType {
  kInt8,
  kUInt8,
  kInt16,
  kUInt16,
  kInt32,
  kUInt32,
  kInt64,
  kUInt64,
  kFloat,
  kDouble
};
const char* to_string(NrrdType type);
std::size_t value_bytes(NrrdType type);

/// A NRRD file as read: three spatial axes, optionally one leading per-voxel (vector) axis.
struct NrrdVolume {
  VolumeGeometry geometry;  ///< dims of the spatial axes, spacing, origin, direction (LPS)
  int components = 1;       ///< values per voxel: the leading non-spatial axis, or 1
  NrrdType type = NrrdType::kFloat;
  bool has_space = false;  ///< the header named a space; otherwise the axes are taken as L, P, S
  std::vector<std::uint8_t> bytes;  ///< native-endian values, components fastest, then i, j, k

  std::size_t value_count() const { return bytes.size() / value_bytes(type); }
  /// Value `index` (components fastest) converted to double.
  double value(std::size_t index) const;
  /// Every value converted to float.
  std::vector<float> as_float() const;
};

/// Reads a NRRD file (header and data). Throws tsf::Error naming the file, the field or value,
/// and what was expected: unsupported encodings, types, spaces, detached lists, sizes that do not
/// match the data, data that does not decompress (a truncated or corrupt gzip stream).
NrrdVolume read_nrrd(const std::filesystem::path& path);

/// The tissue volume of a PREFIX-density.nrrd (any scalar type with values in [0,1]) and, when
/// they lie beside it, PREFIX-labels.nrrd and PREFIX-weights.nrrd, which must share its geometry;
/// without a labels file, voxels with density ≥ 0.5 get kLabelSoftTissue and the others
/// kLabelOutside (the rule of import::read_tissue_volume, which reads NRRD files through this).
VoxelVolume read_tissue_volume_nrrd(const std::filesystem::path& density_path);

/// True when two geometries match to file precision (dims exact, spacing and origin to 1e-4
/// relative, direction to 1e-6).
bool same_volume_geometry(const VolumeGeometry& a, const VolumeGeometry& b);

}  // namespace tsf::io
