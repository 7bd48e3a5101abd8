#include "fuzz_targets.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include "tsf/common/error.h"
#include "tsf/io/mesh_sequence.h"
#include "yaml_field.h"
#ifdef TSF_FUZZ_SCENE
#include "scene/scene.h"
#endif
#ifdef TSF_FUZZ_IMPORT
#include "tsf/import/decoder_processes.h"
#include "tsf/import/dicom_file_info.h"
#include "tsf/import/dicom_pixel_reader.h"
#include "tsf/import/import_volume.h"
#endif

namespace tsf::fuzz {
namespace fs = std::filesystem;
namespace {

std::size_t g_output_bytes = 0;
std::size_t g_decoder_peak_bytes = 0;
std::string g_refusal;

/// <temp>/tsf-fuzz-<pid>, removed when the process that made it exits normally (a test, the
/// mutation driver, libFuzzer); a forked decoder process that exits leaves it to its parent.
struct ScratchFolder {
  pid_t owner = ::getpid();
  fs::path dir = fs::temp_directory_path() / ("tsf-fuzz-" + std::to_string(owner));
  ScratchFolder() { fs::create_directories(dir); }
  ScratchFolder(const ScratchFolder&) = delete;
  ScratchFolder& operator=(const ScratchFolder&) = delete;
  ~ScratchFolder() {
    std::error_code ec;
    if (::getpid() == owner) fs::remove_all(dir, ec);
  }
};

/// `data` written to <temp>/tsf-fuzz-<pid>/input<extension>: the same path for every input of a
/// process, so a long campaign does not fill the disk.
fs::path input_file(const std::uint8_t* data, std::size_t size, const std::string& extension) {
  static const ScratchFolder scratch;
  const fs::path file = scratch.dir / ("input" + extension);
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return file;
}

/// Runs `parse`; a tsf::Error is an expected answer to bad input.
void expect_result_or_error(const std::function<void()>& parse) {
  try {
    parse();
  } catch (const Error&) {
  }
}

/// Runs the whole of one target's work: a tsf::Error is the input's refusal (last_refusal).
void run_input(const std::function<void()>& parse) {
  g_refusal.clear();
  g_output_bytes = 0;
  g_decoder_peak_bytes = 0;
  try {
    parse();
  } catch (const Error& e) {
    g_refusal = e.what();
    if (g_refusal.empty()) g_refusal = "(empty message)";
  }
}

void walk(const app::YamlField& f, int depth) {
  if (depth > 300 || !f.defined()) return;
  const YAML::Node& n = f.node();
  if (n.IsMap()) {
    expect_result_or_error([&] { f.expect_keys({"name", "path", "stylus", "lattice"}); });
    for (const std::string& key : f.keys()) walk(f[key], depth + 1);
  } else if (n.IsSequence()) {
    expect_result_or_error([&] { f.vec3(); });
    for (std::size_t i = 0; i < f.size(); ++i) walk(f.at(i), depth + 1);
  } else {
    expect_result_or_error([&] { f.number(0, -1e6, 1e6); });
    expect_result_or_error([&] { f.integer(0, -1000, 1000); });
    expect_result_or_error([&] { f.boolean(false); });
    expect_result_or_error([&] { f.text(); });
  }
}

}  // namespace

void tsfmesh(const std::uint8_t* data, std::size_t size) {
  const fs::path file = input_file(data, size, ".tsfmesh");
  run_input([&] { io::read_mesh_sequence(file); });
}

void yaml(const std::uint8_t* data, std::size_t size) {
  const fs::path file = input_file(data, size, ".yaml");
  run_input([&] {
    const app::YamlField root(app::load_yaml_file(file.string()), "", file.string());
    walk(root, 0);
  });
}

#ifdef TSF_FUZZ_SCENE
void scene(const std::uint8_t* data, std::size_t size) {
  const fs::path file = input_file(data, size, ".yaml");
  run_input([&] { app::read_scene(file); });
}
#endif

#ifdef TSF_FUZZ_TRAJECTORY
void read_trajectory_for_fuzzing(const std::filesystem::path& file);  // trajectory_target.cpp

void trajectory(const std::uint8_t* data, std::size_t size) {
  const fs::path file = input_file(data, size, ".yaml");
  run_input([&] { read_trajectory_for_fuzzing(file); });
}
#endif

#ifdef TSF_FUZZ_IMPORT
namespace {

/// What any correct decode of `info` satisfies: finite values within the range its stored bits
/// map to through each frame's rescale (or, with a Modality LUT, within 16 bits).
void check_decoded(const import::DicomFileInfo& info, const std::vector<float>& v) {
  const std::size_t plane = static_cast<std::size_t>(info.columns) * info.rows;
  const double bits = info.bits_stored;
  const double lo = info.pixel_representation ? -std::pow(2.0, bits - 1) : 0.0;
  const double hi =
      info.pixel_representation ? std::pow(2.0, bits - 1) - 1 : std::pow(2.0, bits) - 1;
  for (int f = 0; f < info.number_of_frames; ++f) {
    const import::DicomFrameInfo& fr = info.frames.at(static_cast<std::size_t>(f));
    const double m = fr.has_rescale ? fr.rescale_slope : 1.0;
    const double b = fr.has_rescale ? fr.rescale_intercept : 0.0;
    double a = info.has_modality_lut ? 0.0 : lo * m + b,
           z = info.has_modality_lut ? 65535.0 : hi * m + b;
    if (a > z) std::swap(a, z);
    const double slack = 1e-6 * std::max(std::abs(a), std::abs(z)) + 1e-3;
    for (std::size_t i = 0; i < plane; ++i) {
      const double x = v[static_cast<std::size_t>(f) * plane + i];
      if (!std::isfinite(x) || x < a - slack || x > z + slack)
        throw WrongResult("frame " + std::to_string(f + 1) + " pixel " + std::to_string(i) +
                          " decoded to " + std::to_string(x) + ", outside [" + std::to_string(a) +
                          ", " + std::to_string(z) + "] that BitsStored " +
                          std::to_string(info.bits_stored) + " and the rescale allow (" +
                          import::dicom_uid_name(info.transfer_syntax_uid) + ")");
    }
  }
}

/// Decodes `info` as `tsf import` does: a compressed file in a decoder process (a codec's crash
/// is an error there), an uncompressed one by tsf here.
std::vector<float> decode_as_import(const import::DicomFileInfo& info) {
  const std::size_t plane = static_cast<std::size_t>(info.columns) * info.rows;
  std::vector<float> v(plane * static_cast<std::size_t>(info.number_of_frames));
  if (!info.pixel_data_encapsulated || !import::decoders_isolated()) {
    import::decode_dicom_frames(info, v.data());
    return v;
  }
  const std::vector<const import::DicomFileInfo*> files{&info};
  const auto frame_memory = [&](int, int frame) { return v.data() + plane * frame; };
  const auto note_peak = [](int, const import::DecodedFrameValues& d) {
    g_decoder_peak_bytes = std::max<std::size_t>(g_decoder_peak_bytes, d.decoder_peak_bytes);
  };
  import::decode_in_processes(files, {}, frame_memory, note_peak);
  return v;
}

/// Reads the header of the DICOM file in `data` and decodes its pixels with `decode`, checking
/// what every correct result satisfies.
void dicom_with(const std::uint8_t* data, std::size_t size,
                const std::function<std::vector<float>(const import::DicomFileInfo&)>& decode) {
  const fs::path file = input_file(data, size, ".dcm");
  run_input([&] {
    const import::DicomFileInfo info = import::read_dicom_file_info(file);
    const bool image = info.kind == import::DicomObjectKind::image ||
                       info.kind == import::DicomObjectKind::localizer;
    if (!image)
      throw Error(std::string("not decoded: ") + import::to_string(info.kind) + ": " +
                  info.skip_reason);
    if (info.decoded_bytes() > (std::uint64_t{1} << 25))
      throw Error("not decoded: more than 2^25 bytes of pixels");
    const std::vector<float> v = decode(info);
    g_output_bytes = v.size() * sizeof(float);
    check_decoded(info, v);
    if (decode(info) != v)
      throw WrongResult("two decodes of the same file differ (" +
                        import::dicom_uid_name(info.transfer_syntax_uid) + ")");
  });
}

}  // namespace

void dicom(const std::uint8_t* data, std::size_t size) {
  dicom_with(data, size, decode_as_import);
}

void dicom_codec(const std::uint8_t* data, std::size_t size) {
  dicom_with(data, size, [](const import::DicomFileInfo& info) {
    std::vector<float> v(static_cast<std::size_t>(info.columns) * info.rows *
                         static_cast<std::size_t>(info.number_of_frames));
    import::decode_dicom_frames(info, v.data());
    return v;
  });
}

void volume(const std::uint8_t* data, std::size_t size) {
  g_refusal = "empty input";
  g_output_bytes = 0;
  if (size < 1) return;
  static const char* const kExtensions[] = {".nrrd", ".mha", ".nii", ".nii.gz"};
  const fs::path file = input_file(data + 1, size - 1, kExtensions[data[0] % 4]);
  import::ImportOptions options;
  options.show_progress = false;
  options.max_voxels = std::int64_t{1} << 24;
  options.reader_threads = 1;
  run_input([&] {
    const import::ImportResult a = import::import_volume(file, options);
    const std::size_t n = a.image->GetLargestPossibleRegion().GetNumberOfPixels();
    g_output_bytes = n * sizeof(float);
    const import::ImportResult b = import::import_volume(file, options);
    if (b.image->GetLargestPossibleRegion() != a.image->GetLargestPossibleRegion() ||
        !std::equal(a.image->GetBufferPointer(), a.image->GetBufferPointer() + n,
                    b.image->GetBufferPointer()))
      throw WrongResult("two imports of the same volume file differ");
  });
}
#endif

std::size_t last_output_bytes() {
  return g_output_bytes;
}

const std::string& last_refusal() {
  return g_refusal;
}

std::size_t last_decoder_peak_bytes() {
  return g_decoder_peak_bytes;
}

Target find_target(const std::string& name) {
  if (name == "tsfmesh") return tsfmesh;
  if (name == "yaml") return yaml;
#ifdef TSF_FUZZ_SCENE
  if (name == "scene") return scene;
#endif
#ifdef TSF_FUZZ_TRAJECTORY
  if (name == "trajectory") return trajectory;
#endif
#ifdef TSF_FUZZ_IMPORT
  if (name == "dicom") return dicom;
  if (name == "dicom_codec") return dicom_codec;
  if (name == "volume") return volume;
#endif
  return nullptr;
}

std::vector<std::string> target_names() {
  std::vector<std::string> names{"tsfmesh", "yaml"};
#ifdef TSF_FUZZ_SCENE
  names.push_back("scene");
#endif
#ifdef TSF_FUZZ_TRAJECTORY
  names.push_back("trajectory");
#endif
#ifdef TSF_FUZZ_IMPORT
  names.insert(names.begin(), {"dicom", "volume"});
#endif
  return names;
}

}  // namespace tsf::fuzz
