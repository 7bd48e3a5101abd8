// The DICOM pixel path facing data that lie: compressed frames whose own header disagrees with
// the DICOM header are refused before decoding, naming both values; the JPEG decoders' chatter
// is kept off the terminal without touching file descriptor 2 (sanitizer reports go there).
// Runs under ASan + UBSan in CI ("Robustness").
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "dicom_test_files.h"
#include "support/error_of.h"
#include "support/gdcm_transcode.h"
#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/import/dicom_pixel_reader.h"
#include "tsf/import/import_volume.h"

namespace tsf::import {
namespace {
namespace fs = std::filesystem;

/// Runs `f` with file descriptor 2 sent to a file; what reached it.
std::string fd2_output_of(const std::function<void()>& f, const fs::path& file) {
  std::fflush(stderr);
  const int saved = ::dup(2);
  FILE* capture = std::fopen(file.c_str(), "w+");
  if (saved < 0 || !capture) return "(cannot capture fd 2)";
  ::dup2(::fileno(capture), 2);
  f();
  std::fflush(stderr);
  ::dup2(saved, 2);
  ::close(saved);
  std::fclose(capture);
  return test_files::file_bytes(file);
}

TEST(DecoderRobustness, JpegChatterIsSilencedButFileDescriptorTwoStaysOpen) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path dir = data / "dicom" / "ct-chest-slice-transfer-syntaxes-cornerstone";
  const fs::path scratch = test::scratch_dir("jpeg-stderr");
  const std::string out = fd2_output_of(
      [&] {
        // 12-bit JPEG: GDCM's 8-bit libjpeg complains before the 12-bit one decodes it.
        for (const char* name : {"JPEGProcess2_4TransferSyntax_1.2.840.10008.1.2.4.51",
                                 "JPEGProcess14SV1TransferSyntax_1.2.840.10008.1.2.4.70"}) {
          const std::vector<float> v =
              decode_dicom_file(dir / (std::string("CTImage.dcm_") + name + ".dcm"));
          EXPECT_FALSE(v.empty()) << name;
          // What is written to fd 2 (as a sanitizer report is) reaches it.
          const std::string marker = std::string("fd2-still-open ") + name + "\n";
          EXPECT_EQ(::write(2, marker.data(), marker.size()), static_cast<ssize_t>(marker.size()));
        }
      },
      scratch / "fd2.txt");
  EXPECT_EQ(out.find("Unsupported JPEG"), std::string::npos) << out;
  EXPECT_NE(out.find("fd2-still-open JPEGProcess2_4"), std::string::npos) << out;
  EXPECT_NE(out.find("fd2-still-open JPEGProcess14SV1"), std::string::npos) << out;
}

/// A slice of the GE sample (the first by default) transcoded by GDCM into `syntax`.
fs::path transcoded(const fs::path& dir, const char* name, gdcm::TransferSyntax::TSType syntax,
                    const char* slice = "01.dcm") {
  const fs::path source = test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing" / slice;
  const fs::path target = dir / (std::string(name) + ".dcm");
  EXPECT_TRUE(test::transcode(source, target, syntax)) << name;
  return target;
}

/// The error of decoding `path` ("" when it decoded).
std::string decode_error(const fs::path& path) {
  return test::error_of([&] { decode_dicom_file(path); });
}

TEST(DecoderRobustness, ACompressedFrameDisagreeingWithTheHeaderIsRefusedBeforeDecoding) {
  const fs::path dir = test::scratch_dir("frame-headers");
  const fs::path native = test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing" / "01.dcm";
  const std::vector<float> reference = decode_dicom_file(native);
  struct Codec {
    const char* name;
    gdcm::TransferSyntax::TSType syntax;
    const char* marker;
  };
  const Codec codecs[] = {
      {"jpeg-lossless", gdcm::TransferSyntax::JPEGLosslessProcess14_1, "the JPEG SOF says"},
      {"jpeg-ls", gdcm::TransferSyntax::JPEGLSLossless, "the JPEG-LS SOF55 says"},
      {"j2k", gdcm::TransferSyntax::JPEG2000Lossless, "the JPEG 2000 SIZ says"},
      {"rle", gdcm::TransferSyntax::RLELossless, "RLE"},
  };
  for (const Codec& c : codecs) {
    const fs::path good = transcoded(dir, c.name, c.syntax);
    // Lossless: the transcoded slice decodes to the native values.
    ASSERT_EQ(decode_error(good), "") << c.name;
    EXPECT_EQ(decode_dicom_file(good), reference) << c.name;

    const bool rle = std::string(c.name) == "rle";
    // A copy of `good` edited by `change` is refused naming the copy and saying `expected`.
    const auto expect_refused = [&](const char* suffix,
                                    const std::function<void(DcmDataset&)>& change,
                                    const std::string& expected) {
      const fs::path copy = dir / (std::string(c.name) + suffix);
      test_files::copy_with_changes(good, copy, change);
      const std::string e = decode_error(copy);
      EXPECT_NE(e.find(copy.filename().string()), std::string::npos) << e;
      EXPECT_NE(e.find(expected), std::string::npos) << c.name << ": " << e;
    };
    expect_refused(
        "-columns.dcm",
        [&](DcmDataset& ds) {
          // RLE carries no size: a header claiming far more rows than its segments can hold.
          ds.putAndInsertUint16(rle ? DCM_Rows : DCM_Columns, rle ? 60000 : 256);
        },
        rle ? "too few for the 512×60000 pixels of the DICOM header"
            : std::string(c.marker) + " 512×512 pixels, the DICOM header (Columns×Rows) 256×512");
    expect_refused(
        "-bits.dcm",
        [](DcmDataset& ds) {
          ds.putAndInsertUint16(DCM_BitsAllocated, 32);
          ds.putAndInsertUint16(DCM_BitsStored, 32);
          ds.putAndInsertUint16(DCM_HighBit, 31);
        },
        rle ? "the RLE header has 2 segments, the DICOM header 1 SamplesPerPixel × 32 "
              "BitsAllocated needs 4"
            : "BitsAllocated is 32");
    expect_refused(
        "-frames.dcm", [](DcmDataset& ds) { ds.putAndInsertString(DCM_NumberOfFrames, "3"); },
        rle ? "RLELossless puts each frame in one fragment: the pixel data hold 1 fragments for "
              "NumberOfFrames 3"
            : "the pixel data hold 1 fragments, fewer than the NumberOfFrames 3");
  }
}

TEST(DecoderRobustness, AJpegClaimingMorePixelsThanItsBytesCanHoldIsRefusedBeforeAllocating) {
  const fs::path dir = test::scratch_dir("jpeg-claims");
  const fs::path good =
      transcoded(dir, "jpeg-lossless", gdcm::TransferSyntax::JPEGLosslessProcess14_1);
  // Header and SOF agree on 20000×20000 (400 M samples) in about 200 kB: lossless JPEG needs a
  // bit per sample, so the file cannot hold them.
  const fs::path big = dir / "claims-20000.dcm";
  test_files::copy_with_changes(good, big, [](DcmDataset& ds) {
    ds.putAndInsertUint16(DCM_Rows, 20000);
    ds.putAndInsertUint16(DCM_Columns, 20000);
  });
  std::string bytes = test_files::file_bytes(big);
  const std::size_t sof = bytes.find("\xFF\xC3");
  ASSERT_NE(sof, std::string::npos);
  for (std::size_t at : {sof + 5, sof + 7}) {  // Y, X: big-endian 20000
    bytes[at] = static_cast<char>(20000 >> 8);
    bytes[at + 1] = static_cast<char>(20000 & 0xff);
  }
  std::ofstream(big, std::ios::binary) << bytes;
  const std::string e = decode_error(big);
  EXPECT_NE(e.find("too few for the 20000×20000×1 pixels of the DICOM header (at most 8 samples "
                   "per byte"),
            std::string::npos)
      << e;
}

TEST(DecoderRobustness, ACorruptJ2kSliceBesideValidOnesFailsTheSameWayOnEveryThreadCount) {
  // A corrupt JPEG 2000 slice decoded beside valid ones on four threads crashed now and then
  // (GDCM wrote past its buffer): it is refused before any decoder runs, on every run.
  const fs::path dir = test::scratch_dir("j2k-parallel") / "series";
  fs::create_directories(dir);
  for (const char* slice : {"01.dcm", "02.dcm", "04.dcm", "05.dcm"})
    transcoded(dir, slice, gdcm::TransferSyntax::JPEG2000Lossless, slice);
  const fs::path good =
      transcoded(dir.parent_path(), "03", gdcm::TransferSyntax::JPEG2000Lossless, "03.dcm");
  test_files::copy_with_changes(good, dir / "03.dcm.dcm",
                                [](DcmDataset& ds) { ds.putAndInsertUint16(DCM_Columns, 480); });
  for (const int threads : {1, 4, 4, 4, 4}) {
    ImportOptions options;
    options.show_progress = false;
    options.reader_threads = threads;
    const std::string e = test::error_of([&] { import_volume(dir, options); });
    EXPECT_NE(e.find("03.dcm.dcm (compressed pixel data disagree with the header: frame 1: the "
                     "JPEG 2000 SIZ says 512×512 pixels, the DICOM header (Columns×Rows) 480×512)"),
              std::string::npos)
        << threads << " threads: " << e;
  }
}

TEST(DecoderRobustness, AJ2kClaimingFarMorePixelsThanItsBytesIsRefusedBeforeAllocating) {
  // 22000×22000 declared by both headers in about 190 kB: 5000:1 where a CT compresses at most
  // about 15:1. JPEG 2000 has no hard bound (a blank frame compresses ~3000:1), so the ratio
  // bound applies above 64 MiB of decoded pixels.
  const fs::path dir = test::scratch_dir("j2k-claims");
  const fs::path good = transcoded(dir, "j2k", gdcm::TransferSyntax::JPEG2000Lossless);
  const fs::path big = dir / "claims-22000.dcm";
  test_files::copy_with_changes(good, big, [](DcmDataset& ds) {
    ds.putAndInsertUint16(DCM_Rows, 22000);
    ds.putAndInsertUint16(DCM_Columns, 22000);
  });
  std::string bytes = test_files::file_bytes(big);
  const std::size_t siz = bytes.find("\xFF\x4F\xFF\x51");
  ASSERT_NE(siz, std::string::npos);
  for (std::size_t at : {siz + 8, siz + 12}) {  // Xsiz, Ysiz: big-endian 22000
    bytes[at] = 0;
    bytes[at + 1] = 0;
    bytes[at + 2] = static_cast<char>(22000 >> 8);
    bytes[at + 3] = static_cast<char>(22000 & 0xff);
  }
  std::ofstream(big, std::ios::binary) << bytes;
  const std::string e = decode_error(big);
  EXPECT_NE(e.find("the 22000×22000×1 pixels of the DICOM header are 968000000 bytes of pixels "
                   "from"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("refused before allocating"), std::string::npos) << e;
}

/// A copy of `good` whose codestream (starting at the first `start` marker) `edit` changes in
/// place; the error of decoding it.
std::string damaged_error(const fs::path& good, const fs::path& copy, const std::string& start,
                          const std::function<void(std::string&, std::size_t)>& edit) {
  std::string bytes = test_files::file_bytes(good);
  const std::size_t at = bytes.find(start);
  EXPECT_NE(at, std::string::npos) << good;
  if (at == std::string::npos) return "";
  edit(bytes, at);
  std::ofstream(copy, std::ios::binary) << bytes;
  return decode_error(copy);
}

/// The offset of the last `marker` in `bytes`.
std::size_t last(const std::string& bytes, const char* marker) {
  return bytes.rfind(marker);
}

TEST(DecoderRobustness, DamageInsideACompressedFrameIsRefusedWhereItsStructureShowsIt) {
  const fs::path dir = test::scratch_dir("codestream-damage");
  struct Damage {
    const char* codec;
    gdcm::TransferSyntax::TSType syntax;
    const char* start;
    const char* name;
    std::function<void(std::string&, std::size_t)> edit;
    const char* expected;
  };
  const std::string soc("\xFF\x4F\xFF\x51", 4), soi("\xFF\xD8", 2);
  const Damage damages[] = {
      {"j2k", gdcm::TransferSyntax::JPEG2000Lossless, soc.c_str(), "no-eoc",
       [](std::string& b, std::size_t) { b[last(b, "\xFF\xD9") + 1] = 0; },
       "does not end with an EOC marker"},
      {"j2k", gdcm::TransferSyntax::JPEG2000Lossless, soc.c_str(), "psot",
       [](std::string& b, std::size_t at) {
         const std::size_t sot = b.find("\xFF\x90", at);
         b[sot + 7] = static_cast<char>(b[sot + 7] + 1);  // Psot grows by 65536
       },
       "bytes (Psot), the codestream holds"},
      {"j2k", gdcm::TransferSyntax::JPEG2000Lossless, soc.c_str(), "tile",
       [](std::string& b, std::size_t at) { b[b.find("\xFF\x90", at) + 5] = 7; },
       "the image has only 1 tiles"},
      {"j2k", gdcm::TransferSyntax::JPEG2000Lossless, soc.c_str(), "marker-in-data",
       [](std::string& b, std::size_t) {
         const std::size_t eoc = last(b, "\xFF\xD9");
         b[eoc - 40] = static_cast<char>(0xFF);
         b[eoc - 39] = static_cast<char>(0xA5);
       },
       "marker code 0xFFA5 inside the coded data"},
      {"jpeg-lossless", gdcm::TransferSyntax::JPEGLosslessProcess14_1, soi.c_str(), "no-eoi",
       [](std::string& b, std::size_t) { b[last(b, "\xFF\xD9") + 1] = 0; }, "EOI"},
      {"jpeg-lossless", gdcm::TransferSyntax::JPEGLosslessProcess14_1, soi.c_str(), "stray-rst",
       [](std::string& b, std::size_t) {
         const std::size_t eoi = last(b, "\xFF\xD9");
         b[eoi - 100] = static_cast<char>(0xFF);
         b[eoi - 99] = static_cast<char>(0xD3);
       },
       "restart marker RST3 where RST0 is due"},
      {"jpeg-ls", gdcm::TransferSyntax::JPEGLSLossless, soi.c_str(), "no-eoi",
       [](std::string& b, std::size_t) { b[last(b, "\xFF\xD9") + 1] = 0; }, "EOI"},
      {"rle", gdcm::TransferSyntax::RLELossless, "\xFE\xFF\x00\xE0", "short-run",
       [](std::string& b, std::size_t) {
         // The first control byte of segment 1 (after the frame's item tag, length and the
         // 64-byte RLE header) now copies one literal byte fewer or more.
         const std::size_t first = b.rfind(std::string("\xFE\xFF\x00\xE0", 4)) + 8 + 64;
         b[first] = static_cast<char>(static_cast<unsigned char>(b[first]) ^ 0x01);
       },
       "RLE segment 1"},
  };
  for (const Damage& d : damages) {
    const fs::path good = transcoded(dir, d.codec, d.syntax);
    ASSERT_EQ(decode_error(good), "") << d.codec;
    const fs::path copy = dir / (std::string(d.codec) + "-" + d.name + ".dcm");
    const std::string e = damaged_error(good, copy, d.start, d.edit);
    EXPECT_NE(e.find(copy.filename().string()), std::string::npos) << e;
    EXPECT_NE(e.find(d.expected), std::string::npos) << d.codec << " " << d.name << ": " << e;
  }
}

TEST(DecoderRobustness, ADecoderWarningOfDamagedDataRefusesTheFile) {
  // Bytes of a lossless JPEG's coded data overwritten: libjpeg decodes, warns "Corrupt JPEG
  // data: N extraneous bytes before marker 0xd9" and returns wrong pixels; the warning refuses.
  const fs::path dir = test::scratch_dir("decoder-warning");
  const fs::path good =
      transcoded(dir, "jpeg-lossless", gdcm::TransferSyntax::JPEGLosslessProcess14_1);
  const std::string e = damaged_error(good, dir / "jpeg-lossless-extra.dcm", "\xFF\xD8",
                                      [](std::string& b, std::size_t) {
                                        // A copy of the last bytes before EOI, shifted by three.
                                        const std::size_t eoi = last(b, "\xFF\xD9");
                                        for (std::size_t i = 1; i <= 3; ++i)
                                          b[eoi - i] = static_cast<char>(0x5A);
                                      });
  EXPECT_NE(e.find("jpeg-lossless-extra.dcm"), std::string::npos) << e;
  EXPECT_TRUE(e.find("the decoder reported damaged data") != std::string::npos ||
              e.find("cannot decode") != std::string::npos)
      << e;
}

}  // namespace
}  // namespace tsf::import
