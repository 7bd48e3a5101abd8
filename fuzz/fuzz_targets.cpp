#include "fuzz_targets.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include "tsf/common/error.h"
#include "tsf/io/mesh_sequence.h"
#include "yaml_field.h"
#ifdef TSF_FUZZ_IMPORT
#include "tsf/import/dicom_file_info.h"
#include "tsf/import/dicom_pixel_reader.h"
#include "tsf/import/import_volume.h"
#endif

namespace tsf::fuzz {
namespace fs = std::filesystem;
namespace {

/// `data` written to <temp>/tsf-fuzz-<pid>/input<extension>: the same path for every input of a
/// process, so a long campaign does not fill the disk.
fs::path input_file(const std::uint8_t* data, std::size_t size, const std::string& extension) {
  static const fs::path dir = [] {
    const fs::path d = fs::temp_directory_path() / ("tsf-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d;
  }();
  const fs::path file = dir / ("input" + extension);
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
  expect_result_or_error([&] { io::read_mesh_sequence(file); });
}

void yaml(const std::uint8_t* data, std::size_t size) {
  const fs::path file = input_file(data, size, ".yaml");
  expect_result_or_error([&] {
    const app::YamlField root(app::load_yaml_file(file.string()), "", file.string());
    walk(root, 0);
  });
}

#ifdef TSF_FUZZ_IMPORT
void dicom(const std::uint8_t* data, std::size_t size) {
  const fs::path file = input_file(data, size, ".dcm");
  expect_result_or_error([&] {
    const import::DicomFileInfo info = import::read_dicom_file_info(file);
    const bool image = info.kind == import::DicomObjectKind::image ||
                       info.kind == import::DicomObjectKind::localizer;
    if (image && info.decoded_bytes() <= (std::uint64_t{1} << 25)) import::decode_dicom_file(file);
  });
}

void volume(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return;
  static const char* const kExtensions[] = {".nrrd", ".mha", ".nii", ".nii.gz"};
  const fs::path file = input_file(data + 1, size - 1, kExtensions[data[0] % 4]);
  import::ImportOptions options;
  options.show_progress = false;
  options.max_voxels = std::int64_t{1} << 24;
  options.reader_threads = 1;
  expect_result_or_error([&] { import::import_volume(file, options); });
}
#endif

Target find_target(const std::string& name) {
  if (name == "tsfmesh") return tsfmesh;
  if (name == "yaml") return yaml;
#ifdef TSF_FUZZ_IMPORT
  if (name == "dicom") return dicom;
  if (name == "volume") return volume;
#endif
  return nullptr;
}

std::vector<std::string> target_names() {
#ifdef TSF_FUZZ_IMPORT
  return {"dicom", "volume", "tsfmesh", "yaml"};
#else
  return {"tsfmesh", "yaml"};
#endif
}

}  // namespace tsf::fuzz
