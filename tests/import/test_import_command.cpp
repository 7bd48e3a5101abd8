// The `tsf import` command (run as a process when the app is built) and privacy: no patient
// name, ID or birth date in any output file, listing or log.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "dicom_test_files.h"
#include "support/test_data.h"
#include "support/tsf_process.h"
#include "tsf/import/hu_volume_writer.h"
#include "tsf/import/import_report_json.h"
#include "tsf/import/import_volume.h"

namespace tsf::import {
namespace {
namespace fs = std::filesystem;
using test::run_tsf;
using test::shell_quoted;

fs::path ge_dir() {
  return test::samples_dir() / "ct-head-ge-hispeed-tilt-varspacing";
}

TEST(ImportCommand, HelpDescribesInputsOutputsAndEveryOption) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const test::ProcessRun r = run_tsf(tsf, "import --help");
  EXPECT_EQ(r.status, 0) << r.output;
  for (const char* word : {"--output", "--list", "--series", "--strict", "--slice-spacing",
                           "--sidecar", "--any-modality", "--max-gvoxels", "DICOMDIR", "NIfTI",
                           "gantry tilt", "int16", "No patient name"})
    EXPECT_NE(r.output.find(word), std::string::npos) << word;
}

TEST(ImportCommand, ListShowsTheSeriesAndWhatWasSkipped) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const test::ProcessRun r = run_tsf(tsf, "import " + shell_quoted(ge_dir()) + " --list");
  EXPECT_EQ(r.status, 0) << r.output;
  for (const char* text :
       {"1.2.826.0.1.3680043.9.4245.3115138630835728997848661150714813892", "modality     CT",
        "28 files, 28 slices", "512 × 512 × 28", "0.488 × 0.488 mm in-plane",
        "slice gaps 4.00 mm ×13, 1.08 mm ×1, 7.00 mm ×13 (uneven)", "18.50° from positions",
        "after resampling", "not DICOM (1): LICENSE-SOURCE.txt"})
    EXPECT_NE(r.output.find(text), std::string::npos) << text << "\n" << r.output;
  const test::ProcessRun j = run_tsf(tsf, "import " + shell_quoted(ge_dir()) + " --list --json");
  EXPECT_EQ(j.status, 0);
  const auto parsed = nlohmann::json::parse(j.output);
  EXPECT_EQ(parsed.at("series").size(), 1u);
  EXPECT_EQ(parsed.at("series")[0].at("slices"), 28);
}

TEST(ImportCommand, WritesTheVolumeAndItsSidecar) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const fs::path dir = test::scratch_dir("cli-write");
  const test::ProcessRun r =
      run_tsf(tsf, "import " + shell_quoted(ge_dir()) + " -o " + shell_quoted(dir / "ge.nrrd"));
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("warning: gantry tilt"), std::string::npos) << r.output;
  ASSERT_TRUE(fs::exists(dir / "ge.nrrd"));
  std::ifstream in(dir / "ge.json");
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j.at("output").at("stored_pixel_type"), "int16");
  EXPECT_EQ(j.at("output").at("file"), (dir / "ge.nrrd").string());
  EXPECT_TRUE(j.at("resampling").at("applied").get<bool>());
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 2) << "the volume and its sidecar, no temporary files";
}

TEST(ImportCommand, ErrorsExitNonZeroAndWriteNothing) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const fs::path dir = test::scratch_dir("cli-errors");
  const test::ProcessRun strict = run_tsf(
      tsf, "import " + shell_quoted(ge_dir()) + " --strict -o " + shell_quoted(dir / "g.nrrd"));
  EXPECT_NE(strict.status, 0);
  EXPECT_NE(strict.output.find("refused (strict)"), std::string::npos) << strict.output;
  const test::ProcessRun no_output = run_tsf(tsf, "import " + shell_quoted(ge_dir()));
  EXPECT_NE(no_output.status, 0);
  EXPECT_NE(no_output.output.find("give -o OUT.nrrd"), std::string::npos) << no_output.output;
  const test::ProcessRun bad_ext =
      run_tsf(tsf, "import " + shell_quoted(ge_dir()) + " -o " + shell_quoted(dir / "g.png"));
  EXPECT_NE(bad_ext.status, 0);
  EXPECT_NE(bad_ext.output.find(".nrrd or .mha"), std::string::npos) << bad_ext.output;
  const test::ProcessRun missing =
      run_tsf(tsf, "import " + shell_quoted(dir / "nothing-here") + " --list");
  EXPECT_NE(missing.status, 0);
  EXPECT_TRUE(fs::is_empty(dir));
}

/// Identifying values of a DICOM file, read with DCMTK: the name (and its components), ID,
/// birth date. Values under 5 characters are left out: they occur by chance in any text
/// (the phantom's ID "0010", a name "HEAD").
std::vector<std::string> identifying_values(const fs::path& file) {
  DcmFileFormat f;
  EXPECT_TRUE(f.loadFile(file.c_str()).good());
  std::vector<std::string> out;
  for (const DcmTagKey& tag : {DCM_PatientName, DCM_PatientID, DCM_PatientBirthDate}) {
    OFString v;
    if (f.getDataset()->findAndGetOFString(tag, v).bad()) continue;
    std::string s = v.c_str();
    while (!s.empty() && s.back() == ' ') s.pop_back();
    if (s.size() >= 5) out.push_back(s);
    std::stringstream parts(s);
    std::string part;
    while (std::getline(parts, part, '^'))
      if (part.size() >= 5 && part != s) out.push_back(part);
  }
  return out;
}

std::string header_text(const fs::path& nrrd) {
  const std::string bytes = test_files::file_bytes(nrrd);
  return bytes.substr(0, bytes.find("\n\n"));
}

void expect_absent(const std::vector<std::string>& values, const std::string& text,
                   const std::string& where) {
  for (const auto& v : values)
    EXPECT_EQ(text.find(v), std::string::npos) << "'" << v << "' in " << where;
}

struct PrivacyCase {
  fs::path input;
  fs::path identified_by;  ///< a DICOM file of the input carrying the identifying values
};

std::vector<PrivacyCase> privacy_cases() {
  std::vector<PrivacyCase> cases{{ge_dir(), ge_dir() / "01.dcm"}};
  if (const auto data = test::shared_data_dir()) {
    const fs::path d = *data / "dicom";
    cases.push_back({d / "pydicom-data-selected" / "eCT_Supplemental.dcm",
                     d / "pydicom-data-selected" / "eCT_Supplemental.dcm"});
    cases.push_back({d / "ct-head-phantom-philips-ingenuity",
                     d / "ct-head-phantom-philips-ingenuity" / "S21570" / "S2010" / "I10"});
    cases.push_back({d / "ct-chest-slice-transfer-syntaxes-cornerstone",
                     d / "ct-chest-slice-transfer-syntaxes-cornerstone" / "CTImage.dcm"});
  }
  return cases;
}

TEST(ImportPrivacy, NoPatientNameIdOrBirthDateInLibraryOutputs) {
  const fs::path dir = test::scratch_dir("privacy-lib");
  int index = 0;
  for (const auto& c : privacy_cases()) {
    const auto values = identifying_values(c.identified_by);
    ASSERT_FALSE(values.empty()) << c.identified_by << ": nothing to look for";
    testing::internal::CaptureStderr();
    testing::internal::CaptureStdout();
    std::string sidecar;
    const fs::path out = dir / ("v" + std::to_string(index++) + ".nrrd");
    try {
      ImportOptions o;
      o.show_progress = false;
      const ImportResult r = import_volume(c.input, o);
      write_hu_volume(out, *r.image, {/*compress=*/false, /*compression_level=*/0});
      sidecar = import_report_to_json(r.report).dump();
    } catch (const std::exception& e) {
      sidecar = e.what();  // an error message is output too
    }
    const std::string logs =
        testing::internal::GetCapturedStderr() + testing::internal::GetCapturedStdout();
    expect_absent(values, sidecar, "the sidecar of " + c.input.string());
    expect_absent(values, logs, "the logs of " + c.input.string());
    if (fs::exists(out)) expect_absent(values, header_text(out), out.string());
  }
}

TEST(ImportPrivacy, NoPatientNameIdOrBirthDateInCommandOutputs) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const fs::path dir = test::scratch_dir("privacy-cli");
  int index = 0;
  for (const auto& c : privacy_cases()) {
    const auto values = identifying_values(c.identified_by);
    const fs::path out = dir / ("v" + std::to_string(index++) + ".nrrd");
    const test::ProcessRun list = run_tsf(tsf, "import " + shell_quoted(c.input) + " --list");
    const test::ProcessRun list_json =
        run_tsf(tsf, "import " + shell_quoted(c.input) + " --list --json");
    const test::ProcessRun import =
        run_tsf(tsf, "import " + shell_quoted(c.input) + " --no-compress -o " + shell_quoted(out));
    expect_absent(values, list.output, "tsf import --list " + c.input.string());
    expect_absent(values, list_json.output, "tsf import --list --json " + c.input.string());
    expect_absent(values, import.output, "tsf import " + c.input.string());
    if (fs::exists(out)) {
      expect_absent(values, header_text(out), out.string());
      fs::path json = out;
      json.replace_extension(".json");
      expect_absent(values, test_files::file_bytes(json), json.string());
    }
  }
}

}  // namespace
}  // namespace tsf::import
