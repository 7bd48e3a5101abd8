// DICOM discovery and series checks: what is skipped and why, what is refused as "not one
// volume" and why, DICOMDIR, enhanced multi-frame CT, rescale, series selection.
#include <dcmtk/dcmdata/dcsequen.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "dicom_test_files.h"
#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/import/dicom_catalog.h"
#include "tsf/import/dicom_pixel_reader.h"
#include "tsf/import/import_volume.h"

namespace tsf::import {
namespace {
namespace fs = std::filesystem;
using test_files::copy_with_changes;

ImportOptions quiet() {
  ImportOptions o;
  o.show_progress = false;
  return o;
}

std::string import_error(const fs::path& path, const ImportOptions& o = quiet()) {
  try {
    import_volume(path, o);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "import of " << path << " succeeded";
  return {};
}

const SkippedFile* skipped(const DicomCatalog& c, const std::string& name) {
  for (const auto& k : c.skipped)
    if (k.path.filename() == name) return &k;
  return nullptr;
}

TEST(DicomSeries, GeFolderIsOneUsableSeriesAndTheLicenceIsSkipped) {
  const DicomCatalog c = catalog_dicom(test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing",
                                       {SliceStackOptions{}, false});
  EXPECT_EQ(c.discovered_by, "folder");
  EXPECT_EQ(c.files_examined, 29);
  ASSERT_EQ(c.series.size(), 1u);
  EXPECT_TRUE(c.series[0].usable());
  EXPECT_EQ(c.series[0].slice_count(), 28);
  EXPECT_EQ(c.series[0].modality, "CT");
  const SkippedFile* licence = skipped(c, "LICENSE-SOURCE.txt");
  ASSERT_NE(licence, nullptr);
  EXPECT_EQ(licence->reason, "not DICOM");
}

TEST(DicomSeries, PhilipsPhantomInterceptIsAppliedAndLocalizerAndDirfileSkipped) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path dir = data / "dicom" / "ct-head-phantom-philips-ingenuity";
  const ImportResult r = import_volume(dir, quiet());
  const ImportReport& rep = r.report;
  EXPECT_EQ(rep.series.description, "STD BRAIN 5MM");
  EXPECT_EQ(rep.acquisition.dims.z, 28);
  EXPECT_FALSE(rep.resampling.applied);
  EXPECT_DOUBLE_EQ(rep.rescale.intercept, -1024.0);
  EXPECT_EQ(rep.rescale.pixel_representation, "unsigned");
  EXPECT_EQ(rep.rescale.bits_stored, 12);

  // Air around the phantom sits at about -1000 HU (the unsigned 12-bit values start at 0).
  const float* v = r.image->GetBufferPointer();
  const std::size_t n = r.image->GetLargestPossibleRegion().GetNumberOfPixels();
  std::vector<float> air;
  for (std::size_t i = 0; i < n; ++i)
    if (v[i] > -1100 && v[i] < -900) air.push_back(v[i]);
  ASSERT_GT(air.size(), n / 4);
  std::nth_element(air.begin(), air.begin() + air.size() / 2, air.end());
  EXPECT_NEAR(air[air.size() / 2], -1000.0f, 10.0f);
  EXPECT_GE(rep.output.min_value, -1024.0f);

  // One pixel, stored value read here with DCMTK: HU = stored + intercept.
  const fs::path first = dir / "S21570" / "S2010" / "I10";
  DcmFileFormat file;
  ASSERT_TRUE(file.loadFile(first.c_str()).good());
  const Uint16* stored = nullptr;
  unsigned long count = 0;
  ASSERT_TRUE(file.getDataset()->findAndGetUint16Array(DCM_PixelData, stored, &count).good());
  Float64 ipp[3];
  for (unsigned long a = 0; a < 3; ++a)
    file.getDataset()->findAndGetFloat64(DCM_ImagePositionPatient, ipp[a], a);
  const int i = 300, j = 200;  // inside the phantom
  HuImage::PointType p;
  p[0] = ipp[0] + i * 0.451171875;
  p[1] = ipp[1] + j * 0.451171875;
  p[2] = ipp[2];
  HuImage::IndexType index;
  ASSERT_TRUE(r.image->TransformPhysicalPointToIndex(p, index));
  EXPECT_EQ(r.image->GetPixel(index), static_cast<float>((stored[j * 512 + i] & 0x0FFF) - 1024));

  const DicomCatalog c = catalog_dicom(dir, {SliceStackOptions{}, false});
  const SkippedFile* localizer = nullptr;
  int dirfiles = 0;
  for (const auto& k : c.skipped) {
    if (k.path.filename() == "I10" && k.path.parent_path().filename() == "S1000") localizer = &k;
    if (k.path.filename() == "DIRFILE") {
      ++dirfiles;
      EXPECT_NE(k.reason.find("DICOMDIR"), std::string::npos) << k.reason;
    }
  }
  ASSERT_NE(localizer, nullptr);
  EXPECT_NE(localizer->reason.find("localizer"), std::string::npos) << localizer->reason;
  EXPECT_EQ(dirfiles, 2);
}

TEST(DicomSeries, ADicomdirImportsTheFilesItReferences) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path dir = data / "dicom" / "ct-head-phantom-philips-ingenuity" / "S21570" / "S2010";
  const ImportResult via_dir = import_volume(dir / "DIRFILE", quiet());
  EXPECT_EQ(via_dir.report.source.discovered_by, "DICOMDIR");
  const ImportResult via_folder = import_volume(dir, quiet());
  const std::size_t n = via_folder.image->GetLargestPossibleRegion().GetNumberOfPixels();
  ASSERT_EQ(via_dir.image->GetLargestPossibleRegion().GetNumberOfPixels(), n);
  EXPECT_TRUE(std::equal(via_dir.image->GetBufferPointer(), via_dir.image->GetBufferPointer() + n,
                         via_folder.image->GetBufferPointer()));
}

TEST(DicomSeries, AStandardDicomdirWrittenByDcmtkIsFollowed) {
  // A General Purpose CD-R file-set: IDs of up to 8 upper-case characters, in a subfolder.
  const fs::path ge = test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
  const fs::path root = test::scratch_dir("fileset");
  fs::create_directories(root / "DICOM");
  for (int k = 1; k <= 6; ++k) {
    char src[16], dst[16];
    std::snprintf(src, sizeof src, "%02d.dcm", k);
    std::snprintf(dst, sizeof dst, "IM%06d", k);
    fs::copy_file(ge / src, root / "DICOM" / dst);
  }
  std::vector<std::string> ids;
  for (int k = 1; k <= 6; ++k) {
    char id[32];
    std::snprintf(id, sizeof id, "DICOM/IM%06d", k);
    ids.push_back(id);
  }
  test_files::write_dicomdir(root, ids);
  fs::create_directories(root / "elsewhere");
  fs::copy_file(ge / "07.dcm", root / "elsewhere" / "07.dcm");  // not referenced: not read

  const DicomCatalog c = catalog_dicom(root / "DICOMDIR", {SliceStackOptions{}, false});
  EXPECT_EQ(c.discovered_by, "DICOMDIR");
  EXPECT_EQ(c.files_examined, 6);
  ASSERT_EQ(c.series.size(), 1u);
  EXPECT_EQ(c.series[0].slice_count(), 6);
  EXPECT_TRUE(c.series[0].usable());
}

TEST(DicomSeries, SixteenCtImageFilesAreRefusedAsOneVolumeWithTheReason) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path src = data / "dicom" / "ct-chest-slice-transfer-syntaxes-cornerstone";
  const fs::path dir = test::scratch_dir("ctimage");
  int copied = 0;
  for (const auto& e : fs::directory_iterator(src))
    if (e.path().filename().string().rfind("CTImage", 0) == 0) {
      fs::create_symlink(e.path(), dir / e.path().filename());
      ++copied;
    }
  ASSERT_EQ(copied, 16);
  const std::string m = import_error(dir);
  EXPECT_NE(m.find("no usable image series"), std::string::npos) << m;
  EXPECT_NE(m.find("16 images"), std::string::npos) << m;
  EXPECT_NE(m.find("SOP Instance UID 1.2.840.113619.2.30.1.1762295590.1623.978668950.109 is "
                   "repeated in 10 files"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("16 slices share one position"), std::string::npos) << m;

  // Asking for that series by UID in the full folder gives the same reasons.
  ImportOptions o = quiet();
  o.series_uid = "1.2.840.113619.2.30.1.1762295590.1623.978668949.890";
  const std::string m2 = import_error(src, o);
  EXPECT_NE(m2.find("is not one volume"), std::string::npos) << m2;
  EXPECT_NE(m2.find("repeated in 10 files"), std::string::npos) << m2;
}

TEST(DicomSeries, SeriesThatAreNotOneVolumeAreRefusedNamingTheCause) {
  const fs::path ge = test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
  auto make_series = [&](const std::string& name, int altered,
                         const std::function<void(DcmDataset&)>& change) {
    const fs::path dir = test::scratch_dir(name);
    for (int k = 1; k <= 6; ++k) {
      char file[16];
      std::snprintf(file, sizeof file, "%02d.dcm", k);
      if (k == altered)
        copy_with_changes(ge / file, dir / file, change);
      else
        fs::copy_file(ge / file, dir / file);
    }
    return dir;
  };
  // A slice of another size (a reconstruction of different matrix in the same series).
  const std::string size = import_error(make_series("size", 3, [](DcmDataset& ds) {
    ds.putAndInsertUint16(DCM_Columns, 256);
    ds.putAndInsertUint16(DCM_Rows, 1024);
  }));
  EXPECT_NE(size.find("images differ in size: 512×512 in 5 slices"), std::string::npos) << size;
  EXPECT_NE(size.find("256×1024 in 1 slice (03.dcm)"), std::string::npos) << size;
  // A slice of another orientation (a sagittal reformat filed under the same series UID).
  const std::string orientation = import_error(make_series("orientation", 4, [](DcmDataset& ds) {
    test_files::new_instance_uid(ds);
    ds.putAndInsertString(DCM_ImageOrientationPatient, "0\\1\\0\\0\\0\\-1");
  }));
  EXPECT_NE(orientation.find("images differ in orientation"), std::string::npos) << orientation;
  EXPECT_NE(orientation.find("04.dcm"), std::string::npos) << orientation;
  // The same image twice under two names (a copy): repeated SOP instance.
  const std::string copy = import_error(make_series("copy", 5, [](DcmDataset& ds) {
    ds.putAndInsertString(DCM_ImagePositionPatient, "-125\\-123.5404569\\99");
    OFString uid;
    DcmFileFormat other;
    other.loadFile((test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing" / "02.dcm").c_str());
    other.getDataset()->findAndGetOFString(DCM_SOPInstanceUID, uid);
    ds.putAndInsertString(DCM_SOPInstanceUID, uid.c_str());
  }));
  EXPECT_NE(copy.find("is repeated in 2 files (02.dcm, 05.dcm)"), std::string::npos) << copy;
  // Two slices at one position with different images (two phases mixed in one series).
  const std::string twice = import_error(make_series("position", 6, [](DcmDataset& ds) {
    test_files::new_instance_uid(ds);
    ds.putAndInsertString(DCM_ImagePositionPatient, "-125\\-123.5404569\\10.0560586");
  }));
  EXPECT_NE(twice.find("2 slices share one position"), std::string::npos) << twice;
  EXPECT_NE(twice.find("02.dcm, 06.dcm"), std::string::npos) << twice;
  // A gap of 20 slices: two stacks, not one volume.
  const std::string gap = import_error(make_series("gap", 6, [](DcmDataset& ds) {
    ds.putAndInsertString(DCM_ImagePositionPatient, "-125\\-123.5404569\\300");
  }));
  EXPECT_NE(gap.find("separate stacks"), std::string::npos) << gap;
}

TEST(DicomSeries, AMissingSliceIsReportedAndInterpolatedOrRefusedWhenStrict) {
  const fs::path ge = test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
  const fs::path dir = test::scratch_dir("missing");
  for (int k = 1; k <= 8; ++k) {
    if (k == 5) continue;
    char file[16];
    std::snprintf(file, sizeof file, "%02d.dcm", k);
    fs::copy_file(ge / file, dir / file);
  }
  const ImportResult r = import_volume(dir, quiet());
  ASSERT_EQ(r.report.acquisition.missing_slices.size(), 1u);
  EXPECT_EQ(r.report.acquisition.missing_slices[0].estimated_missing, 1);
  EXPECT_NEAR(r.report.acquisition.missing_slices[0].gap_mm, 8.0, 0.05);
  std::string warnings;
  for (const auto& w : r.report.warnings) warnings += w + "\n";
  EXPECT_NE(warnings.find("missing slice"), std::string::npos) << warnings;
  ImportOptions strict = quiet();
  strict.strict = true;
  const std::string m = import_error(dir, strict);
  EXPECT_NE(m.find("missing slice"), std::string::npos) << m;
}

TEST(DicomSeries, EnhancedMultiframeCtIsPlacedFromItsFunctionalGroups) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path file = data / "dicom" / "pydicom-data-selected" / "eCT_Supplemental.dcm";
  const ImportResult r = import_volume(file, quiet());
  const auto& img = *r.image;
  EXPECT_TRUE(r.report.series.enhanced_multiframe);
  EXPECT_EQ(img.GetLargestPossibleRegion().GetSize()[2], 2u);
  EXPECT_NEAR(img.GetSpacing()[2], 10.0, 1e-6);
  EXPECT_NEAR(img.GetSpacing()[0], 0.388672, 1e-6);
  // Orientation (-1,0,0 / 0,1,0): the normal is -z; slices sorted along it, so the first slice
  // is the frame at z = -149 (the second frame in the file).
  EXPECT_NEAR(img.GetDirection()[0][0], -1.0, 1e-9);
  EXPECT_NEAR(img.GetDirection()[2][2], -1.0, 1e-9);
  EXPECT_NEAR(img.GetOrigin()[2], -149.0, 1e-6);
  EXPECT_EQ(r.report.rescale.source, "Pixel Value Transformation functional group (per frame)");
  EXPECT_DOUBLE_EQ(r.report.rescale.intercept, -1024.0);
  const std::vector<float> frames = decode_dicom_file(file);
  const std::size_t plane = 512 * 512;
  EXPECT_TRUE(std::equal(frames.begin() + plane, frames.end(), img.GetBufferPointer()));
  EXPECT_FLOAT_EQ(r.report.output.min_value, -1024.0f);
}

TEST(DicomSeries, PerFrameRescaleOfAnEnhancedObjectIsAppliedFrameByFrame) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path src = data / "dicom" / "pydicom-data-selected" / "eCT_Supplemental.dcm";
  const fs::path dst = test::scratch_dir("perframe") / "ect.dcm";
  // Give frame 2 its own Pixel Value Transformation (intercept -1000 instead of -1024).
  copy_with_changes(src, dst, [](DcmDataset& ds) {
    DcmItem* frame2 = nullptr;
    ASSERT_TRUE(ds.findAndGetSequenceItem(DCM_PerFrameFunctionalGroupsSequence, frame2, 1).good());
    DcmItem* transform = nullptr;
    ASSERT_TRUE(frame2->findOrCreateSequenceItem(DCM_PixelValueTransformationSequence, transform, 0)
                    .good());
    transform->putAndInsertString(DCM_RescaleIntercept, "-1000");
    transform->putAndInsertString(DCM_RescaleSlope, "1");
    transform->putAndInsertString(DCM_RescaleType, "HU");
  });
  const ImportResult original = import_volume(src, quiet());
  const ImportResult edited = import_volume(dst, quiet());
  EXPECT_TRUE(edited.report.rescale.varies_between_slices);
  const std::size_t plane = 512 * 512;
  // Output slice 0 is file frame 2 (see above): +24 HU; slice 1 (frame 1) unchanged.
  for (std::size_t i = 0; i < plane; i += 997) {
    EXPECT_FLOAT_EQ(edited.image->GetBufferPointer()[i],
                    original.image->GetBufferPointer()[i] + 24);
    EXPECT_FLOAT_EQ(edited.image->GetBufferPointer()[plane + i],
                    original.image->GetBufferPointer()[plane + i]);
  }
}

TEST(DicomSeries, SeveralUsableSeriesNeedASeriesUidAndTheErrorListsThem) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const fs::path dir = data / "dicom" / "mr-fragmented-jpegll-j2k";
  ImportOptions o = quiet();
  o.allow_non_ct = true;
  const std::string m = import_error(dir, o);
  EXPECT_NE(m.find("2 usable series; choose one with --series UID"), std::string::npos) << m;
  EXPECT_NE(m.find("1.3.12.2.1107.5.2.43.67093.30000023011319484937100000296"), std::string::npos);
  EXPECT_NE(m.find("1.3.12.2.1107.5.2.43.67093.30000023011319484937100000491"), std::string::npos);
  o.series_uid = "1.3.12.2.1107.5.2.43.67093.30000023011319484937100000491";
  const ImportResult r = import_volume(dir, o);
  EXPECT_EQ(r.report.series.series_number, "6001");
  EXPECT_EQ(r.image->GetLargestPossibleRegion().GetSize()[2], 3u);
  EXPECT_NE(r.report.output.units.find("not HU"), std::string::npos);
  // Unknown UID: the error lists what there is.
  o.series_uid = "1.2.3";
  const std::string unknown = import_error(dir, o);
  EXPECT_NE(unknown.find("no series with SeriesInstanceUID 1.2.3"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("#5001"), std::string::npos) << unknown;
}

TEST(DicomSeries, NonCtModalitiesNeedToBeAllowed) {
  TSF_SHARED_DATA_OR_SKIP(data);
  const std::string m =
      import_error(data / "dicom" / "mr-fragmented-jpegll-j2k" / "5001_anat-T1w_acq-tfl");
  EXPECT_NE(m.find("modality MR"), std::string::npos) << m;
  EXPECT_NE(m.find("--any-modality"), std::string::npos) << m;
}

}  // namespace
}  // namespace tsf::import
