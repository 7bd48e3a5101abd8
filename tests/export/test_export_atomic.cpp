// A failed export says why and leaves none of its files (and no temporaries); an existing file
// survives a failed attempt to replace it (mesh_export.h, output_file_set.h).
#include <gtest/gtest.h>

#include <fstream>

#include "export_test_helpers.h"
#include "tsf/common/error.h"
#include "tsf/export/mesh_export.h"
#include "tsf/export/output_file_set.h"

namespace tsf::exporter {
namespace {
using namespace test;

std::string export_error(const imt::SurfaceMesh& mesh, const fs::path& file, ExportOptions o) {
  try {
    export_surface(mesh, oblique_geometry(), file, o);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ExportAtomic, EmptyMeshIsAnErrorAndWritesNothing) {
  const fs::path dir = tsf::test::scratch_dir("atomic");
  imt::SurfaceMesh empty;
  const std::string e = export_error(empty, dir / "empty.glb", {});
  EXPECT_NE(e.find("no triangles"), std::string::npos) << e;
  EXPECT_TRUE(files_in(dir).empty());
}

TEST(ExportAtomic, BadMeshIsAnErrorNamingTheProblem) {
  const fs::path dir = tsf::test::scratch_dir("atomic");
  imt::SurfaceMesh mesh = labelled_sphere(oblique_geometry());
  mesh.triangles[3][2] = static_cast<std::uint32_t>(mesh.vertex_count() + 5);
  const std::string e = export_error(mesh, dir / "bad.glb", {});
  EXPECT_NE(e.find("triangle 3"), std::string::npos) << e;
  EXPECT_TRUE(files_in(dir).empty());
}

TEST(ExportAtomic, ExtensionMustMatchTheFormat) {
  const fs::path dir = tsf::test::scratch_dir("atomic");
  const imt::SurfaceMesh mesh = labelled_sphere(oblique_geometry());
  ExportOptions o;
  o.format = ExportFormat::obj;
  const std::string e = export_error(mesh, dir / "mesh.glb", o);
  EXPECT_NE(e.find("'.glb'"), std::string::npos) << e;
  EXPECT_TRUE(files_in(dir).empty());
}

TEST(ExportAtomic, UnwritableFolderIsAnErrorNamingTheOutput) {
  const fs::path dir = tsf::test::scratch_dir("atomic");
  const imt::SurfaceMesh mesh = labelled_sphere(oblique_geometry());
  std::ofstream(dir / "plain-file") << "not a folder";
  // A path below a regular file cannot be created, even by root.
  const fs::path target = dir / "plain-file" / "sub" / "mesh.glb";
  const std::string e = export_error(mesh, target, {});
  EXPECT_NE(e.find(target.string()), std::string::npos) << e;
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"plain-file"});
}

TEST(ExportAtomic, ObjAndItsMaterialsAppearTogetherOrNotAtAll) {
  const fs::path dir = tsf::test::scratch_dir("atomic");
  const imt::SurfaceMesh mesh = labelled_sphere(oblique_geometry());
  ExportOptions o;
  o.format = ExportFormat::obj;
  // The .mtl target is a directory: the commit must fail before the .obj appears.
  fs::create_directories(dir / "mesh.mtl" / "blocker");
  const std::string e = export_error(mesh, dir / "mesh.obj", o);
  EXPECT_NE(e.find("mesh.mtl"), std::string::npos) << e;
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"mesh.mtl"}) << "no .obj, no temporaries";
  fs::remove_all(dir / "mesh.mtl");
  export_surface(mesh, oblique_geometry(), dir / "mesh.obj", o);
  EXPECT_EQ(files_in(dir), (std::vector<std::string>{"mesh.mtl", "mesh.obj"}));
  EXPECT_NE(read_bytes(dir / "mesh.obj").find("mtllib mesh.mtl"), std::string::npos);
}

TEST(ExportAtomic, FailedExportKeepsTheExistingFile) {
  const fs::path dir = tsf::test::scratch_dir("atomic");
  std::ofstream(dir / "keep.glb") << "previous contents";
  const std::string e = export_error(imt::SurfaceMesh{}, dir / "keep.glb", {});
  EXPECT_FALSE(e.empty());
  EXPECT_EQ(read_bytes(dir / "keep.glb"), "previous contents");
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"keep.glb"});
}

TEST(OutputFileSet, UncommittedSetRemovesItsTemporaries) {
  const fs::path dir = tsf::test::scratch_dir("atomic");
  {
    OutputFileSet set;
    set.add(dir / "a.bin", "alpha");
    set.add(dir / "b.bin", "beta");
    EXPECT_EQ(files_in(dir).size(), 2u) << "temporaries exist until commit";
    EXPECT_FALSE(fs::exists(dir / "a.bin"));
    EXPECT_THROW(set.add(dir / "a.bin", "again"), Error) << "same target twice";
  }
  EXPECT_TRUE(files_in(dir).empty());
  OutputFileSet set;
  set.add(dir / "a.bin", "alpha");
  set.commit();
  EXPECT_EQ(read_bytes(dir / "a.bin"), "alpha");
  EXPECT_EQ(files_in(dir), std::vector<std::string>{"a.bin"});
}

}  // namespace
}  // namespace tsf::exporter
