// The bundled GE HiSpeed head series: real DICOM with an 18.5° gantry tilt and uneven spacing
// (4 mm, one 1.08 mm, then 7 mm). Geometry is checked against the headers read independently
// here with DCMTK; anatomy placement against the acquired pixels.
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <gtest/gtest.h>
#include <itkLinearInterpolateImageFunction.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/import/dicom_pixel_reader.h"
#include "tsf/import/import_report_json.h"
#include "tsf/import/import_volume.h"

namespace tsf::import {
namespace {
namespace fs = std::filesystem;

fs::path ge_dir() {
  return test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
}

struct SliceHeader {
  fs::path path;
  Vec3d position, row, column;
  double spacing_rows = 0, spacing_cols = 0;
  int rows = 0, cols = 0;
};

/// IPP/IOP/PixelSpacing/Rows/Columns of every slice, read here with DCMTK (not via tsf).
std::vector<SliceHeader> read_headers() {
  std::vector<SliceHeader> out;
  for (const auto& e : fs::directory_iterator(ge_dir())) {
    if (e.path().extension() != ".dcm") continue;
    DcmFileFormat f;
    EXPECT_TRUE(f.loadFile(e.path().c_str()).good());
    DcmDataset* ds = f.getDataset();
    SliceHeader h;
    h.path = e.path();
    Float64 v = 0;
    for (unsigned long i = 0; i < 3; ++i) {
      ds->findAndGetFloat64(DCM_ImagePositionPatient, v, i);
      h.position[static_cast<int>(i)] = v;
      ds->findAndGetFloat64(DCM_ImageOrientationPatient, v, i);
      h.row[static_cast<int>(i)] = v;
      ds->findAndGetFloat64(DCM_ImageOrientationPatient, v, i + 3);
      h.column[static_cast<int>(i)] = v;
    }
    ds->findAndGetFloat64(DCM_PixelSpacing, h.spacing_rows, 0);
    ds->findAndGetFloat64(DCM_PixelSpacing, h.spacing_cols, 1);
    Uint16 r = 0, c = 0;
    ds->findAndGetUint16(DCM_Rows, r);
    ds->findAndGetUint16(DCM_Columns, c);
    h.rows = r;
    h.cols = c;
    out.push_back(h);
  }
  return out;
}

ImportResult import_ge() {
  ImportOptions o;
  o.show_progress = false;
  return import_volume(ge_dir(), o);
}

Vec3d axis_of(const HuImage& image, int a) {
  return {image.GetDirection()[0][a], image.GetDirection()[1][a], image.GetDirection()[2][a]};
}

TEST(ImportGeSeries, HounsfieldRangeIsPlausible) {
  const ImportResult r = import_ge();
  const HuImage& img = *r.image;
  const std::size_t n = img.GetLargestPossibleRegion().GetNumberOfPixels();
  const float* v = img.GetBufferPointer();
  // Air around the head: the voxels between -1100 and -900 HU cluster around -1000.
  std::vector<float> air;
  std::size_t bone = 0, head = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (v[i] > -1100 && v[i] < -900) air.push_back(v[i]);
    if (v[i] > -300) ++head;
    if (v[i] > 700) ++bone;
  }
  ASSERT_GT(air.size(), n / 20) << "a head CT has plenty of air around the head";
  std::nth_element(air.begin(), air.begin() + air.size() / 2, air.end());
  EXPECT_NEAR(air[air.size() / 2], -1000.0f, 30.0f) << "median air value";
  EXPECT_GT(r.report.output.max_value, 700.0f);
  EXPECT_GT(bone, head / 50) << "skull: a few percent of the head is bone above 700 HU";
  EXPECT_LT(r.report.output.max_value, 4000.0f);
  EXPECT_EQ(r.report.output.units, "HU");
  EXPECT_TRUE(r.report.output.integral_values);
}

TEST(ImportGeSeries, ExtentEqualsWhatTheImagePositionsSpan) {
  const ImportResult r = import_ge();
  const HuImage& img = *r.image;
  const auto headers = read_headers();
  ASSERT_EQ(headers.size(), 28u);
  const auto size = img.GetLargestPossibleRegion().GetSize();
  const Vec3d origin{img.GetOrigin()[0], img.GetOrigin()[1], img.GetOrigin()[2]};
  // Every acquired pixel centre (the corners of every slice) lies inside the volume, and the
  // volume is the tightest box around them: each face touches a corner (within half a voxel).
  for (int a = 0; a < 3; ++a) {
    const Vec3d axis = axis_of(img, a);
    const double extent = (static_cast<double>(size[a]) - 1) * img.GetSpacing()[a];
    double lo = 1e300, hi = -1e300;
    for (const auto& h : headers)
      for (int c = 0; c < 4; ++c) {
        const Vec3d corner = h.position + h.row * (c & 1 ? (h.cols - 1) * h.spacing_cols : 0.0) +
                             h.column * (c & 2 ? (h.rows - 1) * h.spacing_rows : 0.0);
        const double coord = dot(corner - origin, axis);
        lo = std::min(lo, coord);
        hi = std::max(hi, coord);
      }
    EXPECT_NEAR(lo, 0.0, 1e-3) << "axis " << a;
    EXPECT_LE(hi, extent + 1e-3) << "axis " << a;
    EXPECT_GT(hi, extent - img.GetSpacing()[a]) << "axis " << a;
  }
  // Along the table axis (z) the extent is exact: the positions' span plus the tilted image
  // height, with whole slices.
  const Vec3d z = axis_of(img, 2);
  double zmin = 1e300, zmax = -1e300;
  for (const auto& h : headers) {
    zmin = std::min(
        {zmin, dot(h.position, z), dot(h.position + h.column * (h.rows - 1) * h.spacing_rows, z)});
    zmax = std::max(
        {zmax, dot(h.position, z), dot(h.position + h.column * (h.rows - 1) * h.spacing_rows, z)});
  }
  EXPECT_NEAR((static_cast<double>(size[2]) - 1) * img.GetSpacing()[2], zmax - zmin, 1e-3);
  // The direction matrix is orthonormal (voxels are boxes) and z is the table axis.
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      EXPECT_NEAR(dot(axis_of(img, a), axis_of(img, b)), a == b ? 1.0 : 0.0, 1e-9);
  const Vec3d table = normalized_or_zero(headers.back().position - headers.front().position);
  EXPECT_NEAR(std::abs(dot(z, table)), 1.0, 1e-9);
}

TEST(ImportGeSeries, TiltAndUnevenSpacingAreReportedAsTheSidecarSays) {
  const ImportResult r = import_ge();
  const auto j = import_report_to_json(r.report);
  const auto& acq = j.at("acquisition");
  EXPECT_NEAR(acq.at("gantry_tilt_deg").get<double>(), 18.5, 0.05);
  EXPECT_NEAR(acq.at("gantry_tilt_tag_deg").get<double>(), 18.5, 1e-9);
  EXPECT_TRUE(acq.at("gantry_tilted").get<bool>());
  EXPECT_TRUE(acq.at("uneven_spacing").get<bool>());
  const auto& gaps = acq.at("slice_gaps");
  ASSERT_EQ(gaps.size(), 3u);
  EXPECT_NEAR(gaps[0].at("gap_mm").get<double>(), 4.00, 0.01);
  EXPECT_EQ(gaps[0].at("count").get<int>(), 13);
  EXPECT_NEAR(gaps[1].at("gap_mm").get<double>(), 1.08, 0.01);
  EXPECT_EQ(gaps[1].at("count").get<int>(), 1);
  EXPECT_NEAR(gaps[2].at("gap_mm").get<double>(), 7.00, 0.01);
  EXPECT_EQ(gaps[2].at("count").get<int>(), 13);
  EXPECT_TRUE(acq.at("missing_slices").empty()) << "4 mm then 7 mm is a protocol, not a loss";
  EXPECT_NEAR(acq.at("slice_thickness_tag_mm").get<double>(), 4.0, 1e-9);

  const auto& rs = j.at("resampling");
  EXPECT_TRUE(rs.at("applied").get<bool>());
  const std::string reasons = rs.at("reasons").dump();
  EXPECT_NE(reasons.find("gantry tilt"), std::string::npos) << reasons;
  EXPECT_NE(reasons.find("uneven"), std::string::npos) << reasons;
  EXPECT_NE(rs.at("gantry_tilt_resolution").get<std::string>().find("orthogonal grid"),
            std::string::npos);
  // The sidecar's output geometry is the image's.
  const auto& out = j.at("output");
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(out.at("dims")[a].get<int>(),
              static_cast<int>(r.image->GetLargestPossibleRegion().GetSize()[a]));
    EXPECT_NEAR(out.at("spacing_mm")[a].get<double>(), r.image->GetSpacing()[a], 1e-12);
    EXPECT_NEAR(out.at("origin_mm")[a].get<double>(), r.image->GetOrigin()[a], 1e-12);
  }
  const std::string warnings = j.at("warnings").dump();
  EXPECT_NE(warnings.find("4.00 mm ×13, 1.08 mm ×1, 7.00 mm ×13"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("gantry tilt of 18.50°"), std::string::npos) << warnings;
}

TEST(ImportGeSeries, ResampledAnatomySitsWhereThePixelsWereAcquired) {
  // Interpolate the imported volume at acquired pixel centres of several slices and compare
  // with the decoded pixels. A geometry error (ignoring the tilt, a wrong shear direction or
  // slice order) moves bone edges by millimetres and is caught by the control below.
  const ImportResult r = import_ge();
  auto interp = itk::LinearInterpolateImageFunction<HuImage, double>::New();
  interp->SetInputImage(r.image);
  auto compare = [&](const Vec3d& shift) {
    std::vector<double> errors;
    for (const char* name : {"03.dcm", "10.dcm", "20.dcm"}) {
      DicomFileInfo info;
      const std::vector<float> pixels = decode_dicom_file(ge_dir() / name, &info);
      const DicomFrameInfo& f = info.frames[0];
      for (int j = 40; j < info.rows - 40; j += 7)
        for (int i = 40; i < info.columns - 40; i += 7) {
          const Vec3d p = f.position + f.row * (i * f.spacing_between_columns) +
                          f.column * (j * f.spacing_between_rows) + shift;
          HuImage::PointType point;
          for (int a = 0; a < 3; ++a) point[a] = p[a];
          itk::ContinuousIndex<double, 3> index;
          if (!r.image->TransformPhysicalPointToContinuousIndex(point, index) ||
              !interp->IsInsideBuffer(index))
            continue;
          errors.push_back(std::abs(
              interp->EvaluateAtContinuousIndex(index) -
              static_cast<double>(pixels[static_cast<std::size_t>(j) * info.columns + i])));
        }
    }
    std::sort(errors.begin(), errors.end());
    return std::make_pair(errors[errors.size() / 2], errors[errors.size() * 9 / 10]);
  };
  const auto [median, p90] = compare({0, 0, 0});
  EXPECT_LT(median, 15.0) << "median |resampled - acquired| in HU";
  EXPECT_LT(p90, 120.0) << "90th percentile (bone edges)";
  // Control: the same comparison 4 mm off (what ignoring the tilt's shear does at mid-height)
  // must be clearly worse, so the test can fail.
  const auto [median_off, p90_off] = compare({0, 4.0, 0});
  EXPECT_GT(p90_off, 2 * p90);
  EXPECT_GT(median_off, 2 * median);
}

TEST(ImportGeSeries, StrictRefusesTheResamplingWithTheReasons) {
  ImportOptions o;
  o.show_progress = false;
  o.strict = true;
  try {
    import_volume(ge_dir(), o);
    FAIL() << "--strict accepted a tilted, unevenly spaced series";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("strict"), std::string::npos) << m;
    EXPECT_NE(m.find("gantry tilt"), std::string::npos) << m;
    EXPECT_NE(m.find("uneven slice spacing (4.00 mm ×13, 1.08 mm ×1, 7.00 mm ×13)"),
              std::string::npos)
        << m;
  }
}

TEST(ImportGeSeries, ASingleSliceIsNotAVolume) {
  ImportOptions o;
  o.show_progress = false;
  try {
    import_volume(ge_dir() / "05.dcm", o);
    FAIL() << "one slice accepted as a volume";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("at least 2"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tsf::import
