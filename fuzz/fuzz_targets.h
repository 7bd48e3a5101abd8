// Fuzz targets: untrusted bytes in, a result or a tsf::Error out (docs/robustness.md). A crash, a
// hang, a sanitizer report or any other exception is a finding. Every reader takes a path, so
// each target writes its input to a file in a private scratch folder first.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsf::fuzz {

/// Thrown by a target whose input was accepted but whose result breaks what any correct result
/// must satisfy (a silently wrong result): a finding, like a crash.
struct WrongResult : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// How the last call of a target ended: "" when the input was accepted, else the message of the
/// tsf::Error that refused it.
const std::string& last_refusal();

/// Bytes of the volume the last call of a target produced (the decoded or imported floats; 0
/// when the input was refused): the memory bound of a campaign is 2× this + 256 MiB.
std::size_t last_output_bytes();

/// The peak resident memory a decoder process added for the last input (0: none ran): counted
/// with this process's own peak against the memory bound.
std::size_t last_decoder_peak_bytes();

using Target = void (*)(const std::uint8_t* data, std::size_t size);

/// A DICOM file: its header (read_dicom_file_info) and, for an image of at most 2^25 bytes, its
/// pixels decoded as `tsf import` decodes them (a compressed file in a decoder process, where a
/// codec's crash is an error). Accepted pixels must be finite, within what BitsStored and the
/// rescale allow, and the same when decoded twice (else WrongResult).
void dicom(const std::uint8_t* data, std::size_t size);
/// The same with the codecs inside this process (decode_dicom_frames): for libFuzzer, whose
/// coverage stops at a process boundary; its crashes are ones the decoder processes contain.
/// Reads the seeds of `dicom`.
void dicom_codec(const std::uint8_t* data, std::size_t size);
/// A volume file: the first byte picks .nrrd, .mha, .nii or .nii.gz for the rest, imported with
/// a 2^24-voxel limit; an accepted volume must be the same when imported twice.
void volume(const std::uint8_t* data, std::size_t size);
/// A mesh sequence (.tsfmesh).
void tsfmesh(const std::uint8_t* data, std::size_t size);
/// A scene file as tsf reads it (app::read_scene: every key, range and name rule).
void scene(const std::uint8_t* data, std::size_t size);
/// A haptic trajectory file as `tsf haptics --trajectory` reads it (its points, stylus, force
/// law, playback and their ranges).
void trajectory(const std::uint8_t* data, std::size_t size);
/// A YAML file as the app reads scenes and trajectories (load_yaml_file), then every mapping,
/// list and scalar through the strict accessors of YamlField.
void yaml(const std::uint8_t* data, std::size_t size);

/// The target called `name`; nullptr when there is none (or it is not built).
Target find_target(const std::string& name);
/// The names of the targets built.
std::vector<std::string> target_names();

}  // namespace tsf::fuzz
