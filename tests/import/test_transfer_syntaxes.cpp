// Every transfer syntax GDCM decodes, through tsf's DICOM pixel path (GDCM + tsf's rescale):
// lossless encodings must decode to exactly the uncompressed values, lossy ones within a stated
// tolerance; 12-bit stored pixels must be masked and sign-extended as the reference says.
#include <gtest/gtest.h>
#include <itkImage.h>
#include <itkImageFileReader.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/import/dicom_pixel_reader.h"
#include "tsf/import/imaging_library_setup.h"

namespace tsf::import {
namespace {
namespace fs = std::filesystem;

struct Difference {
  double max_abs = 0, rms = 0;
  std::size_t differing = 0;
};

Difference compare(const std::vector<float>& a, const std::vector<float>& b) {
  Difference d;
  EXPECT_EQ(a.size(), b.size());
  double sum2 = 0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    const double e = static_cast<double>(a[i]) - static_cast<double>(b[i]);
    d.max_abs = std::max(d.max_abs, std::abs(e));
    sum2 += e * e;
    d.differing += e != 0;
  }
  d.rms = std::sqrt(sum2 / static_cast<double>(std::max<std::size_t>(a.size(), 1)));
  return d;
}

TEST(TransferSyntaxes, ChestCtLosslessVariantsArePixelIdentical) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path dir = data / "dicom" / "ct-chest-slice-transfer-syntaxes-cornerstone";
  const std::vector<float> reference = decode_dicom_file(dir / "CTImage.dcm");
  const char* lossless[] = {
      "LittleEndianImplicitTransferSyntax_1.2.840.10008.1.2",
      "LittleEndianExplicitTransferSyntax_1.2.840.10008.1.2.1",
      "BigEndianExplicitTransferSyntax_1.2.840.10008.1.2.2",
      "DeflatedExplicitVRLittleEndianTransferSyntax_1.2.840.10008.1.2.1.99",
      "JPEGProcess14TransferSyntax_1.2.840.10008.1.2.4.57",
      "JPEGProcess14SV1TransferSyntax_1.2.840.10008.1.2.4.70",
      "JPEGLSLosslessTransferSyntax_1.2.840.10008.1.2.4.80",
      "JPEG2000LosslessOnlyTransferSyntax_1.2.840.10008.1.2.4.90",
      "RLELosslessTransferSyntax_1.2.840.10008.1.2.5",
  };
  for (const char* name : lossless) {
    const std::vector<float> v =
        decode_dicom_file(dir / (std::string("CTImage.dcm_") + name + ".dcm"));
    const Difference d = compare(v, reference);
    EXPECT_EQ(d.differing, 0u) << name << ": max |difference| " << d.max_abs << " HU";
  }
  const auto [lo, hi] = std::minmax_element(reference.begin(), reference.end());
  EXPECT_LE(*lo, -1000.0f) << "air (and the -3024 outside the field of view) after rescale";
  EXPECT_GT(*hi, 700.0f) << "bone";
}

TEST(TransferSyntaxes, ChestCtLossyVariantsStayWithinTheirTolerance) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path dir = data / "dicom" / "ct-chest-slice-transfer-syntaxes-cornerstone";
  const std::vector<float> reference = decode_dicom_file(dir / "CTImage.dcm");
  // Tolerances in HU (RMS over the slice, and the largest single error). The 12-bit JPEGs were
  // made with slope 2.0002 (one stored step = 2 HU), the 8-bit baseline one with slope 32.12
  // (one step = 32 HU: quantisation alone is ~9 HU RMS, DCT ringing at bone edges adds more).
  // JPEG-LS near-lossless guarantees |error| <= NEAR (1 here); lossy JPEG 2000 was encoded at a
  // high rate. Measured on this data: 22.7/64, 5.2/36 (x3), 0.83/1, 0.89/5.
  struct Lossy {
    const char* name;
    double rms_tolerance_hu, max_tolerance_hu, stored_step_hu;
  };
  const Lossy lossy[] = {
      {"JPEGProcess1TransferSyntax_1.2.840.10008.1.2.4.50", 30.0, 100.0, 32.12},
      {"JPEGProcess2_4TransferSyntax_1.2.840.10008.1.2.4.51", 8.0, 50.0, 2.0},
      {"JPEGProcess6_8TransferSyntax_1.2.840.10008.1.2.4.53", 8.0, 50.0, 2.0},
      {"JPEGProcess10_12TransferSyntax_1.2.840.10008.1.2.4.55", 8.0, 50.0, 2.0},
      {"JPEGLSLossyTransferSyntax_1.2.840.10008.1.2.4.81", 1.0, 1.0, 1.0},
      {"JPEG2000TransferSyntax_1.2.840.10008.1.2.4.91", 2.0, 10.0, 1.0},
  };
  for (const auto& l : lossy) {
    const std::vector<float> v =
        decode_dicom_file(dir / (std::string("CTImage.dcm_") + l.name + ".dcm"));
    const Difference d = compare(v, reference);
    EXPECT_LE(d.rms, l.rms_tolerance_hu) << l.name;
    EXPECT_LE(d.max_abs, l.max_tolerance_hu) << l.name;
    EXPECT_GT(d.differing, 0u) << l.name << " is lossy: some values must differ";
    // A wrong rescale or sign would shift the whole slice: the mean error stays near zero.
    double mean = 0;
    for (std::size_t i = 0; i < v.size(); ++i)
      mean += static_cast<double>(v[i]) - static_cast<double>(reference[i]);
    mean /= static_cast<double>(v.size());
    EXPECT_LT(std::abs(mean), l.stored_step_hu) << l.name;
  }
}

TEST(TransferSyntaxes, EnhancedMrVariantsArePixelIdenticalAndTruncatedOneFails) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path dir = data / "dicom" / "pydicom-data-selected";
  DicomFileInfo info;
  const std::vector<float> reference = decode_dicom_file(dir / "emri_small.dcm", &info);
  EXPECT_EQ(info.number_of_frames, 10);
  for (const char* name : {"emri_small_RLE.dcm", "emri_small_big_endian.dcm",
                           "emri_small_jpeg_2k_lossless.dcm", "emri_small_jpeg_ls_lossless.dcm"}) {
    const Difference d = compare(decode_dicom_file(dir / name), reference);
    EXPECT_EQ(d.differing, 0u) << name << ": max " << d.max_abs;
  }
  try {
    decode_dicom_file(dir / "emri_small_jpeg_2k_lossless_too_short.dcm");
    FAIL() << "a truncated JPEG 2000 stream decoded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("emri_small_jpeg_2k_lossless_too_short.dcm"),
              std::string::npos)
        << e.what();
  }
}

TEST(TransferSyntaxes, JpegLosslessAndJpeg2000RegressionFilesMatchUncompressed) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path dir = data / "dicom" / "pydicom-data-selected";
  // NEMA WG04 MR: uncompressed vs JPEG 2000 lossless, slope 3.77 applied to both.
  EXPECT_EQ(
      compare(decode_dicom_file(dir / "MR2_J2KR.dcm"), decode_dicom_file(dir / "MR2_UNCR.dcm"))
          .differing,
      0u);
  // pydicom issue 693 (BitsStored 14 in the header, 16 in the JPEG 2000 stream).
  const Difference d =
      compare(decode_dicom_file(dir / "693_J2KR.dcm"), decode_dicom_file(dir / "693_UNCR.dcm"));
  EXPECT_EQ(d.differing, 0u) << "max " << d.max_abs;
}

/// A Siemens mosaic (tiles of tile×tile pixels, row-major) against the NIfTI reference that
/// dcm2niix made from it (one tile per slice). dcm2niix may flip rows; either way every value
/// must match.
void expect_mosaic_matches_nifti(const fs::path& dicom, const fs::path& nifti) {
  setup_imaging_libraries();
  DicomFileInfo info;
  const std::vector<float> mosaic = decode_dicom_file(dicom, &info);
  using Image = itk::Image<float, 3>;
  auto reader = itk::ImageFileReader<Image>::New();
  reader->SetFileName(nifti.string());
  reader->Update();
  const Image* ref = reader->GetOutput();
  const auto size = ref->GetLargestPossibleRegion().GetSize();
  const int tile = static_cast<int>(size[0]);
  const int per_row = info.columns / tile;
  ASSERT_EQ(static_cast<int>(size[1]), tile);
  ASSERT_GT(per_row, 0);
  for (bool flip : {false, true}) {
    std::size_t mismatches = 0;
    for (int k = 0; k < static_cast<int>(size[2]); ++k)
      for (int y = 0; y < tile; ++y)
        for (int x = 0; x < tile; ++x) {
          const int row = (k / per_row) * tile + (flip ? tile - 1 - y : y);
          const int col = (k % per_row) * tile + x;
          const float a = mosaic[static_cast<std::size_t>(row) * info.columns + col];
          const float b =
              ref->GetBufferPointer()[(static_cast<std::size_t>(k) * tile + y) * tile + x];
          mismatches += a != b;
        }
    if (mismatches == 0) return;
  }
  ADD_FAILURE() << dicom << " does not match " << nifti << " in either row order";
}

TEST(TransferSyntaxes, TwelveBitStoredPixelsAreMaskedAndSignExtended) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path dir = data / "dicom" / "mr-12bit-signed-unsigned";
  expect_mosaic_matches_nifti(dir / "In" / "12bitUnsigned.dcm", dir / "Ref" / "2.nii");
  expect_mosaic_matches_nifti(dir / "In" / "12bitUnsigned_0x0F0F.dcm", dir / "Ref" / "3.nii");
  expect_mosaic_matches_nifti(dir / "In" / "12bitSigned_0x0F0F.dcm", dir / "Ref" / "4.nii");
  // The stripes: 0x0F0F is 3855 unsigned and -241 as 12-bit signed; 0xFFFF is 4095 / -1.
  const auto u = decode_dicom_file(dir / "In" / "12bitUnsigned_0x0F0F.dcm");
  const auto s = decode_dicom_file(dir / "In" / "12bitSigned_0x0F0F.dcm");
  EXPECT_NE(std::find(u.begin(), u.end(), 3855.0f), u.end());
  EXPECT_NE(std::find(s.begin(), s.end(), -241.0f), s.end());
  EXPECT_EQ(*std::max_element(u.begin(), u.end()), 4095.0f);
  EXPECT_GE(*std::min_element(s.begin(), s.end()), -2048.0f);
  EXPECT_LE(*std::max_element(s.begin(), s.end()), 2047.0f);
}

TEST(TransferSyntaxes, MrVariantsMatchEachOtherAndTheReference) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path dir = data / "dicom" / "mr-transfer-syntax-variants";
  const std::vector<float> reference = decode_dicom_file(dir / "1.dcm");
  for (int k = 2; k <= 9; ++k) {
    DicomFileInfo info;
    const auto v = decode_dicom_file(dir / (std::to_string(k) + ".dcm"), &info);
    EXPECT_EQ(compare(v, reference).differing, 0u)
        << k << ".dcm (" << dicom_uid_name(info.transfer_syntax_uid) << ")";
  }
  expect_mosaic_matches_nifti(dir / "1.dcm", dir / "Ref" / "1.nii");
}

TEST(TransferSyntaxes, FragmentedJpegLosslessAndJpeg2000FramesDecode) {
  TSF_SHARED_DATA_OR_SKIP(data);
  for (const auto& e :
       fs::recursive_directory_iterator(data / "dicom" / "mr-fragmented-jpegll-j2k")) {
    if (e.path().extension() != ".dcm") continue;
    DicomFileInfo info;
    const auto v = decode_dicom_file(e.path(), &info);
    EXPECT_EQ(v.size(), static_cast<std::size_t>(info.columns) * info.rows) << e.path();
    EXPECT_GT(*std::max_element(v.begin(), v.end()), 0.0f) << e.path() << " decoded to zeros";
  }
}

}  // namespace
}  // namespace tsf::import
