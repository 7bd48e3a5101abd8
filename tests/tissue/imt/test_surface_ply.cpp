#include "tsf/imt/surface_ply.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "support/test_data.h"
#include "tsf/common/error.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/volume/analytic_volumes.h"

namespace tsf::imt {
namespace {

TEST(SurfacePly, RoundTripsPositionsNormalsLabelsAndTriangles) {
  const VoxelVolume v = make_blob_volume(cube_geometry({32, 32, 32}, 0.7), 4);
  const SurfaceMesh m = extract_surface(v);
  const auto path = test::scratch_dir("ply") / "mesh.ply";
  write_surface_ply(path, m);
  const SurfaceMesh r = read_surface_ply(path);
  ASSERT_EQ(r.vertex_count(), m.vertex_count());
  ASSERT_EQ(r.triangle_count(), m.triangle_count());
  EXPECT_EQ(r.positions, m.positions);
  EXPECT_EQ(r.normals, m.normals);
  EXPECT_EQ(r.labels, m.labels);
  EXPECT_EQ(r.triangles, m.triangles);
}

TEST(SurfacePly, FailedWriteLeavesNoFile) {
  SurfaceMesh bad;
  bad.positions = {{0, 0, 0}};
  bad.labels = {1};
  bad.triangles = {{0, 0, 7}};
  const auto path = test::scratch_dir("ply-bad") / "bad.ply";
  EXPECT_THROW(write_surface_ply(path, bad), Error);
  EXPECT_FALSE(std::filesystem::exists(path));
}

TEST(SurfacePly, ReaderNamesWhatIsWrong) {
  const auto dir = test::scratch_dir("ply-read");
  {
    std::ofstream f(dir / "ascii.ply");
    f << "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n";
  }
  try {
    read_surface_ply(dir / "ascii.ply");
    FAIL() << "ascii PLY accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ascii.ply"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("binary_little_endian"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_surface_ply(dir / "missing.ply"), Error);
}

}  // namespace
}  // namespace tsf::imt
