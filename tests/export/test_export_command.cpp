// `tsf export` as a process: volume and mesh sequence inputs, the patient frame end to end from a
// NRRD with an oblique direction, --stats, and errors that say why and leave no file.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <fstream>

#include "export_test_helpers.h"
#include "support/tsf_process.h"
#include "tsf/io/mesh_sequence.h"

namespace tsf::exporter {
namespace {
using namespace test;
using ::tsf::test::ProcessRun;
using ::tsf::test::run_tsf;
using ::tsf::test::shell_quoted;

/// PREFIX-density.nrrd and PREFIX-labels.nrrd of a sphere in the oblique frame (raw NRRD).
void write_sphere_volume(const fs::path& prefix, const VolumeGeometry& g, double radius) {
  const Vec3d centre = g.index_to_tissue({9.5, 9.5, 9.5});
  const VoxelVolume v = make_sdf_volume(
      g, [&](const Vec3d& p) { return length(p - centre) - radius; }, 1.0);
  auto header = [&](const char* type) {
    const auto& d = g.direction;
    char text[1024];
    std::snprintf(text, sizeof(text),
                  "NRRD0004\ntype: %s\ndimension: 3\nspace: left-posterior-superior\n"
                  "sizes: %d %d %d\nspace directions: (%.17g,%.17g,%.17g) (%.17g,%.17g,%.17g) "
                  "(%.17g,%.17g,%.17g)\nkinds: domain domain domain\nendian: little\n"
                  "encoding: raw\nspace origin: (%.17g,%.17g,%.17g)\n\n",
                  type, g.dims.x, g.dims.y, g.dims.z, d[0] * g.spacing.x, d[3] * g.spacing.x,
                  d[6] * g.spacing.x, d[1] * g.spacing.y, d[4] * g.spacing.y, d[7] * g.spacing.y,
                  d[2] * g.spacing.z, d[5] * g.spacing.z, d[8] * g.spacing.z, g.origin.x,
                  g.origin.y, g.origin.z);
    return std::string(text);
  };
  std::ofstream density(prefix.string() + "-density.nrrd", std::ios::binary);
  density << header("float");
  density.write(reinterpret_cast<const char*>(v.density_data().data()),
                static_cast<std::streamsize>(v.density_data().size() * sizeof(float)));
  std::vector<std::uint8_t> labels = v.label_data();
  for (int k = 10; k < g.dims.z; ++k)
    for (int j = 0; j < g.dims.y; ++j)
      for (int i = 0; i < g.dims.x; ++i)
        if (labels[v.index(i, j, k)] != kLabelOutside) labels[v.index(i, j, k)] = kLabelMucosa;
  std::ofstream label_file(prefix.string() + "-labels.nrrd", std::ios::binary);
  label_file << header("uchar");
  label_file.write(reinterpret_cast<const char*>(labels.data()),
                   static_cast<std::streamsize>(labels.size()));
}

TEST(ExportCommand, HelpListsFormatsAndFrames) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const ProcessRun r = run_tsf(tsf, "export --help");
  EXPECT_EQ(r.status, 0) << r.output;
  for (const char* word : {"--format", "--split-labels", "--units", "--frames", "glb", "fbx-ascii",
                           "y-up", "STEM-KKKK"})
    EXPECT_NE(r.output.find(word), std::string::npos) << word;
}

TEST(ExportCommand, VolumeLandsInThePatientFrame) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const fs::path dir = tsf::test::scratch_dir("command");
  const VolumeGeometry g = oblique_geometry();
  write_sphere_volume(dir / "sphere", g, 5.5);
  const ProcessRun r = run_tsf(tsf, "export " + shell_quoted(dir / "sphere-density.nrrd") + " -o " +
                                        shell_quoted(dir / "out.stl") + " --stats");
  if (r.status != 0 && r.output.find("needs ITK") != std::string::npos)
    GTEST_SKIP() << "not run: this build reads no volumes (TSF_WITH_ITK=OFF): " << r.output;
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json stats = nlohmann::json::parse(r.output);
  EXPECT_EQ(stats["input_kind"], "density volume");
  EXPECT_EQ(stats["axes"], "lps");
  EXPECT_EQ(stats["units"], "mm");
  EXPECT_GT(stats["triangles"].get<int>(), 500);

  // STL keeps LPS millimetres: the sphere's centre is where the volume's geometry puts voxel
  // (9.5, 9.5, 9.5) in the scanner's frame, not where it sits in tissue space.
  const Imported got = import_file(dir / "out.stl");
  const Vec3d want = g.index_to_physical({9.5, 9.5, 9.5});
  const Vec3d got_centre = to_double((got.lo + got.hi) * 0.5f);
  EXPECT_LT(length(got_centre - want), 0.3)
      << "centre " << got_centre.x << " " << got_centre.y << " " << got_centre.z;
  EXPECT_GT(length(g.index_to_tissue({9.5, 9.5, 9.5}) - want), 3.0)
      << "the test frame must differ from tissue space to mean anything";

  // Labels came along: per-tissue meshes in an OBJ.
  const ProcessRun split =
      run_tsf(tsf, "export " + shell_quoted(dir / "sphere-density.nrrd") + " -o " +
                       shell_quoted(dir / "split.obj") + " --split-labels");
  ASSERT_EQ(split.status, 0) << split.output;
  const Imported parts = import_file(dir / "split.obj");
  EXPECT_EQ(parts.meshes, 2u) << "soft tissue and mucosa";
}

TEST(ExportCommand, SequenceExportsFramesAndAnimation) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const fs::path dir = tsf::test::scratch_dir("command");
  io::MeshSequence s;
  s.geometry = oblique_geometry();
  s.rest = labelled_sphere(s.geometry);
  for (int f = 1; f <= 2; ++f) {
    io::MeshFrame frame;
    frame.time_s = 0.1 * f;
    for (const Vec3f& p : s.rest.positions) frame.positions.push_back(p * (1.0f + 0.05f * f));
    s.frames.push_back(frame);
  }
  io::write_mesh_sequence(dir / "state.tsfmesh", s);
  const ProcessRun r =
      run_tsf(tsf, "export " + shell_quoted(dir / "state.tsfmesh") + " -o " +
                       shell_quoted(dir / "out" / "t.glb") + " --frames all --stats");
  ASSERT_EQ(r.status, 0) << r.output;
  const nlohmann::json stats = nlohmann::json::parse(r.output);
  EXPECT_EQ(stats["input_kind"], "mesh sequence");
  EXPECT_TRUE(stats["animated"].get<bool>());
  EXPECT_EQ(stats["files"].size(), 4u);
  EXPECT_EQ(files_in(dir / "out"),
            (std::vector<std::string>{"t-0000.glb", "t-0001.glb", "t-0002.glb", "t.glb"}));

  const ProcessRun last = run_tsf(tsf, "export " + shell_quoted(dir / "state.tsfmesh") + " -o " +
                                           shell_quoted(dir / "last.ply"));
  ASSERT_EQ(last.status, 0) << last.output;
  EXPECT_NE(last.output.find("state 2"), std::string::npos) << last.output;
}

TEST(ExportCommand, ErrorsSayWhyAndLeaveNothing) {
  TSF_EXECUTABLE_OR_SKIP(tsf);
  const fs::path dir = tsf::test::scratch_dir("command");
  io::MeshSequence s;
  s.geometry = oblique_geometry();
  s.rest = labelled_sphere(s.geometry);
  io::write_mesh_sequence(dir / "state.tsfmesh", s);
  const std::string in = "export " + shell_quoted(dir / "state.tsfmesh");
  const fs::path out = dir / "out";
  struct Bad {
    std::string args, says;
  };
  for (const Bad& b :
       {Bad{" -o " + shell_quoted(out / "x.dae"), "unknown extension '.dae'"},
        Bad{" -o " + shell_quoted(out / "x.glb") + " --units mm", "metres"},
        Bad{" -o " + shell_quoted(out / "x.glb") + " --format obj", "writes '.obj'"},
        Bad{" -o " + shell_quoted(out / "x.stl") + " --split-labels", "--split-labels"},
        Bad{" -o " + shell_quoted(out / "x.glb") + " --frames 3", "states 0..0"},
        Bad{" -o " + shell_quoted(out / "x.glb") + " --frames sideways", "--frames"},
        Bad{" -o " + shell_quoted(out / "x.glb") + " --iso 0.4", "--iso"}}) {
    const ProcessRun r = run_tsf(tsf, in + b.args);
    EXPECT_NE(r.status, 0) << b.args;
    EXPECT_NE(r.output.find(b.says), std::string::npos) << b.args << ": " << r.output;
    EXPECT_FALSE(fs::exists(out) && !fs::is_empty(out)) << b.args << " left files behind";
  }
  std::ofstream(dir / "corrupt.tsfmesh", std::ios::binary) << "\x89TSFM\r\n\x1a"
                                                           << "garbage";
  const ProcessRun corrupt = run_tsf(tsf, "export " + shell_quoted(dir / "corrupt.tsfmesh") +
                                              " -o " + shell_quoted(out / "c.glb"));
  EXPECT_NE(corrupt.status, 0);
  EXPECT_NE(corrupt.output.find("corrupt.tsfmesh"), std::string::npos) << corrupt.output;
}

}  // namespace
}  // namespace tsf::exporter
