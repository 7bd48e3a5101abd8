// ImportRobustness: every file and folder of the data, and crafted broken or lying inputs, give
// either a volume with consistent geometry or a tsf::Error that names the input — never a
// crash, a hang or an unbounded allocation. CI runs this suite under ASan + UBSan
// (.ci/run: ctest -R Robustness), so a read past a buffer or a huge allocation fails it.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <string>

#include "dicom_test_files.h"
#include "support/crafted_bytes.h"
#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/import/dicom_file_info.h"
#include "tsf/import/dicom_pixel_reader.h"
#include "tsf/import/import_volume.h"
#include "tsf/import/volume_statistics.h"

namespace tsf::import {
namespace {
namespace fs = std::filesystem;
using test_files::copy_with_changes;

/// Generous for a 2-core CI machine under ASan; a hang shows up as a failure, not a timeout.
constexpr double kSecondsPerInput = 60;

ImportOptions walk_options() {
  ImportOptions o;
  o.show_progress = false;
  o.allow_non_ct = true;  // exercise every decoding path, MR included
  return o;
}

void expect_consistent_volume(const ImportResult& r, const fs::path& path) {
  ASSERT_TRUE(r.image) << path;
  const auto size = r.image->GetLargestPossibleRegion().GetSize();
  for (int a = 0; a < 3; ++a) {
    EXPECT_GT(size[a], 0u) << path;
    EXPECT_GT(r.image->GetSpacing()[a], 0.0) << path;
    EXPECT_TRUE(std::isfinite(r.image->GetSpacing()[a]) && std::isfinite(r.image->GetOrigin()[a]))
        << path;
    EXPECT_EQ(static_cast<int>(size[a]), r.report.output.dims[a]) << path;
    for (int b = 0; b < 3; ++b) {
      double d = 0;
      for (int row = 0; row < 3; ++row)
        d += r.image->GetDirection()[row][a] * r.image->GetDirection()[row][b];
      EXPECT_NEAR(d, a == b ? 1.0 : 0.0, 1e-6) << path << ": direction not orthonormal";
    }
  }
  EXPECT_GE(size[2], 2u) << path;
  const VolumeStatistics s = volume_statistics(
      r.image->GetBufferPointer(), r.image->GetLargestPossibleRegion().GetNumberOfPixels());
  EXPECT_EQ(s.non_finite, 0) << path;
  EXPECT_EQ(s.min, r.report.output.min_value) << path;
  EXPECT_EQ(s.max, r.report.output.max_value) << path;
}

/// Imports `path`: a volume must be consistent; an error must be a tsf::Error naming the input.
/// Returns true when a volume came back.
bool import_or_clear_error(const fs::path& path, const ImportOptions& options = walk_options()) {
  const auto start = std::chrono::steady_clock::now();
  bool ok = false;
  try {
    const ImportResult r = import_volume(path, options);
    expect_consistent_volume(r, path);
    ok = true;
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_FALSE(m.empty()) << path;
    EXPECT_NE(m.find(path.filename().string()), std::string::npos)
        << path << ": the error does not name the input: " << m;
  } catch (const std::exception& e) {
    ADD_FAILURE() << path << ": not a tsf::Error (" << typeid(e).name() << "): " << e.what();
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, kSecondsPerInput) << path;
  return ok;
}

/// Decodes `path` directly when it is a DICOM image: every codec path runs under the sanitizers
/// even for single images that are not volumes.
void decode_or_clear_error(const fs::path& path) {
  DicomFileInfo info;
  try {
    info = read_dicom_file_info(path);
  } catch (const Error&) {
    return;
  }
  if (info.kind != DicomObjectKind::image && info.kind != DicomObjectKind::localizer) return;
  try {
    const std::vector<float> v = decode_dicom_file(path);
    EXPECT_EQ(volume_statistics(v.data(), v.size()).non_finite, 0) << path;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path.filename().string()), std::string::npos) << e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << path << ": not a tsf::Error: " << e.what();
  }
}

struct WalkCount {
  int inputs = 0, volumes = 0;
};

WalkCount walk(const fs::path& root) {
  WalkCount count;
  std::vector<fs::path> inputs{root};
  for (const auto& e : fs::recursive_directory_iterator(root)) inputs.push_back(e.path());
  for (const auto& p : inputs) {
    ++count.inputs;
    if (import_or_clear_error(p)) ++count.volumes;
    if (fs::is_regular_file(p)) decode_or_clear_error(p);
  }
  return count;
}

TEST(ImportRobustness, EveryBundledSampleFileAndFolderGivesAVolumeOrAClearError) {
  const WalkCount c = walk(test::samples_dir());
  EXPECT_GT(c.inputs, 30);
  EXPECT_GE(c.volumes, 2) << "at least the cranium and the GE series";
}

TEST(ImportRobustness, EverySharedDataFileAndFolderGivesAVolumeOrAClearError) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const WalkCount c = walk(data);
  EXPECT_GT(c.inputs, 100);
  EXPECT_GE(c.volumes, 8);
}

void write_file(const fs::path& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary) << bytes;
}

std::string expect_refused(const fs::path& p, const std::string& expected_words) {
  try {
    import_volume(p, walk_options());
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(expected_words), std::string::npos) << e.what();
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << p << ": not a tsf::Error: " << e.what();
    return {};
  }
  ADD_FAILURE() << p << " was accepted";
  return {};
}

/// A NIfTI-1 header (348 bytes + 4 extension bytes) declaring dims nx×ny×nz of int16.
std::string nifti_header(std::int16_t nx, std::int16_t ny, std::int16_t nz) {
  const float pixdim[3] = {1, 1, 1}, none[4] = {0, 0, 0, 0};
  return test::nifti1_header(nx, ny, nz, pixdim, 0, none, 0, none);
}

TEST(ImportRobustness, HugeHeaderClaimsAreRefusedBeforeAllocating) {
  const fs::path dir = test::scratch_dir("huge");
  write_file(dir / "claims-1e15.nrrd",
             "NRRD0004\ntype: int16\ndimension: 3\nsizes: 100000 100000 100000\nendian: little\n"
             "encoding: raw\n\n" +
                 std::string(64, '\0'));
  expect_refused(dir / "claims-1e15.nrrd", "refused before allocating");
  // Within the voxel limit but far more than the file holds (800 MB claimed, 64 bytes there).
  write_file(dir / "short-raw.nrrd",
             "NRRD0004\ntype: int16\ndimension: 3\nsizes: 1000 1000 400\nendian: little\n"
             "encoding: raw\n\n" +
                 std::string(64, '\0'));
  expect_refused(dir / "short-raw.nrrd", "holds only 64");
  write_file(dir / "short-gzip.nrrd",
             "NRRD0004\ntype: int16\ndimension: 3\nsizes: 1000 1000 400\nendian: little\n"
             "encoding: gzip\n\n" +
                 std::string(100, 'x'));
  expect_refused(dir / "short-gzip.nrrd", "gzip cannot compress");
  write_file(dir / "detached.nhdr",
             "NRRD0004\ntype: int16\ndimension: 3\nsizes: 512 512 300\nendian: little\n"
             "encoding: raw\ndata file: missing.raw\n\n");
  expect_refused(dir / "detached.nhdr", "detached.nhdr");
  write_file(dir / "huge.mha",
             "ObjectType = Image\nNDims = 3\nDimSize = 60000 60000 60000\nElementType = MET_SHORT\n"
             "ElementDataFile = LOCAL\n" +
                 std::string(64, '\0'));
  expect_refused(dir / "huge.mha", "refused before allocating");
  write_file(dir / "short.mha",
             "ObjectType = Image\nNDims = 3\nDimSize = 1000 1000 400\nElementType = MET_SHORT\n"
             "ElementDataFile = LOCAL\n" +
                 std::string(64, '\0'));
  expect_refused(dir / "short.mha", "holds only");
  write_file(dir / "huge.nii", nifti_header(30000, 30000, 30000));
  expect_refused(dir / "huge.nii", "refused before allocating");
  write_file(dir / "short.nii", nifti_header(1000, 1000, 400) + std::string(64, '\0'));
  expect_refused(dir / "short.nii", "holds only");

  // DICOM: two slices claiming 40000² pixels each (3.2 G voxels) in native pixel data of 512².
  const fs::path ge = test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
  for (const char* name : {"01.dcm", "02.dcm"})
    copy_with_changes(ge / name, dir / "dicom-huge" / name, [](DcmDataset& ds) {
      ds.putAndInsertUint16(DCM_Rows, 40000);
      ds.putAndInsertUint16(DCM_Columns, 40000);
    });
  expect_refused(dir / "dicom-huge", "hold 524288 bytes, its header declares 40000×40000");
  // A real series over a (lowered) voxel limit: refused before its slices are allocated.
  ImportOptions small = walk_options();
  small.max_voxels = 1000000;
  try {
    import_volume(ge, small);
    ADD_FAILURE() << "a 7.3 M voxel series passed a 1 M voxel limit";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("more than the limit of 1000000"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("ct-head-ge-hispeed-tilt-varspacing"), std::string::npos);
  }
  // One slice claiming 60000 frames.
  copy_with_changes(ge / "01.dcm", dir / "frames.dcm",
                    [](DcmDataset& ds) { ds.putAndInsertString(DCM_NumberOfFrames, "60000"); });
  expect_refused(dir / "frames.dcm", "frames.dcm");
  EXPECT_THROW(decode_dicom_file(dir / "frames.dcm"), Error);
  copy_with_changes(ge / "01.dcm", dir / "frames-out-of-range.dcm", [](DcmDataset& ds) {
    ds.putAndInsertString(DCM_NumberOfFrames, "2000000000");
  });
  const DicomFileInfo info = read_dicom_file_info(dir / "frames-out-of-range.dcm");
  EXPECT_EQ(info.kind, DicomObjectKind::unsupported);
  EXPECT_NE(info.skip_reason.find("out of range"), std::string::npos) << info.skip_reason;
}

TEST(ImportRobustness, TruncatedAndGarbageInputsGiveClearErrors) {
  const fs::path dir = test::scratch_dir("garbage");
  const fs::path ge = test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
  const std::string slice = test_files::file_bytes(ge / "01.dcm");
  std::mt19937 rng(7);
  std::string noise(4096, '\0');
  for (char& c : noise) c = static_cast<char>(rng() & 0xff);

  std::vector<fs::path> files;
  auto add = [&](const std::string& name, const std::string& bytes) {
    write_file(dir / name, bytes);
    files.push_back(dir / name);
  };
  add("empty.dcm", "");
  add("noise.dcm", noise);
  add("preamble-then-noise.dcm", std::string(128, '\0') + "DICM" + noise);
  add("truncated-header.dcm", slice.substr(0, 700));
  add("truncated-pixels.dcm", slice.substr(0, slice.size() / 2));
  add("truncated-last-byte.dcm", slice.substr(0, slice.size() - 1));
  add("noise-in-pixels.dcm", slice.substr(0, slice.size() - 4096) + noise);
  add("empty.nrrd", "");
  add("header-only.nrrd", "NRRD0004\ntype: int16\ndimension: 3\nsizes: 4 4 4\n");
  add("noise.nrrd", "NRRD0004\n" + noise);
  add("noise.mha", "ObjectType = Image\n" + noise);
  add("truncated.nii", nifti_header(16, 16, 16).substr(0, 200));
  add("noise.nii.gz", noise);
  for (const auto& f : files) {
    import_or_clear_error(f);
    decode_or_clear_error(f);
  }
  // A folder of nothing usable says what it found.
  const std::string m = expect_refused(dir, "files examined");
  EXPECT_NE(m.find("skipped"), std::string::npos) << m;
  EXPECT_NE(m.find("damaged or truncated DICOM"), std::string::npos) << m;
  // A series with one truncated slice is refused naming that slice.
  fs::create_directories(dir / "series");
  fs::copy_file(ge / "01.dcm", dir / "series" / "01.dcm");
  fs::copy_file(ge / "02.dcm", dir / "series" / "02.dcm");
  const std::string third = test_files::file_bytes(ge / "03.dcm");
  write_file(dir / "series" / "03.dcm", third.substr(0, third.size() - 1000));
  const std::string t = expect_refused(dir / "series", "03.dcm");
  EXPECT_NE(t.find("is damaged"), std::string::npos) << t;
}

}  // namespace
}  // namespace tsf::import
