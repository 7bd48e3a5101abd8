// Same head, other scanner, same model: the bundled cranium stored five other ways — another
// origin, voxel order reversed along i and j (direction cosines to match, as an RAS-ordered file
// would), slices stored top-down (a mirrored frame), half the in-plane resolution, and a voxel
// grid turned 12° about the vertical — each run
// through the unchanged scenes/sinus.yaml with `tsf run --ct`. In patient coordinates (mapped back
// by the known shift), the landmarks must agree within 2 mm, the simulated region (rest surface)
// and the exported final surface within 2 mm, and the removed tissue within 10 % of the canonical
// run (docs/patients.md, "Same head, other scanner").
#include <gtest/gtest.h>

#include <itkImage.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>

#include "support/test_data.h"
#include "support/tsf_process.h"
#include "tsf/import/hu_volume_writer.h"
#include "tsf/import/import_report.h"
#include "tsf/import/volume_file_reader.h"
#include "tsf/imt/surface_ply.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;
using import::HuImage;
using nlohmann::json;

HuImage::Pointer make_image(const HuImage::SizeType& size, const HuImage::SpacingType& spacing,
                            const HuImage::PointType& origin,
                            const HuImage::DirectionType& direction) {
  auto img = HuImage::New();
  HuImage::RegionType region;
  region.SetSize(size);
  img->SetRegions(region);
  img->SetSpacing(spacing);
  img->SetOrigin(origin);
  img->SetDirection(direction);
  img->Allocate();
  img->FillBuffer(-1024.0f);
  return img;
}

/// Trilinear sample of `img` at the LPS point p (-1024 HU outside).
float sample(const HuImage* img, const HuImage::PointType& p) {
  itk::ContinuousIndex<double, 3> c;
  img->TransformPhysicalPointToContinuousIndex(p, c);
  const auto size = img->GetLargestPossibleRegion().GetSize();
  std::array<long, 3> i0{};
  std::array<double, 3> f{};
  for (unsigned a = 0; a < 3; ++a) {
    if (!(c[a] >= 0.0 && c[a] <= double(size[a] - 1))) return -1024.0f;
    i0[a] = std::min(static_cast<long>(std::floor(c[a])), static_cast<long>(size[a]) - 2);
    f[a] = c[a] - double(i0[a]);
  }
  double v = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    HuImage::IndexType idx;
    double w = 1.0;
    for (unsigned a = 0; a < 3; ++a) {
      const bool hi = (corner >> a) & 1;
      idx[a] = i0[a] + hi;
      w *= hi ? f[a] : 1.0 - f[a];
    }
    v += w * double(img->GetPixel(idx));
  }
  return static_cast<float>(v);
}

struct Variant {
  std::string name;
  HuImage::Pointer image;
  std::array<double, 3> shift{0, 0, 0};  ///< LPS translation of the head (mapped back)
};

/// `canon` with its voxel order reversed along the axes in `flip`, its direction cosines and
/// origin changed to match: the same head in patient coordinates.
Variant reversed(const HuImage::Pointer& canon, const std::string& name,
                 const std::array<bool, 3>& flip) {
  const auto size = canon->GetLargestPossibleRegion().GetSize();
  HuImage::DirectionType d = canon->GetDirection();
  HuImage::IndexType far{};
  for (unsigned a = 0; a < 3; ++a) {
    if (!flip[a]) continue;
    for (unsigned r = 0; r < 3; ++r) d[r][a] = -d[r][a];
    far[a] = static_cast<long>(size[a]) - 1;
  }
  HuImage::PointType o;
  canon->TransformIndexToPhysicalPoint(far, o);
  Variant v{name, make_image(size, canon->GetSpacing(), o, d)};
  for (long k = 0; k < long(size[2]); ++k)
    for (long j = 0; j < long(size[1]); ++j)
      for (long i = 0; i < long(size[0]); ++i) {
        HuImage::IndexType from{{i, j, k}};
        for (unsigned a = 0; a < 3; ++a)
          if (flip[a]) from[a] = static_cast<long>(size[a]) - 1 - from[a];
        v.image->SetPixel({{i, j, k}}, canon->GetPixel(from));
      }
  return v;
}

std::vector<Variant> make_variants(const HuImage::Pointer& canon) {
  const auto size = canon->GetLargestPossibleRegion().GetSize();
  const auto spacing = canon->GetSpacing();
  const auto origin = canon->GetOrigin();
  const auto direction = canon->GetDirection();
  std::vector<Variant> out;
  {  // the same voxels, the scanner's origin elsewhere
    Variant v{"shifted", make_image(size, spacing, origin, direction), {37.5, -61.25, 120.0}};
    HuImage::PointType o = origin;
    for (unsigned a = 0; a < 3; ++a) o[a] += v.shift[a];
    v.image->SetOrigin(o);
    std::copy(canon->GetBufferPointer(),
              canon->GetBufferPointer() + canon->GetPixelContainer()->Size(),
              v.image->GetBufferPointer());
    out.push_back(v);
  }
  // Voxel order reversed along i and j (the direction cosines saying so, as an RAS-ordered file),
  // and slices stored from the top down (k reversed: the voxel axes mirror the patient's).
  out.push_back(reversed(canon, "flipped", {true, true, false}));
  out.push_back(reversed(canon, "slices-top-down", {false, false, true}));
  {  // half the in-plane resolution: 2 × 2 voxels averaged
    HuImage::SizeType s = size;
    s[0] /= 2;
    s[1] /= 2;
    HuImage::SpacingType sp = spacing;
    sp[0] *= 2;
    sp[1] *= 2;
    HuImage::PointType o = origin;
    for (unsigned a = 0; a < 2; ++a) o[a] += 0.5 * spacing[a];
    Variant v{"half-resolution", make_image(s, sp, o, direction)};
    for (long k = 0; k < long(s[2]); ++k)
      for (long j = 0; j < long(s[1]); ++j)
        for (long i = 0; i < long(s[0]); ++i) {
          float sum = 0;
          for (long dj = 0; dj < 2; ++dj)
            for (long di = 0; di < 2; ++di) sum += canon->GetPixel({{2 * i + di, 2 * j + dj, k}});
          v.image->SetPixel({{i, j, k}}, sum / 4.0f);
        }
    out.push_back(v);
  }
  {  // the voxel grid turned 12° about the vertical (resampled; the head stays where it is)
    const double a = 12.0 * 3.14159265358979323846 / 180.0;
    HuImage::DirectionType r;
    r.SetIdentity();
    r[0][0] = std::cos(a);
    r[0][1] = -std::sin(a);
    r[1][0] = std::sin(a);
    r[1][1] = std::cos(a);
    // The rotated grid covers the canonical volume's box.
    std::array<double, 3> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (int corner = 0; corner < 8; ++corner) {
      HuImage::IndexType idx;
      for (unsigned ax = 0; ax < 3; ++ax)
        idx[ax] = (corner >> ax) & 1 ? static_cast<long>(size[ax]) - 1 : 0;
      HuImage::PointType p;
      canon->TransformIndexToPhysicalPoint(idx, p);
      for (unsigned ax = 0; ax < 3; ++ax) {  // q = Rᵀ p
        const double q = r[0][ax] * p[0] + r[1][ax] * p[1] + r[2][ax] * p[2];
        lo[ax] = std::min(lo[ax], q);
        hi[ax] = std::max(hi[ax], q);
      }
    }
    HuImage::SizeType s;
    HuImage::PointType o;
    for (unsigned ax = 0; ax < 3; ++ax) {
      s[ax] = static_cast<unsigned long>(std::ceil((hi[ax] - lo[ax]) / spacing[ax])) + 1;
      o[ax] = r[ax][0] * lo[0] + r[ax][1] * lo[1] + r[ax][2] * lo[2];
    }
    Variant v{"rotated-12deg", make_image(s, spacing, o, r)};
    for (long k = 0; k < long(s[2]); ++k)
      for (long j = 0; j < long(s[1]); ++j)
        for (long i = 0; i < long(s[0]); ++i) {
          HuImage::PointType p;
          v.image->TransformIndexToPhysicalPoint({{i, j, k}}, p);
          v.image->SetPixel({{i, j, k}}, sample(canon.GetPointer(), p));
        }
    out.push_back(v);
  }
  return out;
}

struct RunResult {
  std::map<std::string, std::array<double, 3>> landmarks;  ///< LPS, mapped back
  std::array<double, 6> rest_box{}, final_box{};           ///< LPS min, max, mapped back
  double removed_mm3 = 0;
};

std::array<double, 6> ply_box(const fs::path& ply, const std::array<double, 3>& shift) {
  const imt::SurfaceMesh m = imt::read_surface_ply(ply);
  std::array<double, 6> b{1e300, 1e300, 1e300, -1e300, -1e300, -1e300};
  for (const Vec3f& p : m.positions)
    for (int a = 0; a < 3; ++a) {
      b[a] = std::min(b[a], double(p[a]) - shift[a]);
      b[a + 3] = std::max(b[a + 3], double(p[a]) - shift[a]);
    }
  return b;
}

RunResult run_sinus(const fs::path& exe, const fs::path& ct, const fs::path& out,
                    const std::array<double, 3>& shift) {
  const test::ProcessRun r = test::run_tsf(
      exe, "run " + test::shell_quoted(test::source_dir() / "scenes" / "sinus.yaml") + " --ct " +
               test::shell_quoted(ct) + " -q --backend cpu --force -o " + test::shell_quoted(out));
  EXPECT_EQ(r.status, 0) << ct << ":\n" << r.output;
  RunResult res;
  const json seg = json::parse(test::read_text(out / "sinus-report.json"));
  for (const json& l : seg["anatomy"]["landmarks"]) {
    if (!l.value("found", false)) continue;
    std::array<double, 3> p{};
    for (int a = 0; a < 3; ++a) p[a] = l["position_mm"][a].get<double>() - shift[a];
    res.landmarks[l["name"].get<std::string>()] = p;
  }
  const json run = json::parse(test::read_text(out / "run-report.json"));
  res.removed_mm3 = run["interaction"]["totals"]["removed_mm3"].get<double>();
  res.rest_box = ply_box(out / "sinus-rest.ply", shift);
  res.final_box = ply_box(out / "sinus-final.ply", shift);
  return res;
}

TEST(PatientVariants, SameHeadOtherScannerGivesTheSameModel) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  const fs::path dir = test::scratch_dir("patient-variants");
  const fs::path canon_path = test::samples_dir() / "ct-head-cranium" / "cranium.nrrd";
  import::ImportOptions options;
  options.show_progress = false;
  import::ImportReport report;
  const HuImage::Pointer canon = import::read_volume_file(canon_path, options, report);
  const RunResult ref = run_sinus(exe, canon_path, dir / "canonical", {0, 0, 0});
  ASSERT_TRUE(ref.landmarks.count("nose-tip"));
  ASSERT_GT(ref.removed_mm3, 100.0);
  std::printf(
      "| variant | landmarks, worst (mm) | rest surface box, worst side (mm) | final "
      "surface box, worst side (mm) | removed mm³ (canonical %.0f) |\n| --- | --- | --- "
      "| --- | --- |\n",
      ref.removed_mm3);
  for (const Variant& v : make_variants(canon)) {
    SCOPED_TRACE(v.name);
    const fs::path ct = dir / (v.name + ".nrrd");
    import::write_hu_volume(ct, *v.image);
    const RunResult got = run_sinus(exe, ct, dir / v.name, v.shift);
    double worst_landmark = 0, worst_rest = 0, worst_final = 0;
    for (const char* name : {"nose-tip", "nostril-left", "nostril-right"}) {
      ASSERT_TRUE(got.landmarks.count(name)) << name;
      double d2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double d = got.landmarks.at(name)[a] - ref.landmarks.at(name)[a];
        d2 += d * d;
      }
      EXPECT_LE(std::sqrt(d2), 2.0) << name << " moved";
      worst_landmark = std::max(worst_landmark, std::sqrt(d2));
    }
    for (int a = 0; a < 6; ++a) {
      EXPECT_NEAR(got.rest_box[a], ref.rest_box[a], 2.0) << "rest surface box, entry " << a;
      EXPECT_NEAR(got.final_box[a], ref.final_box[a], 2.0) << "final surface box, entry " << a;
      worst_rest = std::max(worst_rest, std::abs(got.rest_box[a] - ref.rest_box[a]));
      worst_final = std::max(worst_final, std::abs(got.final_box[a] - ref.final_box[a]));
    }
    EXPECT_NEAR(got.removed_mm3, ref.removed_mm3, 0.1 * ref.removed_mm3) << "removed tissue";
    // The table of docs/patients.md ("Same head, other scanner").
    std::printf("| %s | %.2f | %.2f | %.2f | %.0f (%+.1f %%) |\n", v.name.c_str(), worst_landmark,
                worst_rest, worst_final, got.removed_mm3,
                100.0 * (got.removed_mm3 - ref.removed_mm3) / ref.removed_mm3);
  }
}

}  // namespace
}  // namespace tsf
