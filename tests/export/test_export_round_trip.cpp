// Every format through assimp's importer: the same triangles (corners, winding), bounds, normals,
// colours where the format has them, tissue materials, and per-tissue meshes that partition the
// surface.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "export_test_helpers.h"
#include "tsf/export/export_normals.h"
#include "tsf/export/label_partition.h"
#include "tsf/export/mesh_cleanup.h"
#include "tsf/export/mesh_export.h"
#include "tsf/export/tissue_palette.h"

namespace tsf::exporter {
namespace {
using namespace test;

struct Case {
  ExportFormat format;
  const char* file;
  float tolerance;  ///< corner distance allowed (file units): 0 for binary formats
};

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  std::string n = format_info(info.param.format).name;
  for (char& c : n)
    if (c == '-') c = '_';
  return n;
}

/// The mesh as the file should hold it: file frame, area-weighted unit normals (the test
/// sphere has no zero-area or duplicate triangles, so cleaning keeps it as it is).
imt::SurfaceMesh expected_mesh(const imt::SurfaceMesh& mesh, const VolumeGeometry& g,
                               const ExportOptions& o) {
  imt::SurfaceMesh out =
      to_output_frame(mesh, make_output_frame(g, o.resolved_axes(), o.resolved_units()));
  out.normals = area_weighted_normals(out.positions, out.triangles);
  return out;
}

struct Bits {
  std::uint32_t x, y, z;
  bool operator<(const Bits& o) const { return std::tie(x, y, z) < std::tie(o.x, o.y, o.z); }
};
Bits bits(const Vec3f& p) {
  Bits b{};
  std::memcpy(&b.x, &p.x, 4);
  std::memcpy(&b.y, &p.y, 4);
  std::memcpy(&b.z, &p.z, 4);
  return b;
}

/// Expected colour of a label in the format's encoding.
std::array<float, 3> expected_colour(std::uint8_t label, ExportFormat f) {
  if (f == ExportFormat::glb || f == ExportFormat::gltf) return tissue_colour_linear(label);
  const auto c = tissue_colour_srgb(label);
  return {c[0] / 255.0f, c[1] / 255.0f, c[2] / 255.0f};
}

class ExportRoundTrip : public ::testing::TestWithParam<Case> {};

TEST_P(ExportRoundTrip, ImporterReadsBackTheSameSurface) {
  const Case c = GetParam();
  const VolumeGeometry g = oblique_geometry();
  const imt::SurfaceMesh mesh = labelled_sphere(g);
  ExportOptions options;
  options.format = c.format;
  options.vertex_colours = true;
  const fs::path dir = tsf::test::scratch_dir("round-trip");
  const fs::path file = dir / c.file;
  const ExportReport report = export_surface(mesh, g, file, options);
  const ExportFormatInfo& info = format_info(c.format);
  ASSERT_TRUE(fs::exists(file));
  ASSERT_EQ(count_triangle_defects(mesh).zero_area, 0u) << "the test sphere is clean already";
  EXPECT_EQ(report.triangles, mesh.triangle_count());
  EXPECT_EQ(report.written.zero_area, 0u);
  EXPECT_EQ(report.written.duplicates, 0u);

  const imt::SurfaceMesh want = expected_mesh(mesh, g, options);
  const Imported got = import_file(file);
  ASSERT_EQ(got.triangles.size(), mesh.triangle_count());
  EXPECT_LE(triangle_set_distance(triangle_keys(want), got.triangles), c.tolerance)
      << "corners or winding changed";

  // Winding: counter-clockwise seen from outside, so every face normal points away from the
  // sphere's centre (the mean of the corners read back).
  Vec3d centre{0, 0, 0};
  for (const TriangleKey& k : got.triangles)
    for (std::size_t i = 0; i < 3; ++i) centre += Vec3d{k[3 * i], k[3 * i + 1], k[3 * i + 2]};
  centre = centre / (3.0 * static_cast<double>(got.triangles.size()));
  std::size_t inward = 0, faces = 0;
  for (const TriangleKey& k : got.triangles) {
    const Vec3d a{k[0], k[1], k[2]}, b{k[3], k[4], k[5]}, d{k[6], k[7], k[8]};
    const Vec3d n = cross(b - a, d - a);
    if (length(n) == 0.0) continue;
    ++faces;
    if (dot(n, (a + b + d) / 3.0 - centre) <= 0.0) ++inward;
  }
  EXPECT_GT(faces, mesh.triangle_count() / 2);
  EXPECT_EQ(inward, 0u) << "triangles facing into the tissue";

  // Bounds in file units (glTF metres: the sphere is ~11 mm wide).
  Vec3f lo{1e30f, 1e30f, 1e30f}, hi{-1e30f, -1e30f, -1e30f};
  for (const Vec3f& p : want.positions) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(got.lo[a], lo[a], c.tolerance + 1e-7f) << "axis " << a;
    EXPECT_NEAR(got.hi[a], hi[a], c.tolerance + 1e-7f) << "axis " << a;
  }
  const float extent = hi.x - lo.x;
  EXPECT_NEAR(extent, info.default_units == LengthUnit::metre ? 0.011f : 11.0f, extent * 0.1f);

  // Vertex counts: PLY keeps the indexed vertices; glTF a mesh (primitive) per tissue, vertices
  // on tissue borders in each; OBJ, STL and FBX come back unindexed.
  std::size_t per_tissue = 0;
  for (const LabelPart& part : partition_by_label(want)) per_tissue += part.vertices.size();
  switch (c.format) {
    case ExportFormat::glb:
    case ExportFormat::gltf:
      EXPECT_EQ(got.vertices, per_tissue);
      break;
    case ExportFormat::ply:
    case ExportFormat::ply_ascii:
      EXPECT_EQ(got.vertices, mesh.vertex_count());
      break;
    default:
      EXPECT_EQ(got.vertices, 3 * mesh.triangle_count());
  }

  EXPECT_TRUE(got.all_normals) << "normals missing";
  EXPECT_EQ(got.all_colours, info.vertex_colours) << "vertex colours (asked for)";

  // Exact per-vertex normals and colours where positions survive bit for bit.
  if (c.tolerance == 0.0f) {
    std::map<Bits, std::size_t> by_position;
    for (std::size_t v = 0; v < want.positions.size(); ++v)
      by_position[bits(want.positions[v])] = v;
    std::size_t checked = 0;
    for (std::size_t i = 0; i < got.positions.size(); ++i) {
      const auto it = by_position.find(bits(got.positions[i]));
      ASSERT_NE(it, by_position.end()) << "a vertex at an unknown position";
      const std::size_t v = it->second;
      if (info.vertex_normals) {
        ASSERT_LT(i, got.normals.size());
        EXPECT_LT(length(got.normals[i] - want.normals[v]), 1e-5f) << "normal of vertex " << v;
      }
      if (info.vertex_colours) {
        const auto col = expected_colour(want.labels[v], c.format);
        for (int k = 0; k < 3; ++k)
          EXPECT_NEAR(got.colours[i][static_cast<std::size_t>(k)], col[static_cast<std::size_t>(k)],
                      0.5f / 255.0f)
              << "colour of vertex " << v;
      }
      ++checked;
    }
    EXPECT_EQ(checked, got.vertices);
  } else if (info.vertex_colours) {
    // Text formats: every colour read back is the colour of a tissue on the surface.
    for (const auto& col : got.colours) {
      bool known = false;
      for (std::uint8_t l : {kLabelSoftTissue, kLabelMucosa, kLabelCorticalBone}) {
        const auto e = expected_colour(l, c.format);
        known = known ||
                (std::fabs(col[0] - e[0]) < 1.0f / 255 && std::fabs(col[1] - e[1]) < 1.0f / 255 &&
                 std::fabs(col[2] - e[2]) < 1.0f / 255);
      }
      ASSERT_TRUE(known) << "colour " << col[0] << " " << col[1] << " " << col[2];
    }
  }
  if (c.format == ExportFormat::fbx || c.format == ExportFormat::fbx_ascii) {
    ASSERT_TRUE(got.unit_scale.has_value()) << "FBX without UnitScaleFactor";
    EXPECT_NEAR(*got.unit_scale, 0.1, 1e-6) << "millimetres are 0.1 cm";
  }
}

INSTANTIATE_TEST_SUITE_P(EveryFormat, ExportRoundTrip,
                         ::testing::Values(Case{ExportFormat::glb, "sphere.glb", 0.0f},
                                           Case{ExportFormat::gltf, "sphere.gltf", 0.0f},
                                           Case{ExportFormat::obj, "sphere.obj", 2e-5f},
                                           Case{ExportFormat::stl, "sphere.stl", 0.0f},
                                           Case{ExportFormat::stl_ascii, "sphere.stl", 2e-5f},
                                           Case{ExportFormat::ply, "sphere.ply", 0.0f},
                                           Case{ExportFormat::ply_ascii, "sphere.ply", 2e-5f},
                                           Case{ExportFormat::fbx, "sphere.fbx", 0.0f},
                                           Case{ExportFormat::fbx_ascii, "sphere.fbx", 2e-5f}),
                         case_name);

class SplitLabelsRoundTrip : public ::testing::TestWithParam<Case> {};

TEST_P(SplitLabelsRoundTrip, PerTissueMeshesPartitionTheSurface) {
  const Case c = GetParam();
  const VolumeGeometry g = oblique_geometry();
  const imt::SurfaceMesh mesh = labelled_sphere(g);
  ExportOptions options;
  options.format = c.format;
  options.split_labels = true;
  const fs::path file = tsf::test::scratch_dir("split") / c.file;
  const ExportReport report = export_surface(mesh, g, file, options);
  const auto parts = partition_by_label(mesh);
  ASSERT_EQ(parts.size(), 3u) << "the test sphere has three tissues";
  EXPECT_EQ(report.meshes_per_file, 3u);

  const imt::SurfaceMesh want = expected_mesh(mesh, g, options);
  const Imported got = import_file(file);
  ASSERT_EQ(got.meshes, parts.size());
  // Union of the meshes = the whole surface, and no triangle twice (multiset equality).
  EXPECT_LE(triangle_set_distance(triangle_keys(want), got.triangles), c.tolerance);
  // Each mesh is exactly one tissue's triangles, named after it, with its material.
  std::map<std::string, std::vector<TriangleKey>> by_name;
  for (std::size_t m = 0; m < got.meshes; ++m) {
    by_name[got.mesh_names[m]] = got.mesh_keys[m];
    EXPECT_EQ(got.mesh_materials[m], got.mesh_names[m]) << "material named after its tissue";
  }
  for (const LabelPart& part : parts) {
    const std::string name = tissue_material_name(part.label);
    ASSERT_TRUE(by_name.count(name)) << "no mesh named " << name;
    std::vector<TriangleKey> keys;
    for (std::uint32_t t : part.triangle_ids) {
      const auto& tri = want.triangles[t];
      keys.push_back(
          triangle_key(want.positions[tri[0]], want.positions[tri[1]], want.positions[tri[2]]));
    }
    EXPECT_LE(triangle_set_distance(keys, by_name[name]), c.tolerance) << name;
  }
}

INSTANTIATE_TEST_SUITE_P(MultiMeshFormats, SplitLabelsRoundTrip,
                         ::testing::Values(Case{ExportFormat::glb, "split.glb", 0.0f},
                                           Case{ExportFormat::gltf, "split.gltf", 0.0f},
                                           Case{ExportFormat::obj, "split.obj", 2e-5f},
                                           Case{ExportFormat::fbx, "split.fbx", 0.0f},
                                           Case{ExportFormat::fbx_ascii, "split.fbx", 2e-5f}),
                         case_name);

TEST(ExportMaterials, OneColouredPbrMaterialPerTissueAndNoVertexColoursByDefault) {
  const VolumeGeometry g = oblique_geometry();
  const imt::SurfaceMesh mesh = labelled_sphere(g);
  const fs::path dir = tsf::test::scratch_dir("materials");
  export_surface(mesh, g, dir / "plain.glb", {});
  const GltfDocument doc = parse_glb(read_bytes(dir / "plain.glb"));
  // One node, one mesh whose primitives are the tissues, each with its own material.
  ASSERT_EQ(doc.json["meshes"].size(), 1u);
  const auto& primitives = doc.json["meshes"][0]["primitives"];
  ASSERT_EQ(primitives.size(), 3u);
  std::set<std::string> names;
  for (const auto& p : primitives) {
    EXPECT_FALSE(p["attributes"].contains("COLOR_0")) << "vertex colours only on request";
    const auto& m = doc.json["materials"][p["material"].get<std::size_t>()];
    const std::uint8_t label = m["extras"]["tsf_label"].get<std::uint8_t>();
    EXPECT_EQ(m["name"], tissue_material_name(label));
    names.insert(m["name"].get<std::string>());
    const auto linear = tissue_colour_linear(label);
    const auto& base = m["pbrMetallicRoughness"]["baseColorFactor"];
    for (std::size_t k = 0; k < 3; ++k) EXPECT_NEAR(base[k].get<double>(), linear[k], 1e-6);
    EXPECT_EQ(base[3].get<double>(), 1.0);
    EXPECT_EQ(m["pbrMetallicRoughness"]["metallicFactor"].get<double>(), 0.0);
    EXPECT_NEAR(m["pbrMetallicRoughness"]["roughnessFactor"].get<double>(),
                tissue_look(label).roughness, 1e-6);
  }
  EXPECT_EQ(names, (std::set<std::string>{"soft-tissue", "mucosa", "cortical-bone"}));
  EXPECT_NE(tissue_look(kLabelMucosa).roughness, tissue_look(kLabelCancellousBone).roughness);

  // With --vertex-colours: COLOR_0 on every primitive and white materials (glTF multiplies).
  ExportOptions o;
  o.vertex_colours = true;
  export_surface(mesh, g, dir / "coloured.glb", o);
  const GltfDocument coloured = parse_glb(read_bytes(dir / "coloured.glb"));
  for (const auto& p : coloured.json["meshes"][0]["primitives"]) {
    EXPECT_TRUE(p["attributes"].contains("COLOR_0"));
    const auto& base = coloured.json["materials"][p["material"].get<std::size_t>()]
                                    ["pbrMetallicRoughness"]["baseColorFactor"];
    EXPECT_EQ(base, nlohmann::json({1.0, 1.0, 1.0, 1.0}));
  }

  // OBJ and FBX carry the tissue colour in their materials.
  ExportOptions obj;
  obj.format = ExportFormat::obj;
  export_surface(mesh, g, dir / "plain.obj", obj);
  const std::string mtl = read_bytes(dir / "plain.mtl");
  const auto c = tissue_colour_srgb(kLabelMucosa);
  const std::size_t block = mtl.find("newmtl mucosa");
  ASSERT_NE(block, std::string::npos) << mtl;
  const std::size_t kd = mtl.find("Kd ", block);
  ASSERT_NE(kd, std::string::npos) << mtl;
  float r = 0, gr = 0, b = 0;
  ASSERT_EQ(std::sscanf(mtl.c_str() + kd, "Kd %f %f %f", &r, &gr, &b), 3);
  EXPECT_NEAR(r, c[0] / 255.0f, 1e-3f);
  EXPECT_NEAR(gr, c[1] / 255.0f, 1e-3f);
  EXPECT_NEAR(b, c[2] / 255.0f, 1e-3f);
  EXPECT_EQ(import_file(dir / "plain.obj").all_colours, false);
}

TEST(ExportRoundTrip, SlicerSpaceTokenInStlPlyAndObjHeaders) {
  const VolumeGeometry g = oblique_geometry();
  const imt::SurfaceMesh mesh = labelled_sphere(g);
  const fs::path dir = tsf::test::scratch_dir("space");
  struct Want {
    ExportFormat format;
    std::optional<AxisConvention> axes;
    const char* file;
    const char* token;  ///< expected, or nullptr for none
  };
  for (const Want& w :
       {Want{ExportFormat::stl, std::nullopt, "lps.stl", "SPACE=LPS"},
        Want{ExportFormat::stl, AxisConvention::ras, "ras.stl", "SPACE=RAS"},
        Want{ExportFormat::stl_ascii, AxisConvention::ras, "ras-ascii.stl", "SPACE=RAS"},
        Want{ExportFormat::ply, AxisConvention::ras, "ras.ply", "SPACE=RAS"},
        Want{ExportFormat::ply_ascii, std::nullopt, "lps-ascii.ply", "SPACE=LPS"},
        Want{ExportFormat::obj, AxisConvention::lps, "lps.obj", "SPACE=LPS"},
        Want{ExportFormat::obj, std::nullopt, "yup.obj", nullptr},
        Want{ExportFormat::stl, AxisConvention::y_up, "yup.stl", nullptr}}) {
    ExportOptions o;
    o.format = w.format;
    o.axes = w.axes;
    export_surface(mesh, g, dir / w.file, o);
    const std::string bytes = read_bytes(dir / w.file);
    // Where Slicer looks: the 80-byte header of a binary STL, the "solid" line of an ASCII one,
    // PLY comment lines, OBJ comments before the data.
    std::string header;
    if (w.format == ExportFormat::stl)
      header = bytes.substr(0, 80);
    else if (w.format == ExportFormat::stl_ascii)
      header = bytes.substr(0, bytes.find('\n'));
    else if (w.format == ExportFormat::obj)
      header = bytes.substr(0, bytes.find("\nv "));
    else
      header = bytes.substr(0, bytes.find("end_header"));
    if (w.token) {
      EXPECT_NE(header.find(w.token), std::string::npos) << w.file << ": " << header;
    } else {
      EXPECT_EQ(header.find("SPACE="), std::string::npos) << w.file << ": " << header;
    }
    if (w.format == ExportFormat::ply || w.format == ExportFormat::ply_ascii) {
      EXPECT_NE(header.find("comment "), std::string::npos);
    }
    if (w.format == ExportFormat::stl) {
      EXPECT_NE(header.rfind("solid", 0), 0u);
    }
  }
  // And the file still reads: the ASCII STL's solid line with the token included.
  EXPECT_EQ(import_file(dir / "ras-ascii.stl").triangles.size(), mesh.triangle_count());
}

TEST(ExportRoundTrip, MetresAndOtherAxesWhereTheFormatAllows) {
  const VolumeGeometry g = oblique_geometry();
  const imt::SurfaceMesh mesh = labelled_sphere(g);
  ExportOptions options;
  options.format = ExportFormat::ply;
  options.units = LengthUnit::metre;
  options.axes = AxisConvention::ras;
  const fs::path file = tsf::test::scratch_dir("units") / "ras-metres.ply";
  export_surface(mesh, g, file, options);
  const Imported got = import_file(file);
  // RAS metres: x = −L/1000: compare with the patient positions from the volume geometry itself.
  const Vec3d centre = g.index_to_physical({9.5, 9.5, 9.5});
  const Vec3f mid = (got.lo + got.hi) * 0.5f;
  EXPECT_NEAR(mid.x, -centre.x / 1000.0, 2e-4);
  EXPECT_NEAR(mid.y, -centre.y / 1000.0, 2e-4);
  EXPECT_NEAR(mid.z, centre.z / 1000.0, 2e-4);
}

}  // namespace
}  // namespace tsf::exporter
