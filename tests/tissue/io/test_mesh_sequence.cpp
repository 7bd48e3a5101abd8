// The mesh sequence file (tsf/io/mesh_sequence.h): round trips, topology changes, atomic writes.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>

#include "mesh_sequence_test_helpers.h"
#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/io/crc32.h"
#include "tsf/io/mesh_sequence.h"

namespace tsf::io {
namespace {
namespace fs = std::filesystem;
using test::read_bytes;
using test::small_sequence;

void expect_same_mesh(const imt::SurfaceMesh& a, const imt::SurfaceMesh& b) {
  EXPECT_EQ(a.positions, b.positions);
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.labels, b.labels);
  EXPECT_EQ(a.triangles, b.triangles);
}

std::size_t files_in(const fs::path& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

TEST(Crc32, MatchesTheStandardCheckValueAndComposes) {
  const char* text = "123456789";
  EXPECT_EQ(crc32(text, 9), 0xCBF43926u);
  EXPECT_EQ(crc32_update(crc32(text, 4), text + 4, 5), 0xCBF43926u);
  EXPECT_EQ(crc32(text, 0), 0u);
}

TEST(MeshSequence, RoundTripKeepsEveryFieldBitForBit) {
  const MeshSequence s = small_sequence();
  ASSERT_GT(s.rest.triangle_count(), 100u);
  const fs::path file = tsf::test::scratch_dir("seq") / "state.tsfmesh";
  write_mesh_sequence(file, s);
  ASSERT_TRUE(is_mesh_sequence_file(file));

  const MeshSequence r = read_mesh_sequence(file);
  EXPECT_EQ(r.geometry.dims, s.geometry.dims);
  EXPECT_EQ(r.geometry.spacing, s.geometry.spacing);
  EXPECT_EQ(r.geometry.origin, s.geometry.origin);
  EXPECT_EQ(r.geometry.direction, s.geometry.direction);
  EXPECT_EQ(r.rest_time_s, s.rest_time_s);
  expect_same_mesh(r.rest, s.rest);
  ASSERT_EQ(r.frames.size(), s.frames.size());
  for (std::size_t f = 0; f < s.frames.size(); ++f) {
    SCOPED_TRACE("frame " + std::to_string(f));
    EXPECT_EQ(r.frames[f].time_s, s.frames[f].time_s);
    EXPECT_EQ(r.frames[f].topology_changed, s.frames[f].topology_changed);
    expect_same_mesh(frame_mesh(r, f), frame_mesh(s, f));
  }
  EXPECT_FALSE(has_constant_topology(r));
}

TEST(MeshSequence, FrameMeshUsesTheTopologyInForce) {
  const MeshSequence s = small_sequence();
  // Frames 0-2 are poses of the rest mesh, frame 3 re-meshes, frame 4 poses the new mesh.
  EXPECT_EQ(frame_mesh(s, 1).triangles, s.rest.triangles);
  EXPECT_EQ(frame_mesh(s, 4).triangles, s.frames[3].triangles);
  EXPECT_EQ(frame_mesh(s, 4).labels, s.frames[3].labels);
  EXPECT_EQ(frame_mesh(s, 4).positions, s.frames[4].positions);
  EXPECT_NE(s.frames[3].triangles.size(), s.rest.triangles.size());
  EXPECT_THROW(frame_mesh(s, 5), Error);
}

TEST(MeshSequence, WriterStoresPosesWithoutTopologyAndDetectsChanges) {
  const MeshSequence s = small_sequence();
  const fs::path dir = tsf::test::scratch_dir("seq");
  const fs::path file = dir / "streamed.tsfmesh";
  {
    MeshSequenceWriter writer(file, s.geometry, s.rest);
    for (std::size_t f = 0; f < s.frames.size(); ++f)
      writer.add_frame(s.frames[f].time_s, frame_mesh(s, f));
    EXPECT_FALSE(fs::exists(file)) << "the file must appear only when finished";
    writer.finish();
    EXPECT_EQ(writer.frame_count(), s.frames.size());
  }
  MeshSequenceReader reader(file);
  MeshFrame frame;
  std::vector<bool> changed;
  while (reader.next_frame(frame)) changed.push_back(frame.topology_changed);
  EXPECT_EQ(changed, (std::vector<bool>{false, false, false, true, false}));
  expect_same_mesh(reader.current_mesh(), frame_mesh(s, 4));

  // A pose record costs positions (+ normals) only: far less than the full mesh.
  const auto pose_bytes = 24 + 24 * s.rest.vertex_count() + 16;
  const auto mesh_bytes = 32 + 25 * s.rest.vertex_count() + 12 * s.rest.triangle_count();
  EXPECT_LT(pose_bytes, mesh_bytes * 7 / 10);
}

TEST(MeshSequence, RestOnlyFileHasNoFrames) {
  MeshSequence s = small_sequence();
  s.frames.clear();
  const fs::path file = tsf::test::scratch_dir("seq") / "rest.tsfmesh";
  write_mesh_sequence(file, s);
  const MeshSequence r = read_mesh_sequence(file);
  EXPECT_TRUE(r.frames.empty());
  EXPECT_TRUE(has_constant_topology(r));
  expect_same_mesh(r.rest, s.rest);
}

TEST(MeshSequence, UnfinishedWriterLeavesNothing) {
  const MeshSequence s = small_sequence();
  const fs::path dir = tsf::test::scratch_dir("seq");
  {
    MeshSequenceWriter writer(dir / "never.tsfmesh", s.geometry, s.rest);
    writer.add_frame(0.5, s.rest);
  }
  EXPECT_EQ(files_in(dir), 0u) << "neither the target nor the temporary may remain";
}

TEST(MeshSequence, WriterRejectsBadFramesAndKeepsTheOldFile) {
  const MeshSequence s = small_sequence();
  const fs::path dir = tsf::test::scratch_dir("seq");
  const fs::path file = dir / "state.tsfmesh";
  write_mesh_sequence(file, s);
  const std::string before = read_bytes(file);
  {
    MeshSequenceWriter writer(file, s.geometry, s.rest, 1.0);
    EXPECT_THROW(writer.add_pose(1.0, s.rest.positions, {}), Error);  // not later than rest
  }
  {
    MeshSequenceWriter writer(file, s.geometry, s.rest);
    std::vector<Vec3f> short_positions(s.rest.positions.begin(), s.rest.positions.end() - 1);
    try {
      writer.add_pose(0.1, short_positions, {});
      FAIL() << "a pose with the wrong vertex count was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("positions for a topology of"), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
  }
  {
    MeshSequenceWriter writer(file, s.geometry, s.rest);
    std::vector<Vec3f> bad = s.rest.positions;
    bad[7].y = std::nanf("");
    EXPECT_THROW(writer.add_pose(0.1, bad, {}), Error);
  }
  EXPECT_EQ(read_bytes(file), before) << "failed writes must not touch the existing file";
  EXPECT_EQ(files_in(dir), 1u) << "no temporaries left behind";
}

TEST(MeshSequence, ValidateNamesTheFrameAndField) {
  MeshSequence s = small_sequence();
  s.frames[2].time_s = s.frames[1].time_s;
  try {
    validate_mesh_sequence(s);
    FAIL() << "equal frame times accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 2"), std::string::npos) << e.what();
  }
  s = small_sequence();
  s.frames[3].triangles[5][1] = 1u << 30;
  EXPECT_THROW(validate_mesh_sequence(s), Error);
  s = small_sequence();
  s.geometry.spacing.y = 0.0;
  EXPECT_THROW(write_mesh_sequence(tsf::test::scratch_dir("seq") / "x.tsfmesh", s), Error);
}

TEST(MeshSequence, NonSequenceFilesAreRecognised) {
  const fs::path dir = tsf::test::scratch_dir("seq");
  test::write_bytes(dir / "mesh.ply", "ply\nformat binary_little_endian 1.0\n");
  EXPECT_FALSE(is_mesh_sequence_file(dir / "mesh.ply"));
  EXPECT_FALSE(is_mesh_sequence_file(dir / "missing.tsfmesh"));
  try {
    MeshSequenceReader reader(dir / "mesh.ply");
    FAIL() << "a PLY file was read as a mesh sequence";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("magic"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tsf::io
