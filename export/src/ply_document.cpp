#include "tsf/export/ply_document.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <vector>

#include "tsf/common/error.h"

namespace tsf::exporter {

namespace {

std::size_t type_size(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" ||
      type == "float32")
    return 4;
  if (type == "double" || type == "float64") return 8;
  throw Error("PLY document: unknown property type '" + type + "'");
}

bool is_colour(const std::string& name) {
  return name == "red" || name == "green" || name == "blue" || name == "alpha";
}

}  // namespace

std::string finalise_ply_binary(std::string_view bytes, const std::string& comment) {
  const std::size_t end_header = bytes.find("end_header\n");
  require(bytes.substr(0, 4) == "ply\n" && end_header != std::string_view::npos,
          "PLY document: no 'ply' ... 'end_header' header");
  std::string header(bytes.substr(0, end_header + 11));
  std::istringstream lines(header);
  std::string line, element;
  std::size_t vertices = 0, faces = 0;
  bool little_endian = false, triangle_faces = false;
  struct Property {
    std::string type, name;
  };
  std::vector<Property> vertex_properties;
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    std::string word;
    words >> word;
    if (word == "format") {
      std::string format;
      words >> format;
      little_endian = format == "binary_little_endian";
    } else if (word == "element") {
      std::size_t n = 0;
      words >> element >> n;
      if (element == "vertex") vertices = n;
      if (element == "face") faces = n;
    } else if (word == "property" && element == "vertex") {
      Property p;
      words >> p.type >> p.name;
      require(p.type != "list", "PLY document: list property on vertices");
      vertex_properties.push_back(p);
    } else if (word == "property" && element == "face") {
      std::string list, count_type, index_type;
      words >> list >> count_type >> index_type;
      triangle_faces =
          list == "list" && count_type == "uchar" && (index_type == "int" || index_type == "uint");
    }
  }
  require(little_endian, "PLY document: not binary_little_endian");
  require(faces == 0 || triangle_faces, "PLY document: faces are not 'list uchar int'");

  std::size_t declared = 0, written_as_float = 0;
  for (const Property& p : vertex_properties) {
    declared += type_size(p.type);
    written_as_float += (p.type == "uchar" && is_colour(p.name)) ? 4 : type_size(p.type);
  }
  const std::size_t data = bytes.size() - header.size();
  const std::size_t face_bytes = faces * 13;

  std::string out = header;
  const std::size_t format_eol = out.find('\n', out.find("\nformat ") + 1);
  out.insert(format_eol + 1, "comment " + comment + "\n");
  if (data == vertices * declared + face_bytes) {
    out.append(bytes.substr(header.size()));
    return out;
  }
  require(data == vertices * written_as_float + face_bytes,
          "PLY document: " + std::to_string(data) + " data bytes fit neither its header (" +
              std::to_string(vertices * declared + face_bytes) + ") nor float colours (" +
              std::to_string(vertices * written_as_float + face_bytes) + ")");
  // Per property: its byte offset in the written row, its size there, and whether it is a colour
  // channel written as a float.
  struct Field {
    std::size_t from, size;
    bool float_colour;
  };
  std::vector<Field> fields;
  std::size_t from = 0;
  for (const Property& prop : vertex_properties) {
    const bool colour = prop.type == "uchar" && is_colour(prop.name);
    fields.push_back({from, colour ? 4 : type_size(prop.type), colour});
    from += fields.back().size;
  }
  const std::size_t head = out.size();
  out.resize(head + vertices * declared);
  const char* p = bytes.data() + header.size();
  char* q = &out[head];
  for (std::size_t v = 0; v < vertices; ++v, p += written_as_float) {
    for (const Field& f : fields) {
      if (f.float_colour) {
        float c;
        std::memcpy(&c, p + f.from, 4);
        const float clamped = std::isfinite(c) ? std::min(std::max(c, 0.0f), 1.0f) : 0.0f;
        *q++ = static_cast<char>(static_cast<std::uint8_t>(std::lround(clamped * 255.0f)));
      } else {
        std::memcpy(q, p + f.from, f.size);
        q += f.size;
      }
    }
  }
  out.append(p, face_bytes);
  return out;
}

}  // namespace tsf::exporter
