#include "scene/mesh_file.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <unordered_map>

#include "tsf/common/error.h"

namespace tsf::app {
namespace {

constexpr std::size_t kMaxVertices = 4'000'000, kMaxTriangles = 4'000'000;
constexpr double kMaxCoordinate = 1e5;

[[noreturn]] void fail(const std::filesystem::path& p, const std::string& what) {
  throw Error(p.string() + ": " + what);
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

/// Adds a vertex after checking it (finite, within the bound, not too many).
void add_vertex(MeshFile& m, const std::filesystem::path& p, double x, double y, double z,
                double scale, const std::string& where) {
  if (m.vertices.size() >= kMaxVertices)
    fail(p, "more than " + std::to_string(kMaxVertices) + " vertices");
  const Vec3d v{x * scale, y * scale, z * scale};
  if (!all_finite(v) || std::fabs(v.x) > kMaxCoordinate || std::fabs(v.y) > kMaxCoordinate ||
      std::fabs(v.z) > kMaxCoordinate)
    fail(p, where + ": a vertex is not finite or lies beyond ±1e5 mm");
  m.vertices.push_back(to_float(v));
}

/// Fans polygon `poly` (vertex indices, checked) into triangles.
void add_polygon(MeshFile& m, const std::filesystem::path& p, const std::vector<std::int64_t>& poly,
                 const std::string& where) {
  if (poly.size() < 3) fail(p, where + ": a face needs at least 3 vertices");
  for (std::int64_t v : poly)
    if (v < 0 || static_cast<std::size_t>(v) >= m.vertices.size())
      fail(p, where + ": vertex index " + std::to_string(v) + " out of range (" +
                  std::to_string(m.vertices.size()) + " vertices)");
  for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
    if (m.triangles.size() >= kMaxTriangles)
      fail(p, "more than " + std::to_string(kMaxTriangles) + " triangles");
    m.triangles.push_back({static_cast<std::uint32_t>(poly[0]), static_cast<std::uint32_t>(poly[k]),
                           static_cast<std::uint32_t>(poly[k + 1])});
  }
}

std::string read_all(const std::filesystem::path& p) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(p, ec);
  if (ec) fail(p, "cannot read the mesh file: " + ec.message());
  if (size > (std::uintmax_t{1} << 30)) fail(p, "larger than 1 GiB");
  std::ifstream in(p, std::ios::binary);
  if (!in) fail(p, "cannot open the mesh file");
  std::string data(static_cast<std::size_t>(size), '\0');
  in.read(data.data(), static_cast<std::streamsize>(size));
  if (!in) fail(p, "cannot read the mesh file");
  return data;
}

// ---- OBJ ------------------------------------------------------------------------------------

MeshFile read_obj(const std::filesystem::path& p, const std::string& data, double scale) {
  MeshFile m;
  std::istringstream in(data);
  std::string line;
  std::size_t number = 0;
  std::vector<std::int64_t> poly;
  while (std::getline(in, line)) {
    ++number;
    const std::string where = "line " + std::to_string(number);
    std::istringstream ls(line);
    std::string tag;
    if (!(ls >> tag)) continue;
    if (tag == "v") {
      double x, y, z;
      if (!(ls >> x >> y >> z)) fail(p, where + ": expected `v x y z`");
      add_vertex(m, p, x, y, z, scale, where);
    } else if (tag == "f") {
      poly.clear();
      std::string item;
      while (ls >> item) {
        const std::string first = item.substr(0, item.find('/'));
        char* end = nullptr;
        const long long v = std::strtoll(first.c_str(), &end, 10);
        if (first.empty() || end == nullptr || *end != '\0' || v == 0)
          fail(p, where + ": expected vertex indices (1-based, or negative from the end), got '" +
                      item + "'");
        poly.push_back(v > 0 ? v - 1 : static_cast<std::int64_t>(m.vertices.size()) + v);
      }
      add_polygon(m, p, poly, where);
    }
  }
  return m;
}

// ---- STL ------------------------------------------------------------------------------------

/// Welds corners at the same position (STL stores each facet's corners on their own).
struct Welder {
  std::map<std::array<float, 3>, std::uint32_t> index;
  std::uint32_t add(MeshFile& m, const std::filesystem::path& p, double x, double y, double z,
                    double scale, const std::string& where) {
    const std::array<float, 3> key{static_cast<float>(x * scale), static_cast<float>(y * scale),
                                   static_cast<float>(z * scale)};
    const auto it = index.find(key);
    if (it != index.end()) return it->second;
    add_vertex(m, p, x, y, z, scale, where);
    const auto id = static_cast<std::uint32_t>(m.vertices.size() - 1);
    index.emplace(key, id);
    return id;
  }
};

MeshFile read_stl(const std::filesystem::path& p, const std::string& data, double scale) {
  MeshFile m;
  Welder weld;
  // Binary: 80-byte header, uint32 count, 50 bytes per facet. An ASCII file starts with "solid",
  // but so do some binary ones: the size decides.
  if (data.size() >= 84) {
    std::uint32_t count;
    std::memcpy(&count, data.data() + 80, 4);
    if (data.size() == 84 + 50ull * count) {
      if (count > kMaxTriangles) fail(p, "more than " + std::to_string(kMaxTriangles) + " facets");
      for (std::uint32_t f = 0; f < count; ++f) {
        const char* rec = data.data() + 84 + 50ull * f;
        std::array<std::int64_t, 3> ids{};
        for (int k = 0; k < 3; ++k) {
          float c[3];
          std::memcpy(c, rec + 12 + 12 * k, 12);
          ids[static_cast<std::size_t>(k)] =
              weld.add(m, p, c[0], c[1], c[2], scale, "facet " + std::to_string(f));
        }
        add_polygon(m, p, {ids[0], ids[1], ids[2]}, "facet " + std::to_string(f));
      }
      return m;
    }
  }
  if (lower(data.substr(0, 5)) != "solid")
    fail(p, "neither binary STL (its size does not match its facet count) nor ASCII (`solid …`)");
  std::istringstream in(data);
  std::string word;
  std::vector<std::int64_t> corners;
  std::size_t facet = 0;
  while (in >> word) {
    if (word == "vertex") {
      double x, y, z;
      if (!(in >> x >> y >> z))
        fail(p, "facet " + std::to_string(facet) + ": expected `vertex x y z`");
      corners.push_back(weld.add(m, p, x, y, z, scale, "facet " + std::to_string(facet)));
    } else if (word == "endloop") {
      add_polygon(m, p, corners, "facet " + std::to_string(facet));
      corners.clear();
      ++facet;
    }
  }
  return m;
}

// ---- PLY ------------------------------------------------------------------------------------

struct PlyProperty {
  std::string name, type, count_type;  // count_type non-empty: a list
};
struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

std::size_t ply_type_size(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32")
    return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

/// Reads the PLY body: ASCII numbers or binary values of the declared types.
class PlyReader {
 public:
  PlyReader(const std::filesystem::path& p, const std::string& data, std::size_t at, bool ascii,
            bool big_endian)
      : p_(p), data_(data), at_(at), ascii_(ascii), big_(big_endian) {
    if (ascii) text_.str(data.substr(at));
  }
  double value(const std::string& type, const std::string& where) {
    if (ascii_) {
      double v;
      if (!(text_ >> v)) fail(p_, where + ": expected a number");
      return v;
    }
    const std::size_t n = ply_type_size(type);
    if (at_ + n > data_.size()) fail(p_, where + ": the file ends early");
    unsigned char b[8];
    std::memcpy(b, data_.data() + at_, n);
    at_ += n;
    if (big_) std::reverse(b, b + n);
    if (type == "char" || type == "int8") return static_cast<std::int8_t>(b[0]);
    if (type == "uchar" || type == "uint8") return b[0];
    if (type == "short" || type == "int16") return get<std::int16_t>(b);
    if (type == "ushort" || type == "uint16") return get<std::uint16_t>(b);
    if (type == "int" || type == "int32") return get<std::int32_t>(b);
    if (type == "uint" || type == "uint32") return get<std::uint32_t>(b);
    if (type == "float" || type == "float32") return get<float>(b);
    return get<double>(b);
  }

 private:
  template <class T>
  static double get(const unsigned char* b) {
    T v;
    std::memcpy(&v, b, sizeof v);
    return static_cast<double>(v);
  }
  const std::filesystem::path& p_;
  const std::string& data_;
  std::size_t at_;
  bool ascii_, big_;
  std::istringstream text_;
};

MeshFile read_ply(const std::filesystem::path& p, const std::string& data, double scale) {
  const std::size_t end = data.find("end_header");
  if (data.compare(0, 3, "ply") != 0 || end == std::string::npos)
    fail(p, "not a PLY file (expected `ply` … `end_header`)");
  std::istringstream header(data.substr(0, end));
  std::string line, format;
  std::vector<PlyElement> elements;
  while (std::getline(header, line)) {
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "format") {
      ls >> format;
    } else if (word == "element") {
      PlyElement e;
      long long count = -1;
      if (!(ls >> e.name >> count) || count < 0) fail(p, "header: bad element line '" + line + "'");
      e.count = static_cast<std::size_t>(count);
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) fail(p, "header: a property before any element");
      PlyProperty prop;
      std::string type;
      ls >> type;
      if (type == "list") {
        ls >> prop.count_type >> prop.type >> prop.name;
        if (ply_type_size(prop.count_type) == 0 || ply_type_size(prop.type) == 0)
          fail(p, "header: unknown list types in '" + line + "'");
      } else {
        prop.type = type;
        ls >> prop.name;
        if (ply_type_size(type) == 0) fail(p, "header: unknown property type '" + type + "'");
      }
      elements.back().properties.push_back(prop);
    }
  }
  if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian")
    fail(p, "header: format '" + format +
                "' (expected ascii, binary_little_endian or binary_big_endian)");
  std::size_t body = end + std::strlen("end_header");
  if (body < data.size() && data[body] == '\r') ++body;
  if (body < data.size() && data[body] == '\n') ++body;
  PlyReader read(p, data, body, format == "ascii", format == "binary_big_endian");
  MeshFile m;
  std::vector<std::int64_t> poly;
  bool saw_vertices = false;
  for (const PlyElement& e : elements) {
    const bool vertex = e.name == "vertex", face = e.name == "face";
    if (vertex && e.count > kMaxVertices)
      fail(p, "more than " + std::to_string(kMaxVertices) + " vertices");
    if (face && e.count > kMaxTriangles)
      fail(p, "more than " + std::to_string(kMaxTriangles) + " faces");
    if (vertex) {
      saw_vertices = true;
      for (const char* axis : {"x", "y", "z"})
        if (std::none_of(e.properties.begin(), e.properties.end(), [&](const PlyProperty& q) {
              return q.name == axis && q.count_type.empty();
            }))
          fail(p, std::string("header: the vertex element has no property ") + axis);
    }
    for (std::size_t i = 0; i < e.count; ++i) {
      const std::string where = e.name + " " + std::to_string(i);
      double xyz[3] = {0, 0, 0};
      poly.clear();
      for (const PlyProperty& q : e.properties) {
        if (!q.count_type.empty()) {
          const double n = read.value(q.count_type, where);
          if (!(n >= 0 && n <= 1000))
            fail(p, where + ": a list of " + std::to_string(n) + " items");
          for (int k = 0; k < static_cast<int>(n); ++k) {
            const double v = read.value(q.type, where);
            if (face && (q.name == "vertex_indices" || q.name == "vertex_index"))
              poly.push_back(static_cast<std::int64_t>(v));
          }
          continue;
        }
        const double v = read.value(q.type, where);
        if (vertex && q.name == "x") xyz[0] = v;
        if (vertex && q.name == "y") xyz[1] = v;
        if (vertex && q.name == "z") xyz[2] = v;
      }
      if (vertex) add_vertex(m, p, xyz[0], xyz[1], xyz[2], scale, where);
      if (face) add_polygon(m, p, poly, where);
    }
  }
  if (!saw_vertices) fail(p, "header: no vertex element");
  return m;
}

}  // namespace

MeshFile read_mesh_file(const std::filesystem::path& path, double scale) {
  if (!(std::isfinite(scale) && scale > 0))
    throw Error(path.string() + ": the scale must be a number > 0");
  const std::string ext = lower(path.extension().string());
  if (ext != ".obj" && ext != ".stl" && ext != ".ply")
    fail(path, "expected a mesh file .obj, .stl or .ply");
  const std::string data = read_all(path);
  MeshFile m = ext == ".obj"   ? read_obj(path, data, scale)
               : ext == ".stl" ? read_stl(path, data, scale)
                               : read_ply(path, data, scale);
  if (m.triangles.empty()) fail(path, "the mesh has no triangles");
  return m;
}

}  // namespace tsf::app
