// Helpers for the export tests: a labelled test surface, re-import through assimp's importer,
// triangle-set comparison, the Khronos glTF validator (node), glTF accessor reading.
#pragma once

#include <gtest/gtest.h>

#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/test_data.h"
#include "tsf/export/gltf_document.h"
#include "tsf/export/output_frame.h"
#include "tsf/imt/extract_surface.h"
#include "tsf/imt/mesh_topology.h"
#include "tsf/io/mesh_sequence.h"
#include "tsf/volume/analytic_volumes.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::exporter::test {

namespace fs = std::filesystem;

/// An oblique volume frame: a 30° rotation about the patient's z axis and an offset origin.
inline VolumeGeometry oblique_geometry() {
  VolumeGeometry g = cube_geometry({20, 20, 20}, 0.8);
  g.origin = {-40.0, 25.0, -110.0};
  const double c = std::sqrt(3.0) / 2.0, s = 0.5;
  g.direction = {c, -s, 0, s, c, 0, 0, 0, 1};
  return g;
}

/// A sphere surface (tissue space) with three tissues: mucosa above the centre, cortical bone
/// below it on the +x side, soft tissue elsewhere.
inline imt::SurfaceMesh labelled_sphere(const VolumeGeometry& g, double radius = 5.5,
                                        Vec3d shift = {0, 0, 0}) {
  const Vec3d centre = g.index_to_tissue({9.5, 9.5, 9.5}) + shift;
  const VoxelVolume volume = make_sdf_volume(
      g, [&](const Vec3d& p) { return length(p - centre) - radius; }, 1.0);
  imt::SurfaceMesh mesh = imt::extract_surface(volume);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3d p = to_double(mesh.positions[v]);
    mesh.labels[v] = p.z > centre.z   ? kLabelMucosa
                     : p.x > centre.x ? kLabelCorticalBone
                                      : kLabelSoftTissue;
  }
  return mesh;
}

/// Rest state plus `poses` frames that squash the sphere along z by 4% per frame.
inline io::MeshSequence squashing_sphere(int poses) {
  io::MeshSequence s;
  s.geometry = oblique_geometry();
  s.rest = labelled_sphere(s.geometry);
  Vec3f c{0, 0, 0};
  for (const Vec3f& p : s.rest.positions) c += p;
  c = c / static_cast<float>(s.rest.positions.size());
  for (int f = 1; f <= poses; ++f) {
    io::MeshFrame frame;
    frame.time_s = 0.02 * f;
    const float k = 1.0f - 0.04f * static_cast<float>(f);
    for (const Vec3f& p : s.rest.positions)
      frame.positions.push_back({p.x, p.y, c.z + (p.z - c.z) * k});
    frame.normals = s.rest.normals;
    s.frames.push_back(frame);
  }
  return s;
}

/// squashing_sphere(poses) and then a state in which a cut re-meshed the surface (a smaller,
/// shifted sphere stands in for it, 0.02 s after the last pose), then a pose of that topology.
inline io::MeshSequence sphere_with_a_cut(int poses) {
  io::MeshSequence s = squashing_sphere(poses);
  const imt::SurfaceMesh cut = labelled_sphere(s.geometry, 4.0, {1.0, 0.0, 0.0});
  io::MeshFrame remeshed;
  remeshed.time_s = 0.02 * (poses + 1);
  remeshed.topology_changed = true;
  remeshed.positions = cut.positions;
  remeshed.normals = cut.normals;
  remeshed.labels = cut.labels;
  remeshed.triangles = cut.triangles;
  s.frames.push_back(remeshed);
  io::MeshFrame pose;
  pose.time_s = 0.02 * (poses + 2);
  for (const Vec3f& p : cut.positions) pose.positions.push_back(p + Vec3f{0.0f, 0.0f, -0.5f});
  s.frames.push_back(pose);
  return s;
}

/// What analyse_topology found wrong, for failure messages.
inline std::string topology_text(const imt::MeshTopology& t) {
  return "boundary " + std::to_string(t.boundary_edges) + ", non-manifold edges " +
         std::to_string(t.nonmanifold_edges) + ", misoriented " +
         std::to_string(t.misoriented_edges) + ", degenerate " +
         std::to_string(t.degenerate_triangles) + ", pinched vertices " +
         std::to_string(t.nonmanifold_vertices);
}

/// A triangle as its three corners, rotated so the smallest corner comes first (winding kept).
using TriangleKey = std::array<float, 9>;

inline TriangleKey triangle_key(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  std::array<Vec3f, 3> v{a, b, c};
  auto less = [](const Vec3f& p, const Vec3f& q) {
    return std::tie(p.x, p.y, p.z) < std::tie(q.x, q.y, q.z);
  };
  const std::size_t first =
      less(v[1], v[0]) ? (less(v[2], v[1]) ? 2 : 1) : (less(v[2], v[0]) ? 2 : 0);
  TriangleKey k{};
  for (std::size_t i = 0; i < 3; ++i) {
    const Vec3f& p = v[(first + i) % 3];
    k[3 * i] = p.x;
    k[3 * i + 1] = p.y;
    k[3 * i + 2] = p.z;
  }
  return k;
}

inline std::vector<TriangleKey> triangle_keys(const imt::SurfaceMesh& m) {
  std::vector<TriangleKey> keys;
  for (const auto& t : m.triangles)
    keys.push_back(triangle_key(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]));
  return keys;
}

/// What assimp's importer read back from a file.
struct Imported {
  std::vector<TriangleKey> triangles;
  std::size_t vertices = 0;
  std::size_t meshes = 0;
  bool all_normals = true, all_colours = true;
  std::vector<Vec3f> positions, normals;  ///< every vertex of every mesh
  std::vector<std::array<float, 4>> colours;
  std::vector<std::string> mesh_names, mesh_materials;
  std::vector<std::size_t> mesh_triangles;
  std::vector<std::vector<TriangleKey>> mesh_keys;
  Vec3f lo{1e30f, 1e30f, 1e30f}, hi{-1e30f, -1e30f, -1e30f};
  std::optional<double> unit_scale;  ///< FBX UnitScaleFactor metadata
  unsigned animations = 0;
  std::size_t anim_meshes = 0;
};

inline Imported import_file(const fs::path& file) {
  Imported r;
  Assimp::Importer importer;
  const aiScene* s = importer.ReadFile(file.string(), 0);
  if (!s) {
    ADD_FAILURE() << "assimp could not read " << file << ": " << importer.GetErrorString();
    return r;
  }
  r.meshes = s->mNumMeshes;
  r.animations = s->mNumAnimations;
  for (unsigned m = 0; m < s->mNumMeshes; ++m) {
    const aiMesh* mesh = s->mMeshes[m];
    r.vertices += mesh->mNumVertices;
    r.anim_meshes += mesh->mNumAnimMeshes;
    r.all_normals = r.all_normals && mesh->HasNormals();
    r.all_colours = r.all_colours && mesh->HasVertexColors(0);
    r.mesh_names.push_back(mesh->mName.C_Str());
    aiString material;
    s->mMaterials[mesh->mMaterialIndex]->Get(AI_MATKEY_NAME, material);
    r.mesh_materials.push_back(material.C_Str());
    auto pos = [&](unsigned i) {
      return Vec3f{mesh->mVertices[i].x, mesh->mVertices[i].y, mesh->mVertices[i].z};
    };
    for (unsigned i = 0; i < mesh->mNumVertices; ++i) {
      const Vec3f p = pos(i);
      r.positions.push_back(p);
      r.lo = {std::min(r.lo.x, p.x), std::min(r.lo.y, p.y), std::min(r.lo.z, p.z)};
      r.hi = {std::max(r.hi.x, p.x), std::max(r.hi.y, p.y), std::max(r.hi.z, p.z)};
      if (mesh->HasNormals())
        r.normals.push_back({mesh->mNormals[i].x, mesh->mNormals[i].y, mesh->mNormals[i].z});
      if (mesh->HasVertexColors(0)) {
        const aiColor4D& c = mesh->mColors[0][i];
        r.colours.push_back({c.r, c.g, c.b, c.a});
      }
    }
    std::vector<TriangleKey> keys;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) {
        ADD_FAILURE() << file << ": face with " << face.mNumIndices << " corners";
        continue;
      }
      keys.push_back(
          triangle_key(pos(face.mIndices[0]), pos(face.mIndices[1]), pos(face.mIndices[2])));
    }
    r.mesh_triangles.push_back(keys.size());
    r.triangles.insert(r.triangles.end(), keys.begin(), keys.end());
    r.mesh_keys.push_back(std::move(keys));
  }
  if (s->mMetaData) {
    float f = 0;
    double d = 0;
    if (s->mMetaData->Get("UnitScaleFactor", d))
      r.unit_scale = d;
    else if (s->mMetaData->Get("UnitScaleFactor", f))
      r.unit_scale = f;
  }
  return r;
}

/// Largest corner distance between two triangle multisets, each sorted exactly (text formats
/// round monotonically, so the order survives); infinity when the counts differ.
inline double triangle_set_distance(std::vector<TriangleKey> a, std::vector<TriangleKey> b) {
  if (a.size() != b.size()) return INFINITY;
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  double worst = 0;
  for (std::size_t t = 0; t < a.size(); ++t)
    for (std::size_t i = 0; i < 9; ++i)
      worst = std::max(worst, static_cast<double>(std::fabs(a[t][i] - b[t][i])));
  return worst;
}

inline std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline std::vector<std::string> files_in(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

/// The `node` executable, if any (TSF_NODE overrides the search on PATH).
inline std::optional<std::string> node_executable() {
  if (const char* env = std::getenv("TSF_NODE"); env && *env) return std::string(env);
  const char* path = std::getenv("PATH");
  if (!path) return std::nullopt;
  std::string dirs = path;
  std::size_t begin = 0;
  while (begin <= dirs.size()) {
    const std::size_t end = dirs.find(':', begin);
    const fs::path candidate =
        fs::path(dirs.substr(begin, end == std::string::npos ? std::string::npos : end - begin)) /
        "node";
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec)) return candidate.string();
    if (end == std::string::npos) break;
    begin = end + 1;
  }
  return std::nullopt;
}

/// Runs tools/gltf-validator/validate.js on `file`; the parsed JSON report (null on failure).
inline nlohmann::json run_gltf_validator(const std::string& node, const fs::path& file) {
  const fs::path script = tsf::test::source_dir() / "tools" / "gltf-validator" / "validate.js";
  const std::string command =
      "'" + node + "' '" + script.string() + "' '" + file.string() + "' 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return nullptr;
  std::string out;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) out.append(buf, n);
  pclose(pipe);
  try {
    return nlohmann::json::parse(out);
  } catch (const nlohmann::json::exception&) {
    ADD_FAILURE() << "validator output is not JSON: " << out;
    return nullptr;
  }
}

#define TSF_NODE_OR_SKIP(var)                                                                      \
  const auto var##_opt = ::tsf::exporter::test::node_executable();                                 \
  if (!var##_opt)                                                                                  \
    GTEST_SKIP() << "not run: Node.js ('node') is not installed, so the Khronos glTF validator "   \
                    "in tools/gltf-validator cannot run (Debian package nodejs; scripts/setup.sh " \
                    "installs it)";                                                                \
  const std::string var = *var##_opt

/// Float accessor `index` of a glTF document as a flat vector (tightly packed, as assimp and
/// tsf write them).
inline std::vector<float> read_float_accessor(const GltfDocument& doc, std::size_t index) {
  const auto& accessor = doc.json["accessors"][index];
  const auto& view = doc.json["bufferViews"][accessor["bufferView"].get<std::size_t>()];
  const std::string type = accessor["type"];
  const std::size_t components = type == "SCALAR" ? 1 : type == "VEC2" ? 2 : type == "VEC3" ? 3 : 4;
  const std::size_t count = accessor["count"].get<std::size_t>() * components;
  const std::size_t offset =
      view.value("byteOffset", std::size_t{0}) + accessor.value("byteOffset", std::size_t{0});
  std::vector<float> out(count);
  if (offset + count * 4 > doc.bin.size()) {
    ADD_FAILURE() << "accessor " << index << " runs past the buffer";
    return {};
  }
  std::memcpy(out.data(), doc.bin.data() + offset, count * 4);
  return out;
}

}  // namespace tsf::exporter::test
