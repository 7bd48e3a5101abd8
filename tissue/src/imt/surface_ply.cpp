#include "tsf/imt/surface_ply.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tsf/common/atomic_file.h"
#include "tsf/common/error.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::imt {

namespace {

bool little_endian() {
  const std::uint16_t one = 1;
  std::uint8_t first;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

template <typename T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

}  // namespace

std::array<std::uint8_t, 3> label_colour(std::uint8_t label) {
  switch (label) {
    case kLabelSoftTissue:
      return {214, 150, 140};
    case kLabelMucosa:
      return {232, 120, 130};
    case kLabelFat:
      return {240, 215, 130};
    case kLabelCartilage:
      return {170, 200, 230};
    case kLabelCancellousBone:
      return {225, 215, 190};
    case kLabelCorticalBone:
      return {245, 240, 225};
    case kLabelTumour:
      return {150, 90, 160};
    case kLabelVessel:
      return {200, 40, 40};
    case kLabelNerve:
      return {240, 220, 60};
    default: {  // any other label: a stable hash colour
      const std::uint32_t h = label * 2654435761u;
      return {static_cast<std::uint8_t>(80 + (h >> 8) % 160),
              static_cast<std::uint8_t>(80 + (h >> 16) % 160),
              static_cast<std::uint8_t>(80 + (h >> 24) % 160)};
    }
  }
}

void write_surface_ply(const std::filesystem::path& path, const SurfaceMesh& mesh) {
  validate_mesh(mesh);
  require(little_endian(), "write_surface_ply: only little-endian hosts are supported");
  const bool normals = !mesh.normals.empty();
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment tsf IMT surface, tissue space, mm\n"
         << "element vertex " << mesh.positions.size() << "\n"
         << "property float x\nproperty float y\nproperty float z\n";
  if (normals) header << "property float nx\nproperty float ny\nproperty float nz\n";
  header << "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar label\n"
         << "element face " << mesh.triangles.size() << "\n"
         << "property list uchar int vertex_indices\nend_header\n";
  std::string bytes = header.str();
  bytes.reserve(bytes.size() + mesh.positions.size() * (normals ? 28 : 16) +
                mesh.triangles.size() * 13);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3f& p = mesh.positions[v];
    put(bytes, p.x);
    put(bytes, p.y);
    put(bytes, p.z);
    if (normals) {
      put(bytes, mesh.normals[v].x);
      put(bytes, mesh.normals[v].y);
      put(bytes, mesh.normals[v].z);
    }
    const auto c = label_colour(mesh.labels[v]);
    for (std::uint8_t b : c) put(bytes, b);
    put(bytes, mesh.labels[v]);
  }
  require(mesh.positions.size() <= 0x7fffffffu,
          "write_surface_ply: " + std::to_string(mesh.positions.size()) +
              " vertices exceed the PLY int index range");
  for (const auto& t : mesh.triangles) {
    put(bytes, std::uint8_t{3});
    for (std::uint32_t i : t) put(bytes, static_cast<std::int32_t>(i));
  }
  write_text_atomically(path, bytes);
}

SurfaceMesh read_surface_ply(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  require(static_cast<bool>(in), "cannot open PLY file '" + path.string() + "'");
  auto fail = [&](const std::string& what) {
    throw Error("PLY file '" + path.string() + "': " + what);
  };
  std::string line;
  std::getline(in, line);
  if (line != "ply") fail("does not start with 'ply'");
  std::size_t n_vertices = 0, n_faces = 0;
  std::vector<std::string> vertex_props;
  std::string element;
  bool face_ok = false;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "format") {
      std::string f;
      ls >> f;
      if (f != "binary_little_endian") fail("format '" + f + "' is not binary_little_endian");
    } else if (word == "element") {
      std::size_t n = 0;
      ls >> element >> n;
      if (element == "vertex")
        n_vertices = n;
      else if (element == "face")
        n_faces = n;
      else
        fail("unexpected element '" + element + "'");
    } else if (word == "property") {
      std::string type, name;
      ls >> type;
      if (type == "list") {
        std::string count_type, index_type;
        ls >> count_type >> index_type >> name;
        face_ok = element == "face" && count_type == "uchar" &&
                  (index_type == "int" || index_type == "uint");
        if (!face_ok) fail("face property must be 'list uchar int vertex_indices'");
      } else {
        ls >> name;
        if (element != "vertex") fail("unexpected property '" + name + "' outside vertex");
        if ((name == "x" || name == "y" || name == "z" || name == "nx" || name == "ny" ||
             name == "nz") &&
            type != "float")
          fail("property " + name + " must be float, is " + type);
        if (name != "x" && name != "y" && name != "z" && name != "nx" && name != "ny" &&
            name != "nz" && type != "uchar")
          fail("vertex property " + name + " of type " + type + " is not supported");
        vertex_props.push_back(name);
      }
    } else if (word == "end_header") {
      break;
    }
  }
  if (vertex_props.size() < 3 || vertex_props[0] != "x" || vertex_props[1] != "y" ||
      vertex_props[2] != "z")
    fail("vertex properties must start with float x y z");
  if (n_faces && !face_ok) fail("faces without a vertex_indices list");
  SurfaceMesh m;
  m.positions.resize(n_vertices);
  m.labels.assign(n_vertices, 0);
  const bool normals =
      std::find(vertex_props.begin(), vertex_props.end(), "nx") != vertex_props.end();
  if (normals) m.normals.resize(n_vertices);
  for (std::size_t v = 0; v < n_vertices; ++v) {
    float f[6] = {};
    for (const std::string& p : vertex_props) {
      if (p == "x" || p == "y" || p == "z" || p == "nx" || p == "ny" || p == "nz") {
        float x;
        if (!in.read(reinterpret_cast<char*>(&x), 4)) fail("truncated vertex data");
        const int k = p == "x"    ? 0
                      : p == "y"  ? 1
                      : p == "z"  ? 2
                      : p == "nx" ? 3
                      : p == "ny" ? 4
                                  : 5;
        f[k] = x;
      } else {
        std::uint8_t b;
        if (!in.read(reinterpret_cast<char*>(&b), 1)) fail("truncated vertex data");
        if (p == "label") m.labels[v] = b;
      }
    }
    m.positions[v] = {f[0], f[1], f[2]};
    if (normals) m.normals[v] = {f[3], f[4], f[5]};
  }
  m.triangles.resize(n_faces);
  for (std::size_t t = 0; t < n_faces; ++t) {
    std::uint8_t count;
    if (!in.read(reinterpret_cast<char*>(&count), 1)) fail("truncated face data");
    if (count != 3)
      fail("face " + std::to_string(t) + " has " + std::to_string(count) + " vertices, expected 3");
    for (int k = 0; k < 3; ++k) {
      std::int32_t i;
      if (!in.read(reinterpret_cast<char*>(&i), 4)) fail("truncated face data");
      if (i < 0 || static_cast<std::size_t>(i) >= n_vertices)
        fail("face " + std::to_string(t) + " uses vertex " + std::to_string(i) + " of " +
             std::to_string(n_vertices));
      m.triangles[t][static_cast<std::size_t>(k)] = static_cast<std::uint32_t>(i);
    }
  }
  return m;
}

}  // namespace tsf::imt
