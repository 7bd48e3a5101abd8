// Compressed DICOM pixel data are decoded in decoder processes (decoder_processes.h): whatever a
// codec does there (a crash, an abort, an endless loop, a hang, an allocation without end)
// becomes an error naming the file while the importing process carries on, and parallel decoding
// of damaged and valid files gives the same answer every time. The faults are injected with the
// test hook TSF_TEST_DECODER_FAULT. Runs under ASan + UBSan in CI ("Robustness").
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dicom_test_files.h"
#include "support/error_of.h"
#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/import/decoder_processes.h"
#include "tsf/import/dicom_file_info.h"
#include "tsf/import/dicom_pixel_reader.h"
#include "tsf/import/import_volume.h"

#if defined(__SANITIZE_ADDRESS__)
#define TSF_TEST_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TSF_TEST_UNDER_ASAN 1
#endif
#endif

namespace tsf::import {
namespace {
namespace fs = std::filesystem;

fs::path seed(const std::string& name) {
  return test::source_dir() / "fuzz" / "corpus" / "dicom" / name;
}

/// The fault-injection hook, set for one scope.
struct InjectedFault {
  InjectedFault(const char* fault, const char* file) {
    setenv("TSF_TEST_DECODER_FAULT", fault, 1);
    setenv("TSF_TEST_DECODER_FAULT_FILE", file, 1);
  }
  ~InjectedFault() {
    unsetenv("TSF_TEST_DECODER_FAULT");
    unsetenv("TSF_TEST_DECODER_FAULT_FILE");
  }
};

std::vector<float> decode_isolated(const DicomFileInfo& info, const DecoderProcessOptions& o = {}) {
  const std::size_t plane = static_cast<std::size_t>(info.columns) * info.rows;
  std::vector<float> v(plane * static_cast<std::size_t>(info.number_of_frames), -12345.0f);
  decode_in_processes(
      {&info}, o,
      [&](int, int frame) { return v.data() + plane * static_cast<std::size_t>(frame); },
      [](int, const DecodedFrameValues&) {});
  return v;
}

TEST(DecoderContainmentRobustness, DecoderProcessesGiveTheValuesOfADecodeInThisProcess) {
  for (const char* name : {"rle.dcm", "jpeg-lossless.dcm", "jpeg-ls.dcm", "j2k.dcm"}) {
    const DicomFileInfo info = read_dicom_file_info(seed(name));
    ASSERT_EQ(info.kind, DicomObjectKind::image) << name << ": " << info.skip_reason;
    EXPECT_EQ(decode_isolated(info), decode_dicom_file(seed(name))) << name;
  }
}

TEST(DecoderContainmentRobustness, ADecoderThatCrashesFailsItsFileAndThisProcessCarriesOn) {
  const DicomFileInfo info = read_dicom_file_info(seed("j2k.dcm"));
  for (const char* fault : {"abort", "segfault"}) {
    InjectedFault f(fault, "j2k");
    const std::string e = test::error_of([&] { decode_isolated(info); });
    EXPECT_NE(e.find("j2k.dcm"), std::string::npos) << fault << ": " << e;
    EXPECT_NE(e.find("JPEG2000"), std::string::npos) << e;
    // Under AddressSanitizer a SIGSEGV ends in ASan's report and exit; otherwise the signal.
    EXPECT_TRUE(e.find("crashed with signal") != std::string::npos ||
                e.find("exited with status") != std::string::npos)
        << e;
    EXPECT_NE(e.find("tsf itself was not affected"), std::string::npos) << e;
  }
  // The process is whole: the same file decodes once the fault is gone.
  EXPECT_EQ(decode_isolated(info), decode_dicom_file(seed("j2k.dcm")));
}

TEST(DecoderContainmentRobustness, ADecoderInAnEndlessLoopIsStoppedByItsCpuLimit) {
  const DicomFileInfo info = read_dicom_file_info(seed("jpeg-ls.dcm"));
  InjectedFault f("spin", "jpeg-ls");
  DecoderProcessOptions o;
  o.cpu_seconds = 1;
  const std::string e = test::error_of([&] { decode_isolated(info, o); });
  EXPECT_NE(e.find("jpeg-ls.dcm"), std::string::npos) << e;
  EXPECT_NE(e.find("CPU limit of 1 s"), std::string::npos) << e;
}

TEST(DecoderContainmentRobustness, ADecoderThatHangsIsStoppedByTheWatchdog) {
  const DicomFileInfo info = read_dicom_file_info(seed("rle.dcm"));
  InjectedFault f("sleep", "rle");
  DecoderProcessOptions o;
  o.stall_seconds = 1;
  const std::string e = test::error_of([&] { decode_isolated(info, o); });
  EXPECT_NE(e.find("rle.dcm"), std::string::npos) << e;
  EXPECT_NE(e.find("sent nothing and used no CPU for 1 s"), std::string::npos) << e;
}

TEST(DecoderContainmentRobustness, ADecoderThatAllocatesWithoutEndIsStoppedByItsMemoryLimit) {
#ifdef TSF_TEST_UNDER_ASAN
  GTEST_SKIP() << "not run under AddressSanitizer: its shadow memory makes the data-segment "
                  "limit meaningless, so decoder processes run without it there";
#endif
  const DicomFileInfo info = read_dicom_file_info(seed("jpeg-lossless.dcm"));
  InjectedFault f("allocate", "jpeg-lossless");
  const std::string e = test::error_of([&] { decode_isolated(info); });
  EXPECT_NE(e.find("jpeg-lossless.dcm"), std::string::npos) << e;
  EXPECT_NE(e.find("memory limit"), std::string::npos) << e;
}

void j2k_series(const fs::path& dir, int count) {
  test_files::series_of_copies(seed("j2k.dcm"), dir, count);
}

TEST(DecoderContainmentRobustness, AnImportNamesTheFileWhoseDecoderCrashed) {
  const fs::path dir = test::scratch_dir("containment-series");
  j2k_series(dir, 6);
  ImportOptions o;
  o.show_progress = false;
  o.reader_threads = 3;
  const ImportResult ok = import_volume(dir, o);
  EXPECT_EQ(ok.report.decoding.compressed_files, 6);
  EXPECT_EQ(ok.report.decoding.decoder_processes, 3);
  InjectedFault f("abort", "slice-4");
  const std::string e = test::error_of([&] { import_volume(dir, o); });
  EXPECT_NE(e.find("slice-4.dcm"), std::string::npos) << e;
  EXPECT_NE(e.find("crashed with signal 6"), std::string::npos) << e;
}

TEST(DecoderContainmentRobustness, ParallelDecodingOfDamagedAndValidFilesAnswersTheSameEveryTime) {
  const fs::path dir = test::scratch_dir("containment-damaged");
  j2k_series(dir, 8);
  // One slice's codestream loses bytes in the middle of its coded data.
  std::string bytes = test_files::file_bytes(dir / "slice-3.dcm");
  const std::size_t soc = bytes.find("\xFF\x4F\xFF\x51");
  ASSERT_NE(soc, std::string::npos);
  for (std::size_t i = 0; i < 40; ++i) bytes[bytes.size() - 200 + i] = static_cast<char>(0xFF);
  std::ofstream(dir / "slice-3.dcm", std::ios::binary) << bytes;
  ImportOptions o;
  o.show_progress = false;
  o.reader_threads = 4;
  std::string first;
  for (int run = 0; run < 10; ++run) {
    const std::string e = test::error_of([&] { import_volume(dir, o); });
    EXPECT_NE(e.find("slice-3.dcm"), std::string::npos) << e;
    if (run == 0) first = e;
    EXPECT_EQ(e, first) << "run " << run;
  }
}

}  // namespace
}  // namespace tsf::import
