// Values that cannot be right: a DICOM slice whose geometry or rescale attribute is present but
// empty, unparsable, not finite or absurd; a volume file whose header carries non-finite or
// absurd geometry, or whose gzip stream fails its own check. Each is refused naming the file,
// the attribute or key, the value and what was expected; none becomes 0 or 1 silently
// (import.md, "Limits and safety"). Runs under ASan + UBSan in CI ("Robustness").
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <utility>

#include <dcmtk/dcmdata/dcsequen.h>

#include "dicom_test_files.h"
#include "support/crafted_bytes.h"
#include "support/error_of.h"
#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/import/dicom_file_info.h"
#include "tsf/import/import_volume.h"

namespace tsf::import {
namespace {
namespace fs = std::filesystem;
using test_files::copy_with_changes;

/// The error of importing `path` ("" when it was accepted).
std::string import_error(const fs::path& path) {
  ImportOptions options;
  options.show_progress = false;
  return test::error_of([&] { import_volume(path, options); });
}

/// Three slices of the GE sample in `dir`, the second edited by `change`.
fs::path ge_series_with_second_slice(const fs::path& dir,
                                     const std::function<void(DcmDataset&)>& change) {
  const fs::path ge = test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
  fs::create_directories(dir);
  for (const char* name : {"01.dcm", "03.dcm"}) fs::copy_file(ge / name, dir / name);
  copy_with_changes(ge / "02.dcm", dir / "02.dcm", change);
  return dir;
}

TEST(HostileValuesRobustness, UnusableRescaleOrGeometryValuesRefuseTheSeriesNamingThem) {
  const fs::path root = test::scratch_dir("hostile-dicom-values");
  // The untouched three slices are a volume: what follows fails because of the one edit.
  const fs::path control = ge_series_with_second_slice(root / "control", [](DcmDataset&) {});
  ASSERT_EQ(import_error(control), "");

  struct Case {
    const char* name;
    DcmTagKey tag;
    const char* value;
    const char* expected;
  };
  const Case cases[] = {
      {"intercept-nan", DCM_RescaleIntercept, "NaN",
       "RescaleIntercept (0028,1052) is 'NaN': expected a finite decimal number"},
      {"intercept-empty", DCM_RescaleIntercept, "",
       "RescaleIntercept (0028,1052) is empty or missing (0 values): expected a finite decimal"},
      {"intercept-text", DCM_RescaleIntercept, "abc",
       "RescaleIntercept (0028,1052) is 'abc': expected a finite decimal number"},
      {"slope-inf", DCM_RescaleSlope, "1e400", "RescaleSlope (0028,1053) is '1e400'"},
      {"spacing-huge", DCM_PixelSpacing, "1e300\\1e300",
       "PixelSpacing (0028,0030)[0] is '1e300': expected a number in (0, 1000] mm"},
      {"spacing-one-value", DCM_PixelSpacing, "0.5",
       "PixelSpacing (0028,0030)[1] is empty or missing (1 values)"},
      {"position-nan", DCM_ImagePositionPatient, "0\\nan\\0",
       "ImagePositionPatient (0020,0032)[1] is 'nan': expected a number in [-1e+06, 1e+06] mm"},
      {"orientation-text", DCM_ImageOrientationPatient, "1\\0\\0\\0\\one\\0",
       "ImageOrientationPatient (0020,0037)[4] is 'one'"},
  };
  for (const Case& c : cases) {
    const fs::path dir = ge_series_with_second_slice(
        root / c.name, [&](DcmDataset& ds) { ds.putAndInsertString(c.tag, c.value); });
    const std::string e = import_error(dir);
    EXPECT_NE(e.find("02.dcm"), std::string::npos) << c.name << ": " << e;
    EXPECT_NE(e.find(c.expected), std::string::npos) << c.name << ": " << e;
    const DicomFileInfo info = read_dicom_file_info(dir / "02.dcm");
    EXPECT_EQ(info.kind, DicomObjectKind::unreadable) << c.name;
  }
}

void write_bytes(const fs::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary) << bytes;
}

const char* const kSpace =
    "space: left-posterior-superior\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n";

/// A 4×4×4 int16 NRRD with `fields` in its header and `data` after it.
std::string nrrd(const std::string& fields, const std::string& encoding, const std::string& data) {
  return "NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 4 4\nendian: little\nencoding: " +
         encoding + "\n" + fields + "\n" + data;
}

/// A 4×4×4 int16 MetaImage with `fields` before its LOCAL data.
std::string mha(const std::string& fields) {
  return "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_SHORT\n" + fields +
         "ElementDataFile = LOCAL\n" + std::string(128, '\0');
}

/// A 4×4×4 int16 NIfTI-1 file: sform (code 1) row x = `srow_x`, pixdim[1] = `dx`; qform off.
std::string nifti(const float srow_x[4], float dx) {
  const float pixdim[3] = {dx, 1, 1}, qoffset[3] = {0, 0, 0};
  return test::nifti1_header(4, 4, 4, pixdim, 0, qoffset, 1, srow_x) + std::string(128, '\0');
}

/// gzip member (stored, no compression) of `data`: CRC-32 and length in its trailer.
std::string gzip_stored(const std::string& data) {
  std::string g("\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\x03", 10);
  const auto n = static_cast<std::uint16_t>(data.size());
  g += '\x01';  // final stored block
  g += static_cast<char>(n & 0xff);
  g += static_cast<char>(n >> 8);
  g += static_cast<char>(~n & 0xff);
  g += static_cast<char>((~n >> 8) & 0xff);
  g += data;
  std::uint32_t crc = 0xffffffffu;
  for (unsigned char c : data) {
    crc ^= c;
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  crc = ~crc;
  for (const std::uint32_t v : {crc, static_cast<std::uint32_t>(data.size())})
    for (int b = 0; b < 4; ++b) g += static_cast<char>((v >> (8 * b)) & 0xff);
  return g;
}

TEST(HostileValuesRobustness, NonFiniteOrAbsurdVolumeGeometryIsRefusedNamingTheKey) {
  const fs::path dir = test::scratch_dir("hostile-volume-geometry");
  const std::string voxels(128, '\0');
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float sform_ok[4] = {1, 0, 0, 0}, sform_nan[4] = {nan, 0, 0, 0};
  struct Case {
    const char* name;
    std::string bytes;
    const char* expected;  ///< "" = accepted
  };
  const Case cases[] = {
      {"ok.nrrd", nrrd(std::string(kSpace) + "space origin: (0,0,0)\n", "raw", voxels), ""},
      {"origin-nan.nrrd",
       nrrd(std::string(kSpace) + "space origin: (nan,nan,nan)\n", "raw", voxels),
       "line 9, space origin is '(nan,nan,nan)': 'nan' is not a finite number within ±1e+06 mm"},
      {"direction-huge.nrrd",
       nrrd("space: left-posterior-superior\nspace directions: (1e300,0,0) (0,1,0) (0,0,1)\n",
            "raw", voxels),
       "space directions is '(1e300,0,0) (0,1,0) (0,0,1)': '1e300' is not a finite number"},
      {"spacings-nan.nrrd", nrrd("spacings: nan 1 1\n", "raw", voxels),
       "line 7, spacings is 'nan 1 1': 'nan' is not a finite"},
      {"spacing-far.nrrd", nrrd("spacings: 5000 1 1\n", "raw", voxels),
       "spacing 5000 along axis 0 (expected a number of mm in (0, 1000])"},
      {"ok.mha", mha("Offset = 0 0 0\nElementSpacing = 1 1 1\n"), ""},
      {"offset-nan.mha", mha("Offset = nan nan nan\n"), "line 5, Offset is 'nan nan nan'"},
      {"spacing-huge.mha", mha("ElementSpacing = 1e300 1 1\n"),
       "line 5, ElementSpacing is '1e300 1 1': '1e300' is not a finite number"},
      {"matrix-inf.mha", mha("TransformMatrix = inf 0 0 0 1 0 0 0 1\n"),
       "line 5, TransformMatrix is 'inf 0 0 0 1 0 0 0 1'"},
      {"ok.nii", nifti(sform_ok, 1), ""},
      {"sform-nan.nii", nifti(sform_nan, 1), "srow_x[0] is 'nan': 'nan' is not a finite number"},
      {"pixdim-inf.nii", nifti(sform_ok, std::numeric_limits<float>::infinity()),
       "pixdim[1] is 'inf'"},
  };
  for (const Case& c : cases) {
    write_bytes(dir / c.name, c.bytes);
    const std::string e = import_error(dir / c.name);
    if (std::string(c.expected).empty()) {
      EXPECT_EQ(e, "") << c.name;
      continue;
    }
    EXPECT_NE(e.find("'" + (dir / c.name).string() + "': "), std::string::npos) << e;
    EXPECT_NE(e.find(c.expected), std::string::npos) << c.name << ": " << e;
  }
}

TEST(HostileValuesRobustness, GzipVoxelDataFailingItsCrcOrLengthAreRefused) {
  const fs::path dir = test::scratch_dir("hostile-gzip");
  std::string voxels(128, '\0');
  for (std::size_t i = 0; i < voxels.size(); ++i) voxels[i] = static_cast<char>(i);
  const std::string header = std::string(kSpace) + "space origin: (0,0,0)\n";
  const std::string good = gzip_stored(voxels);
  write_bytes(dir / "ok.nrrd", nrrd(header, "gzip", good));
  ASSERT_EQ(import_error(dir / "ok.nrrd"), "");
  // One flipped voxel bit: the deflate data stay valid, only the CRC-32 tells.
  std::string flipped = good;
  flipped[15 + 40] ^= 0x04;
  write_bytes(dir / "flipped.nrrd", nrrd(header, "gzip", flipped));
  std::string e = import_error(dir / "flipped.nrrd");
  EXPECT_NE(e.find("the compressed voxel data fail their check: incorrect data check"),
            std::string::npos)
      << e;
  // A wrong length in the trailer.
  std::string length = good;
  length[length.size() - 4] ^= 0x01;
  write_bytes(dir / "length.nrrd", nrrd(header, "gzip", length));
  e = import_error(dir / "length.nrrd");
  EXPECT_NE(e.find("incorrect length check"), std::string::npos) << e;
  // Cut before the trailer: the voxels are all there, the check is not.
  write_bytes(dir / "cut.nrrd", nrrd(header, "gzip", good.substr(0, good.size() - 8)));
  e = import_error(dir / "cut.nrrd");
  EXPECT_NE(e.find("cut short"), std::string::npos) << e;
  // Garbage after the stream.
  write_bytes(dir / "trailing.nrrd", nrrd(header, "gzip", good + "garbage"));
  e = import_error(dir / "trailing.nrrd");
  EXPECT_NE(e.find("bytes follow the end"), std::string::npos) << e;
}

TEST(HostileValuesRobustness, EveryCompressedVolumeFormatIsCheckedOnTheBytesItsReaderInflated) {
  // The checksum is computed over what ITK decompressed (one inflate): right for NIfTI, whose
  // stream holds the header too, and for big-endian voxels, which ITK swaps; wrong bytes refused.
  const fs::path dir = test::scratch_dir("hostile-gzip-formats");
  std::string voxels(128, '\0');
  for (std::size_t i = 0; i < voxels.size(); i += 2) voxels[i] = static_cast<char>(i / 2);
  const float pixdim[3] = {1, 1, 1}, qoffset[3] = {0, 0, 0}, srow[4] = {1, 0, 0, 0};
  const std::string h = test::nifti1_header(4, 4, 4, pixdim, 0, qoffset, 1, srow);
  write_bytes(dir / "ok.nii.gz", gzip_stored(h + voxels));
  ASSERT_EQ(import_error(dir / "ok.nii.gz"), "");
  std::string flipped = gzip_stored(h + voxels);
  flipped[15 + 352 + 20] ^= 0x10;  // a voxel byte, behind the NIfTI header in the stream
  write_bytes(dir / "flipped.nii.gz", flipped);
  std::string e = import_error(dir / "flipped.nii.gz");
  EXPECT_NE(e.find("incorrect data check"), std::string::npos) << e;

  // Big-endian int16 voxels in a gzip NRRD: ITK swaps them; the values are 0..63.
  std::string big(128, '\0');
  for (std::size_t i = 0; i < big.size(); i += 2) big[i + 1] = static_cast<char>(i / 2);
  std::string header = nrrd(std::string(kSpace) + "space origin: (0,0,0)\n", "gzip", "");
  header.replace(header.find("endian: little"), 14, "endian: big");
  write_bytes(dir / "big.nrrd", header + gzip_stored(big));
  ImportOptions options;
  options.show_progress = false;
  const ImportResult r = import_volume(dir / "big.nrrd", options);
  EXPECT_EQ(r.image->GetBufferPointer()[63], 63.0f);
  std::string big_flipped = gzip_stored(big);
  big_flipped[15 + 9] ^= 0x01;
  write_bytes(dir / "big-flipped.nrrd", header + big_flipped);
  e = import_error(dir / "big-flipped.nrrd");
  EXPECT_NE(e.find("incorrect data check"), std::string::npos) << e;

  // A zlib-compressed MetaImage (Adler-32) with one voxel byte changed after compression.
  std::string zlib = test::deflated(voxels, 15);
  write_bytes(dir / "ok.mha",
              "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_SHORT\n"
              "CompressedData = True\nCompressedDataSize = " +
                  std::to_string(zlib.size()) + "\nElementDataFile = LOCAL\n" + zlib);
  ASSERT_EQ(import_error(dir / "ok.mha"), "");
  zlib[zlib.size() - 1] ^= 0x01;  // the Adler-32's last byte
  write_bytes(dir / "adler.mha",
              "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_SHORT\n"
              "CompressedData = True\nCompressedDataSize = " +
                  std::to_string(zlib.size()) + "\nElementDataFile = LOCAL\n" + zlib);
  e = import_error(dir / "adler.mha");
  EXPECT_NE(e.find("incorrect data check"), std::string::npos) << e;
}

/// A DICOMDIR in `root` referencing two GE slices in root/DICOM, then its second record's
/// ReferencedFileID replaced by `id`.
void dicomdir_with_second_id(const fs::path& root, const std::string& id) {
  const fs::path ge = test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
  fs::create_directories(root / "DICOM");
  fs::copy_file(ge / "01.dcm", root / "DICOM" / "IM1");
  fs::copy_file(ge / "02.dcm", root / "DICOM" / "IM2");
  test_files::write_dicomdir(root, {"DICOM/IM1", "DICOM/IM2"});
  DcmFileFormat file;
  ASSERT_TRUE(file.loadFile((root / "DICOMDIR").c_str()).good());
  DcmSequenceOfItems* records = nullptr;
  ASSERT_TRUE(file.getDataset()->findAndGetSequence(DCM_DirectoryRecordSequence, records).good());
  int images = 0;
  for (unsigned long r = 0; r < records->card(); ++r) {
    DcmItem* record = records->getItem(r);
    OFString old;
    if (record->findAndGetOFStringArray(DCM_ReferencedFileID, old).good() && ++images == 2) {
      ASSERT_TRUE(record->putAndInsertString(DCM_ReferencedFileID, id.c_str()).good());
    }
  }
  ASSERT_EQ(images, 2);
  ASSERT_TRUE(file.saveFile((root / "DICOMDIR").c_str()).good());
}

TEST(HostileValuesRobustness, ADicomdirReferenceOutsideItsFileSetIsRefused) {
  const fs::path root = test::scratch_dir("hostile-dicomdir");
  // A file outside the file-set, reachable by an absolute ID or by climbing.
  const fs::path outside = root / "outside";
  fs::create_directories(outside);
  fs::copy_file(test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing" / "03.dcm",
                outside / "IM3");
  dicomdir_with_second_id(root / "control", "DICOM\\IM2");
  EXPECT_EQ(import_error(root / "control" / "DICOMDIR"), "");
  const std::string absolute = (outside / "IM3").string();
  struct Case {
    const char* name;
    std::string id, component;
  };
  const Case cases[] = {{"absolute", absolute, absolute},
                        {"climbing", "..\\..\\outside\\IM3", ".."},
                        {"drive", "C:\\IM3", "C:"}};
  for (const Case& c : cases) {
    const fs::path dicomdir = root / c.name / "DICOMDIR";
    dicomdir_with_second_id(root / c.name, c.id);
    const std::string e = import_error(dicomdir);
    EXPECT_NE(e.find("DICOMDIR '" + dicomdir.string() + "': directory record"), std::string::npos)
        << e;
    EXPECT_NE(e.find("ReferencedFileID (0004,1500) '" + c.id +
                     "' leaves the file-set (component '" + c.component + "')"),
              std::string::npos)
        << c.name << ": " << e;
  }
  // A link inside the file-set that points out of it is not followed.
  const fs::path linked = root / "linked";
  dicomdir_with_second_id(linked, "DICOM\\LINK");
  fs::create_symlink(outside / "IM3", linked / "DICOM" / "LINK");
  const DicomDirContents contents = read_dicomdir(linked / "DICOMDIR");
  EXPECT_EQ(contents.files.size(), 1u);
  EXPECT_EQ(contents.missing.size(), 1u);
}

/// Little-endian bytes of a 16- and 32-bit value.
std::string le16(unsigned v) {
  return {static_cast<char>(v & 0xff), static_cast<char>(v >> 8)};
}
std::string le32(std::uint32_t v) {
  return le16(v & 0xffff) + le16(v >> 16);
}

/// An explicit VR little endian element with a short (2-byte) length.
std::string element(unsigned group, unsigned elem, const char* vr, std::string value) {
  if (value.size() % 2) value += '\0';
  return le16(group) + le16(elem) + vr + le16(static_cast<unsigned>(value.size())) + value;
}

/// A CT-like data set whose one sequence nests `depth` undefined-length sequences; explicit or
/// implicit VR little endian, or deflated (a meta header naming the transfer syntax first).
std::string nested_file(int depth, const std::string& syntax) {
  const bool implicit = syntax == "1.2.840.10008.1.2";
  std::string ds = element(0x0008, 0x0016, "UI", "1.2.840.10008.5.1.4.1.1.2") +
                   element(0x0008, 0x0018, "UI", "1.2.3.4") +
                   element(0x0020, 0x000E, "UI", "1.2.3.99");
  if (implicit) {  // implicit VR: tag, 4-byte length
    ds.clear();
    for (const auto& [e, v] :
         {std::pair<unsigned, std::string>{0x0016, "1.2.840.10008.5.1.4.1.1.2"},
          {0x0018, "1.2.3.4\0"}})
      ds += le16(0x0008) + le16(e) + le32(static_cast<std::uint32_t>(v.size())) + v;
    ds += le16(0x0020) + le16(0x000E) + le32(8) + std::string("1.2.3.99", 8);
  }
  const std::string open_sq = le16(0x0040) + le16(0xA730) +
                              (implicit ? std::string() : std::string("SQ\0\0", 4)) +
                              le32(0xFFFFFFFFu) + le16(0xFFFE) + le16(0xE000) + le32(0xFFFFFFFFu);
  const std::string close_sq =
      le16(0xFFFE) + le16(0xE00D) + le32(0) + le16(0xFFFE) + le16(0xE0DD) + le32(0);
  for (int i = 0; i < depth; ++i) ds += open_sq;
  for (int i = 0; i < depth; ++i) ds += close_sq;
  if (syntax == "1.2.840.10008.1.2.1.99") ds = test::deflated(ds, -15);
  std::string meta = std::string("OB\0\0", 4);
  meta = le16(0x0002) + le16(0x0001) + meta + le32(2) + std::string("\0\1", 2) +
         element(0x0002, 0x0002, "UI", "1.2.840.10008.5.1.4.1.1.2") +
         element(0x0002, 0x0003, "UI", "1.2.3.4") + element(0x0002, 0x0010, "UI", syntax);
  meta = element(0x0002, 0x0000, "UL", le32(static_cast<std::uint32_t>(meta.size()))) + meta;
  return std::string(128, '\0') + "DICM" + meta + ds;
}

TEST(HostileValuesRobustness, DeeplyNestedSequencesAreRefusedBeforeTheParserRecurses) {
  const fs::path dir = test::scratch_dir("hostile-nesting");
  for (const char* syntax :
       {"1.2.840.10008.1.2.1", "1.2.840.10008.1.2", "1.2.840.10008.1.2.1.99"}) {
    // 10,000 levels overflowed DCMTK's recursive reader (a crash in --list too).
    const fs::path deep = dir / (std::string("deep-") + syntax + ".dcm");
    write_bytes(deep, nested_file(10000, syntax));
    DicomFileInfo info = read_dicom_file_info(deep);
    EXPECT_EQ(info.kind, DicomObjectKind::unreadable) << syntax;
    EXPECT_EQ(info.skip_reason, "sequences nested more than 64 deep: refused before parsing")
        << syntax;
    EXPECT_EQ(info.series_instance_uid, "1.2.3.99") << syntax;
    // 60 levels are parsed as usual (a file without pixel data).
    const fs::path shallow = dir / (std::string("shallow-") + syntax + ".dcm");
    write_bytes(shallow, nested_file(60, syntax));
    info = read_dicom_file_info(shallow);
    EXPECT_EQ(info.kind, DicomObjectKind::non_image) << syntax << ": " << info.skip_reason;
  }
  // In a folder: the listing names the file and its reason, nothing crashes.
  const std::string e = import_error(dir);
  EXPECT_NE(e.find("sequences nested more than 64 deep"), std::string::npos) << e;
}

}  // namespace
}  // namespace tsf::import
