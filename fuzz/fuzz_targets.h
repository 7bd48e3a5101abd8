// Fuzz targets: untrusted bytes in, a result or a tsf::Error out (docs/robustness.md). A crash, a
// hang, a sanitizer report or any other exception is a finding. Every reader takes a path, so
// each target writes its input to a file in a private scratch folder first.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace tsf::fuzz {

using Target = void (*)(const std::uint8_t* data, std::size_t size);

/// A DICOM file: its header (read_dicom_file_info) and, for an image of at most 2^24 samples,
/// its pixels (decode_dicom_file).
void dicom(const std::uint8_t* data, std::size_t size);
/// A volume file: the first byte picks .nrrd, .mha, .nii or .nii.gz for the rest, imported with
/// a 2^24-voxel limit.
void volume(const std::uint8_t* data, std::size_t size);
/// A mesh sequence (.tsfmesh).
void tsfmesh(const std::uint8_t* data, std::size_t size);
/// A YAML file as the app reads scenes and trajectories (load_yaml_file), then every mapping,
/// list and scalar through the strict accessors of YamlField.
void yaml(const std::uint8_t* data, std::size_t size);

/// The target called `name`; nullptr when there is none (or it is not built).
Target find_target(const std::string& name);
/// The names of the targets built.
std::vector<std::string> target_names();

}  // namespace tsf::fuzz
