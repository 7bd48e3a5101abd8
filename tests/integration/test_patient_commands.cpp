// A new patient's CT through the executable (docs/patients.md): `tsf info` describes the bundled
// cranium NRRD (no patient frame recorded) and the bundled GE DICOM series (tilted, uneven
// slices); a folder of two series is listed, `tsf run --ct FOLDER` asks for a series by both
// ways of choosing one and `--series UID` gets past the choice; a scene whose crop misses the CT
// fails in under a second with the CT's extent, before anything is segmented;
// `pipeline.source.series` is read strictly; the import's warnings reach the segment report and
// the run report (JSON and Markdown).
#include <gtest/gtest.h>

#include <dcmtk/dcmdata/dctk.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "support/test_data.h"
#include "support/tsf_process.h"
#include "tsf/common/cuda_support.h"

namespace tsf {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::read_text;
using test::shell_quoted;

fs::path cranium() {
  return test::samples_dir() / "ct-head-cranium" / "cranium.nrrd";
}

fs::path ge_series() {
  return test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
}

fs::path sinus_ci() {
  return test::source_dir() / "scenes" / "sinus-ci.yaml";
}

/// sinus-ci.yaml's crop, placed around the nose tip; the checks before segmenting test absolute
/// millimetres, so the copies below put the sample cranium's box in its place.
const std::string kAnatomyCrop =
    "crop: {center: {landmark: nose-tip, offset_mm: {posterior: 25, superior: 5}}, size_mm: [50, "
    "56, 60]}";
const std::string kCraniumCrop = "crop: {min: [98, 180, 10], max: [148, 236, 70]}";

#define SAMPLE_OR_SKIP(path)                                               \
  if (!fs::exists(path))                                                   \
  GTEST_SKIP() << "not run: " << (path)                                    \
               << " is missing (data-samples/README.md lists the bundled " \
                  "data)"

bool contains(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

std::string joined(const json& strings) {
  std::string all;
  for (const auto& s : strings) all += s.get<std::string>() + "\n";
  return all;
}

/// The sinus CI scene with its CT given as an absolute path and `edits` applied (each a
/// from → to replacement of one piece of text), written to `dir/name.yaml`.
fs::path scene_copy(const fs::path& dir, const std::string& name,
                    std::vector<std::pair<std::string, std::string>> edits) {
  std::string text = read_text(sinus_ci());
  edits.insert(edits.begin(),
               {"ct: ../data-samples/ct-head-cranium/cranium.nrrd", "ct: " + cranium().string()});
  for (const auto& [from, to] : edits) {
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
  }
  const fs::path path = dir / (name + ".yaml");
  std::ofstream(path) << text;
  return path;
}

TEST(PatientInfo, CraniumNrrdHasGeometryAndSaysLeftRightIsNotRecorded) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  SAMPLE_OR_SKIP(cranium());
  const test::ProcessRun r = test::run_tsf(exe, "info " + shell_quoted(cranium()) + " --json");
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = json::parse(r.output);
  EXPECT_EQ(j["format"], "nrrd");
  const json& v = j["volume"];
  EXPECT_EQ(v["dims"], json::array({256, 256, 108}));
  EXPECT_NEAR(v["spacing_mm"][0].get<double>(), 0.957, 1e-3);
  EXPECT_NEAR(v["spacing_mm"][2].get<double>(), 1.5, 1e-6);
  EXPECT_FALSE(v["orientation_recorded"].get<bool>());
  EXPECT_TRUE(v["orientation"].is_null());
  EXPECT_TRUE(contains(v["orientation_note"].get<std::string>(), "left/right not recorded"));
  // Voxel centres from the origin (0) to (n-1)·spacing.
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(v["extent_lps_mm"]["min"][a].get<double>(), 0.0, 1e-6);
    EXPECT_NEAR(v["extent_lps_mm"]["max"][a].get<double>(),
                (v["dims"][a].get<int>() - 1) * v["spacing_mm"][a].get<double>(), 1e-6);
  }
  EXPECT_LT(v["value_range"][0].get<double>(), -900.0);  // air
  EXPECT_GT(v["value_range"][1].get<double>(), 1000.0);  // bone
  EXPECT_TRUE(contains(joined(j["warnings"]), "space")) << j["warnings"];

  const test::ProcessRun text = test::run_tsf(exe, "info " + shell_quoted(cranium()));
  ASSERT_EQ(text.status, 0) << text.output;
  for (const char* line : {"dimensions   256 × 256 × 108", "unknown — left/right not recorded",
                           "extent       x 0.0 .. 244.0", "patient LPS", "warnings     1"})
    EXPECT_TRUE(contains(text.output, line)) << line << " in\n" << text.output;
}

TEST(PatientInfo, GeDicomSeriesIsListedWithItsResampledGeometryAndWarnings) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  SAMPLE_OR_SKIP(ge_series() / "01.dcm");
  const test::ProcessRun r = test::run_tsf(exe, "info " + shell_quoted(ge_series()) + " --json");
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = json::parse(r.output);
  EXPECT_EQ(j["format"], "dicom");
  ASSERT_EQ(j["series"].size(), 1u) << j["series"];
  const json& s = j["series"][0];
  EXPECT_EQ(s["modality"], "CT");
  EXPECT_EQ(s["slices"], 28);
  EXPECT_TRUE(s["usable"].get<bool>());
  EXPECT_EQ(j["chosen_series"], s["series_instance_uid"]);
  const json& v = j["volume"];
  EXPECT_TRUE(v["orientation_recorded"].get<bool>());
  const std::string code = v["orientation"].get<std::string>();
  EXPECT_EQ(code.size(), 3u);
  EXPECT_EQ(code, "LPS") << "an axial head scan: i toward the left, j posterior, k superior";
  EXPECT_EQ(v["dims"][0], 512);
  EXPECT_NEAR(v["spacing_mm"][0].get<double>(), 0.488, 1e-3);
  for (int a = 0; a < 3; ++a) {
    const double lo = v["extent_lps_mm"]["min"][a].get<double>();
    const double hi = v["extent_lps_mm"]["max"][a].get<double>();
    EXPECT_TRUE(std::isfinite(lo) && std::isfinite(hi) && lo < hi) << a;
    EXPECT_GT(hi - lo, 50.0) << "a head is wider than 5 cm on axis " << a;
    EXPECT_LT(hi - lo, 400.0) << a;
  }
  // x spans the 512 columns of 0.488 mm from ImagePositionPatient -125 mm.
  EXPECT_NEAR(v["extent_lps_mm"]["min"][0].get<double>(), -125.0, 0.01);
  EXPECT_NEAR(v["extent_lps_mm"]["max"][0].get<double>(), -125.0 + 511 * 0.48828125, 0.01);
  EXPECT_TRUE(v["resampled"].get<bool>());
  const std::string warnings = joined(j["warnings"]);
  EXPECT_TRUE(contains(warnings, "gantry tilt")) << warnings;
  EXPECT_TRUE(contains(warnings, "uneven slice spacing")) << warnings;

  const test::ProcessRun text = test::run_tsf(exe, "info " + shell_quoted(ge_series()));
  ASSERT_EQ(text.status, 0) << text.output;
  for (const char* line : {"1 image series (1 usable)", "orientation  LPS", "extent       x -125.0",
                           "resampled", "gantry tilt"})
    EXPECT_TRUE(contains(text.output, line)) << line << " in\n" << text.output;
}

/// A folder holding the GE series twice: the files as they are, and copies with another
/// SeriesInstanceUID (and SOP instance UIDs, description, number), written with DCMTK. Returns
/// the two UIDs (original first).
std::pair<std::string, std::string> make_two_series_folder(const fs::path& dir) {
  fs::create_directories(dir / "a");
  fs::create_directories(dir / "b");
  std::string original, copy;
  for (const auto& entry : fs::directory_iterator(ge_series())) {
    if (entry.path().extension() != ".dcm") continue;
    fs::copy_file(entry.path(), dir / "a" / entry.path().filename());
    DcmFileFormat file;
    EXPECT_TRUE(file.loadFile(entry.path().c_str()).good()) << entry.path();
    DcmDataset* d = file.getDataset();
    OFString uid, sop;
    d->findAndGetOFString(DCM_SeriesInstanceUID, uid);
    d->findAndGetOFString(DCM_SOPInstanceUID, sop);
    original = uid.c_str();
    copy = original.size() <= 62 ? original + ".2" : original.substr(0, 60) + ".2";
    const std::string new_sop = sop.size() <= 62 ? std::string(sop.c_str()) + ".2" : sop.c_str();
    d->putAndInsertString(DCM_SeriesInstanceUID, copy.c_str());
    d->putAndInsertString(DCM_SOPInstanceUID, new_sop.c_str());
    d->putAndInsertString(DCM_SeriesDescription, "copy for tsf tests");
    d->putAndInsertString(DCM_SeriesNumber, "3");
    file.getMetaInfo()->putAndInsertString(DCM_MediaStorageSOPInstanceUID, new_sop.c_str());
    const fs::path out = dir / "b" / entry.path().filename();
    EXPECT_TRUE(file.saveFile(out.c_str(), EXS_LittleEndianExplicit).good()) << out;
  }
  return {original, copy};
}

TEST(PatientCommands, TwoSeriesFolderIsListedAndRunAsksForOneSeries) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  SAMPLE_OR_SKIP(ge_series() / "01.dcm");
  const fs::path dir = test::scratch_dir("patient-two-series");
  const fs::path folder = dir / "scans";
  const auto [uid_a, uid_b] = make_two_series_folder(folder);
  ASSERT_FALSE(uid_a.empty());
  ASSERT_NE(uid_a, uid_b);

  // tsf info lists both and says how to pick one.
  const test::ProcessRun info = test::run_tsf(exe, "info " + shell_quoted(folder) + " --json");
  ASSERT_EQ(info.status, 0) << info.output;
  const json j = json::parse(info.output);
  ASSERT_EQ(j["series"].size(), 2u) << j["series"];
  std::string uids;
  for (const auto& s : j["series"]) uids += s["series_instance_uid"].get<std::string>() + " ";
  EXPECT_TRUE(contains(uids, uid_a + " ") && contains(uids, uid_b + " ")) << uids;
  EXPECT_TRUE(j["chosen_series"].is_null());
  EXPECT_TRUE(j["volume"].is_null());
  EXPECT_TRUE(contains(j["choose"].get<std::string>(), "--series UID")) << j["choose"];
  const test::ProcessRun listed = test::run_tsf(exe, "info " + shell_quoted(folder));
  ASSERT_EQ(listed.status, 0) << listed.output;
  EXPECT_TRUE(contains(listed.output, uid_a) && contains(listed.output, uid_b)) << listed.output;
  EXPECT_TRUE(contains(listed.output, "--series UID")) << listed.output;

  // With --series, info describes that one.
  const test::ProcessRun one =
      test::run_tsf(exe, "info " + shell_quoted(folder) + " --series " + uid_b + " --json");
  ASSERT_EQ(one.status, 0) << one.output;
  EXPECT_EQ(json::parse(one.output)["chosen_series"], uid_b);

  // tsf run on the folder without a series names both ways to choose one, before any work.
  const test::ProcessRun run =
      test::run_tsf(exe, "run " + shell_quoted(sinus_ci()) + " -q --backend cpu --ct " +
                             shell_quoted(folder) + " -o " + shell_quoted(dir / "out"));
  EXPECT_NE(run.status, 0) << run.output;
  EXPECT_TRUE(contains(run.output, "--series UID")) << run.output;
  EXPECT_TRUE(contains(run.output, "pipeline.source.series")) << run.output;
  EXPECT_TRUE(contains(run.output, uid_a) && contains(run.output, uid_b)) << run.output;
  EXPECT_FALSE(fs::exists(dir / "out" / "sinus-ci-density.nrrd"));

  // With --series it gets past the choice: a crop in the sample cranium's millimetres then
  // misses this head, which the check says with the CT's extent, still before segmenting.
  const fs::path absolute = scene_copy(dir, "absolute-crop", {{kAnatomyCrop, kCraniumCrop}});
  const test::ProcessRun chosen = test::run_tsf(
      exe, "run " + shell_quoted(absolute) + " -q --backend cpu --ct " + shell_quoted(folder) +
               " --series " + uid_a + " -o " + shell_quoted(dir / "out2"));
  EXPECT_FALSE(contains(chosen.output, "usable DICOM series")) << chosen.output;
  EXPECT_NE(chosen.status, 0) << chosen.output;
  EXPECT_TRUE(contains(chosen.output, "lattice.crop")) << chosen.output;
  EXPECT_TRUE(contains(chosen.output, uid_a)) << chosen.output;
  EXPECT_FALSE(fs::exists(dir / "out2" / "absolute-crop-density.nrrd"));

  // An unknown UID is refused naming --series and listing what is there.
  const test::ProcessRun unknown =
      test::run_tsf(exe, "run " + shell_quoted(sinus_ci()) + " -q --ct " + shell_quoted(folder) +
                             " --series 1.2.3.4 -o " + shell_quoted(dir / "out3"));
  EXPECT_NE(unknown.status, 0);
  EXPECT_TRUE(contains(unknown.output, "--series: no series with SeriesInstanceUID 1.2.3.4"))
      << unknown.output;
}

TEST(PatientCommands, ACropThatMissesTheCtFailsInUnderASecondWithTheExtent) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  SAMPLE_OR_SKIP(cranium());
  const fs::path dir = test::scratch_dir("patient-crop-misses");
  const fs::path scene = scene_copy(
      dir, "crop-misses", {{kAnatomyCrop, "crop: {min: [400, 180, 10], max: [450, 236, 70]}"}});
  const auto start = std::chrono::steady_clock::now();
  const test::ProcessRun r =
      test::run_tsf(exe, "run " + shell_quoted(scene) + " -q -o " + shell_quoted(dir / "out"));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_LT(seconds, 1.0) << "the check reads the header only; it took " << seconds << " s";
  EXPECT_TRUE(contains(r.output,
                       "lattice.crop: the box (400.0, 180.0, 10.0) to (450.0, 236.0, "
                       "70.0) mm misses the CT"))
      << r.output;
  EXPECT_TRUE(contains(r.output,
                       "(0.0, 0.0, 0.0) to (244.0, 244.0, 160.5) mm in patient "
                       "coordinates (LPS)"))
      << r.output;
  EXPECT_TRUE(contains(r.output, "Nothing was segmented")) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out" / "crop-misses-density.nrrd"));
}

TEST(PatientInfo, AnatomyOptionFindsTheNoseAndSuggestsTheSinusCrop) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  SAMPLE_OR_SKIP(cranium());
  const test::ProcessRun r =
      test::run_tsf(exe, "info " + shell_quoted(cranium()) + " --anatomy --json");
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = json::parse(r.output);
  const json& a = j["anatomy"];
  EXPECT_FALSE(a["orientation_recorded"].get<bool>());
  EXPECT_DOUBLE_EQ(a["voxel_mm"].get<double>(), 2.0);
  const json& tip = a["landmarks"][0];
  EXPECT_EQ(tip["name"], "nose-tip");
  ASSERT_TRUE(tip["found"].get<bool>()) << tip;
  EXPECT_NEAR(tip["position_mm"][1].get<double>(), 232.0, 3.0);  // the face is toward +y
  // The sinus scenes' crop around it: 50 mm wide, reaching from just in front of the tip back.
  const json& crop = a["suggested_crop"];
  ASSERT_FALSE(crop.is_null());
  EXPECT_NEAR(crop["max_mm"][0].get<double>() - crop["min_mm"][0].get<double>(), 50.0, 0.5);
  EXPECT_NEAR(crop["max_mm"][1].get<double>(), tip["position_mm"][1].get<double>() + 3.0, 0.5);
  // The text form says left/right is unknown.
  const test::ProcessRun t = test::run_tsf(exe, "info " + shell_quoted(cranium()) + " --anatomy");
  ASSERT_EQ(t.status, 0) << t.output;
  EXPECT_TRUE(contains(t.output, "LEFT/RIGHT UNKNOWN")) << t.output;
  EXPECT_TRUE(contains(t.output, "suggested    the sinus scenes' crop")) << t.output;
}

TEST(PatientCommands, CudaWhereItCannotRunIsRefusedBeforeSegmenting) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  SAMPLE_OR_SKIP(cranium());
  if (cuda_status().available)
    GTEST_SKIP() << "not run: CUDA is usable here, so --backend cuda is not refused";
  const fs::path dir = test::scratch_dir("patient-cuda-refused");
  const auto start = std::chrono::steady_clock::now();
  const test::ProcessRun r =
      test::run_tsf(exe, "run " + shell_quoted(sinus_ci()) + " -q --backend cuda -o " +
                             shell_quoted(dir / "out"));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "--backend: cuda was asked for, but CUDA is not usable here"))
      << r.output;
  EXPECT_TRUE(contains(r.output, "Nothing was segmented")) << r.output;
  EXPECT_LT(seconds, 1.0);
  EXPECT_FALSE(fs::exists(dir / "out" / "sinus-ci-density.nrrd"));
}

TEST(PatientCommandsRobustness, PipelineSourceSeriesIsReadStrictly) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  SAMPLE_OR_SKIP(cranium());
  const fs::path dir = test::scratch_dir("patient-series-key");
  struct Case {
    std::string name, series_text, expected;
  };
  const Case cases[] = {
      {"letters", "series: abc",
       "pipeline.source.series: expected a DICOM SeriesInstanceUID (digits and dots"},
      {"double-dot", "series: \"1..2\"", "pipeline.source.series: expected a DICOM"},
      {"list", "series: [1, 2]", "pipeline.source.series: expected a text value"},
      {"empty",
       "series:", "pipeline.source.series: expected a DICOM SeriesInstanceUID, got nothing"},
      {"typo", "serie: 1.2.3", "pipeline.source.serie: unknown key"},
      // A well-formed UID with a volume file: refused before anything is read.
      {"volume-file", "series: 1.2.840.113619.2.55.3",
       "pipeline.source.series: a series UID (1.2.840.113619.2.55.3) was given but"},
  };
  for (const Case& c : cases) {
    const fs::path scene = scene_copy(
        dir, c.name,
        {{"ct: " + cranium().string(), "ct: " + cranium().string() + "\n    " + c.series_text}});
    const test::ProcessRun r =
        test::run_tsf(exe, "run " + shell_quoted(scene) + " -q -o " + shell_quoted(dir / c.name));
    EXPECT_NE(r.status, 0) << c.name << ": " << r.output;
    EXPECT_TRUE(contains(r.output, c.expected))
        << c.name << ": expected '" << c.expected << "' in:\n"
        << r.output;
  }
}

TEST(PatientCommands, ImportWarningsReachTheSegmentAndRunReports) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  SAMPLE_OR_SKIP(cranium());
  const fs::path dir = test::scratch_dir("patient-warnings");
  // The cranium NRRD records no patient frame: the import says so. The ball's press, moved far
  // from the tissue, is warned about before segmenting.
  const fs::path scene = scene_copy(dir, "warned",
                                    {{kAnatomyCrop, kCraniumCrop},
                                     {"position: {landmark: nose-tip, offset_mm: {left: 8.5, "
                                      "posterior: 11, inferior: 1}}",
                                      "position: [600, 600, 600]"},
                                     {"position: {landmark: nose-tip, offset_mm: {left: 6, "
                                      "posterior: 11, inferior: 1}}",
                                      "position: [601, 600, 600]"},
                                     {"position: {landmark: nose-tip, offset_mm: {left: 12.5, "
                                      "posterior: 11, inferior: 1}}",
                                      "position: [602, 600, 600]"}});
  const test::ProcessRun r =
      test::run_tsf(exe, "run " + shell_quoted(scene) + " -q --backend cpu --duration 0.004 -o " +
                             shell_quoted(dir / "out"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "tool 'ball' never comes near the tissue")) << r.output;

  const json seg = json::parse(read_text(dir / "out" / "sinus-ci-report.json"));
  EXPECT_TRUE(contains(joined(seg["warnings"]), "no 'space'")) << seg["warnings"];

  const json run = json::parse(read_text(dir / "out" / "run-report.json"));
  const std::string warnings = joined(run["warnings"]);
  EXPECT_TRUE(contains(warnings, "import: the NRRD header has no 'space'")) << warnings;
  EXPECT_TRUE(contains(warnings, "scene: the trajectory of tool 'ball' never comes near"))
      << warnings;
  EXPECT_EQ(run["ct"]["dims"], json::array({256, 256, 108}));
  EXPECT_FALSE(run["ct"]["orientation_recorded"].get<bool>());

  const std::string md = read_text(dir / "out" / "run-report.md");
  const auto warnings_at = md.find("## Warnings");
  ASSERT_NE(warnings_at, std::string::npos) << md;
  EXPECT_LT(warnings_at, md.find("## Time per stage")) << "warnings come near the top";
  EXPECT_TRUE(contains(md, "- import: the NRRD header has no 'space'")) << md;
}

TEST(PatientCommands, SegmentTakesASeriesAndReportsTheImportWarnings) {
  TSF_EXECUTABLE_OR_SKIP(exe);
  SAMPLE_OR_SKIP(ge_series() / "01.dcm");
  const fs::path dir = test::scratch_dir("patient-segment-ge");
  const test::ProcessRun r = test::run_tsf(
      exe, "segment " + shell_quoted(ge_series()) +
               " --preset head-bone --voxel-mm 3 --no-preview -q -o " + shell_quoted(dir / "ge"));
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_TRUE(contains(r.output, "tsf segment: warning: gantry tilt")) << r.output;
  const json seg = json::parse(read_text(dir / "ge-report.json"));
  const std::string warnings = joined(seg["warnings"]);
  EXPECT_TRUE(contains(warnings, "gantry tilt")) << warnings;
  EXPECT_TRUE(contains(warnings, "uneven slice spacing")) << warnings;
  EXPECT_EQ(seg["input"]["kind"], "dicom");
  EXPECT_FALSE(seg["input"]["series_instance_uid"].get<std::string>().empty());
}

}  // namespace
}  // namespace tsf
