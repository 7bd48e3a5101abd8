// What damage inside compressed pixel data tsf detects, per codec (docs/robustness.md, "Damage
// inside compressed data"): the GE sample's first slice is encoded by GDCM in each lossless
// codec, then, trial after trial, bytes of its coded data (after the codestream's headers) are
// replaced by random values and the copy is decoded as `tsf import` decodes it (in a decoder
// process). Each trial ends one way:
//   structure    refused by tsf's codestream check before decoding
//   decoder      refused by the decoder (an error, a warning of damaged data, or a crash or
//                limit of its process, contained)
//   same pixels  decoded to the original values (the bytes changed did not matter)
//   wrong pixels decoded without a word to other values: damage no check can see
//
// Usage: bench_compressed_damage [--trials N] [--bytes K] [--seed S]
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "support/gdcm_transcode.h"
#include "tsf/common/error.h"
#include "tsf/import/decoder_processes.h"
#include "tsf/import/dicom_file_info.h"
#include "tsf/import/dicom_pixel_reader.h"
#include "tsf/import/imaging_library_setup.h"

namespace fs = std::filesystem;
using namespace tsf::import;

namespace {

std::string bytes_of(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Where the coded data of the frame start and end in the file's bytes.
bool coded_data(const std::string& b, const std::string& codec, std::size_t& begin,
                std::size_t& end) {
  if (codec == "rle") {
    begin = b.rfind(std::string("\xFE\xFF\x00\xE0", 4));  // the frame's item
    if (begin == std::string::npos) return false;
    begin += 8 + 64;
    end = b.size() - 8;  // the sequence delimiter
    return true;
  }
  const std::string start =
      codec == "j2k" ? std::string("\xFF\x93", 2) : std::string("\xFF\xDA", 2);
  begin = b.find(start);
  if (begin == std::string::npos) return false;
  begin += codec == "j2k" ? 2
                          : 2 + ((static_cast<unsigned char>(b[begin + 2]) << 8) |
                                 static_cast<unsigned char>(b[begin + 3]));
  end = b.rfind(codec == "j2k" ? std::string("\xFF\xD9", 2) : std::string("\xFF\xD9", 2));
  return end != std::string::npos && end > begin;
}

}  // namespace

int main(int argc, char** argv) {
  int trials = 200, changed = 1;
  unsigned seed = 1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--trials")
      trials = std::atoi(argv[i + 1]);
    else if (a == "--bytes")
      changed = std::atoi(argv[i + 1]);
    else if (a == "--seed")
      seed = static_cast<unsigned>(std::atoi(argv[i + 1]));
  }
  setup_imaging_libraries();
  const fs::path source =
      fs::path(TSF_SOURCE_DIR) / "data-samples" / "ct-head-ge-hispeed-tilt-varspacing" / "01.dcm";
  const fs::path dir = fs::temp_directory_path() / "tsf-bench-compressed-damage";
  fs::create_directories(dir);
  struct Codec {
    const char* name;
    const char* label;
    gdcm::TransferSyntax::TSType syntax;
  };
  const Codec codecs[] = {
      {"rle", "RLE Lossless", gdcm::TransferSyntax::RLELossless},
      {"jpeg", "JPEG Lossless SV1 (.70)", gdcm::TransferSyntax::JPEGLosslessProcess14_1},
      {"jpeg-ls", "JPEG-LS Lossless", gdcm::TransferSyntax::JPEGLSLossless},
      {"j2k", "JPEG 2000 Lossless", gdcm::TransferSyntax::JPEG2000Lossless},
  };
  std::printf(
      "%d trials per codec, %d random byte(s) of the coded data replaced per trial (seed %u)\n\n",
      trials, changed, seed);
  std::printf("| codec | coded bytes | structure | decoder | same pixels | wrong pixels |\n");
  std::printf("|---|---|---|---|---|---|\n");
  std::mt19937 rng(seed);
  for (const Codec& c : codecs) {
    const fs::path good = dir / (std::string(c.name) + ".dcm");
    if (!tsf::test::transcode(source, good, c.syntax)) {
      std::printf("| %s | cannot encode | | | | |\n", c.label);
      continue;
    }
    const std::vector<float> reference = decode_dicom_file(good);
    const std::string original = bytes_of(good);
    std::size_t begin = 0, end = 0;
    if (!coded_data(original, c.name, begin, end)) {
      std::printf("| %s | coded data not found | | | | |\n", c.label);
      continue;
    }
    int structure = 0, decoder = 0, same = 0, wrong = 0;
    const fs::path copy = dir / (std::string(c.name) + "-damaged.dcm");
    for (int t = 0; t < trials; ++t) {
      std::string b = original;
      for (int k = 0; k < changed; ++k)
        b[begin + rng() % (end - begin)] = static_cast<char>(rng() & 0xFF);
      std::ofstream(copy, std::ios::binary) << b;
      const DicomFileInfo info = read_dicom_file_info(copy);
      if (info.kind != DicomObjectKind::image) {
        ++structure;  // refused by the header pass
        continue;
      }
      std::vector<float> v(reference.size());
      try {
        DecoderProcessOptions o;
        decode_in_processes(
            {&info}, o, [&](int, int) { return v.data(); }, [](int, const DecodedFrameValues&) {});
        ++(v == reference ? same : wrong);
      } catch (const tsf::Error& e) {
        ++(std::string(e.what()).find("is damaged:") != std::string::npos ? structure : decoder);
      }
    }
    std::printf("| %s | %zu | %d | %d | %d | %d |\n", c.label, end - begin, structure, decoder,
                same, wrong);
  }
  fs::remove_all(dir);
  return 0;
}
