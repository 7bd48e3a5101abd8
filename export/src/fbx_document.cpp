#include "tsf/export/fbx_document.h"

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include <zlib.h>

#include "tsf/common/error.h"

namespace tsf::exporter {

namespace {

constexpr char kBinaryMagic[] = "Kaydara FBX Binary  ";  // 20 characters, then 0x00 0x1A 0x00
constexpr std::size_t kBinaryHeaderBytes = 27;           // magic, 0x00 0x1A 0x00, u32 version
constexpr std::size_t kFooterIdBytes = 16;
constexpr std::size_t kFooterMagicBytes = 16;
constexpr int kMaxDepth = 64;

struct Node {
  std::string name;
  std::uint64_t property_count = 0;
  std::string properties;  ///< the raw property records
  std::vector<Node> children;
};

class BinaryReader {
 public:
  BinaryReader(std::string_view bytes, bool wide) : bytes_(bytes), wide_(wide) {}

  [[noreturn]] void fail(std::size_t at, const std::string& what) const {
    throw Error("FBX binary document: " + what + " at byte " + std::to_string(at));
  }

  std::uint64_t offset(std::size_t at) const {
    const std::size_t n = wide_ ? 8 : 4;
    if (at + n > bytes_.size()) fail(at, "node header runs past the end");
    if (wide_) {
      std::uint64_t v;
      std::memcpy(&v, bytes_.data() + at, 8);
      return v;
    }
    std::uint32_t v;
    std::memcpy(&v, bytes_.data() + at, 4);
    return v;
  }

  std::size_t header_bytes() const { return wide_ ? 3 * 8 + 1 : 3 * 4 + 1; }

  bool is_null_record(std::size_t at) const {
    if (at + header_bytes() > bytes_.size()) return false;
    for (std::size_t i = 0; i < header_bytes(); ++i)
      if (bytes_[at + i] != '\0') return false;
    return true;
  }

  /// Parses the node at `at` that must end by `limit`; returns its end offset.
  std::size_t node(std::size_t at, std::size_t limit, int depth, Node& out) const {
    if (depth > kMaxDepth) fail(at, "nesting deeper than " + std::to_string(kMaxDepth));
    const std::size_t w = wide_ ? 8 : 4;
    const std::uint64_t end = offset(at);
    const std::uint64_t count = offset(at + w);
    const std::uint64_t property_bytes = offset(at + 2 * w);
    if (at + 3 * w >= bytes_.size()) fail(at, "node header runs past the end");
    const auto name_bytes = static_cast<unsigned char>(bytes_[at + 3 * w]);
    const std::size_t body = at + header_bytes() + name_bytes;
    if (end > limit || end < body || property_bytes > end - body)
      fail(at, "node end offset " + std::to_string(end) + " out of range");
    out.name.assign(bytes_.data() + at + header_bytes(), name_bytes);
    out.property_count = count;
    out.properties.assign(bytes_.data() + body, static_cast<std::size_t>(property_bytes));
    std::size_t cursor = body + static_cast<std::size_t>(property_bytes);
    while (cursor < end) {
      if (is_null_record(cursor) && cursor + header_bytes() == end) {
        cursor = end;  // the terminator of a well-formed list
        break;
      }
      Node child;
      cursor = node(cursor, static_cast<std::size_t>(end), depth + 1, child);
      out.children.push_back(std::move(child));
    }
    return static_cast<std::size_t>(end);
  }

 private:
  std::string_view bytes_;
  bool wide_;
};

std::string compress_arrays(const std::string& props);

class BinaryWriter {
 public:
  explicit BinaryWriter(bool wide) : wide_(wide) {}
  std::string out;

  void offset(std::uint64_t v) {
    if (wide_) {
      out.append(reinterpret_cast<const char*>(&v), 8);
    } else {
      const auto v32 = static_cast<std::uint32_t>(v);
      out.append(reinterpret_cast<const char*>(&v32), 4);
    }
  }
  void patch(std::size_t at, std::uint64_t v) {
    if (wide_) {
      std::memcpy(&out[at], &v, 8);
    } else {
      const auto v32 = static_cast<std::uint32_t>(v);
      std::memcpy(&out[at], &v32, 4);
    }
  }
  void null_record() { out.append(wide_ ? 25 : 13, '\0'); }

  void node(const Node& n) {
    const std::size_t start = out.size();
    offset(0);
    offset(n.property_count);
    const std::string properties = compress_arrays(n.properties);
    offset(properties.size());
    out.push_back(static_cast<char>(n.name.size()));
    out += n.name;
    out += properties;
    for (const Node& c : n.children) node(c);
    // The FBX SDK ends every nested list, and the record of a node without properties, with a
    // null record; readers require it after nested records.
    if (!n.children.empty() || n.property_count == 0) null_record();
    if (!wide_ && out.size() > UINT32_MAX)
      throw Error("FBX binary document over 4 GiB needs version 7500 (64-bit offsets)");
    patch(start, out.size());
  }

 private:
  bool wide_;
};

/// Size in bytes of the property record at `at` in `props` (type code + payload).
std::size_t property_size(const std::string& props, std::size_t at) {
  auto u32 = [&](std::size_t o) {
    std::uint32_t v = 0;
    if (o + 4 > props.size()) throw Error("FBX binary document: truncated property list");
    std::memcpy(&v, props.data() + o, 4);
    return static_cast<std::size_t>(v);
  };
  switch (props[at]) {
    case 'Y':
      return 1 + 2;
    case 'C':
      return 1 + 1;
    case 'I':
    case 'F':
      return 1 + 4;
    case 'D':
    case 'L':
      return 1 + 8;
    case 'S':
    case 'R':
      return 1 + 4 + u32(at + 1);
    case 'f':
    case 'd':
    case 'l':
    case 'i':
    case 'b':
      return 1 + 12 + u32(at + 9);  // count, encoding, compressed length, data
    default:
      throw Error(std::string("FBX binary document: unknown property type '") + props[at] + "'");
  }
}

/// Offset of property `index` in a node's property list (or npos).
std::size_t property_offset(const std::string& props, std::size_t index) {
  std::size_t at = 0;
  for (std::size_t i = 0; i < index; ++i) {
    if (at >= props.size()) return std::string::npos;
    at += property_size(props, at);
  }
  return at < props.size() ? at : std::string::npos;
}

/// The property list with every raw array of at least kCompressBytes deflated (encoding 1), as
/// the FBX SDK writes large arrays; an array that would not shrink stays raw. The arrays of one
/// node (a mesh's vertices, indices, normals, colours) are compressed in parallel.
std::string compress_arrays(const std::string& props) {
  constexpr std::size_t kCompressBytes = 1024;
  struct Span {
    std::size_t at, size;
    bool compress;
    std::vector<unsigned char> packed;
  };
  std::vector<Span> spans;
  for (std::size_t at = 0; at < props.size();) {
    const std::size_t n = property_size(props, at);
    if (n > props.size() - at) throw Error("FBX binary document: property runs past its node");
    const char type = props[at];
    bool compress = false;
    if (type == 'f' || type == 'd' || type == 'l' || type == 'i' || type == 'b') {
      std::uint32_t encoding = 0, bytes = 0;
      std::memcpy(&encoding, props.data() + at + 5, 4);
      std::memcpy(&bytes, props.data() + at + 9, 4);
      compress = encoding == 0 && bytes >= kCompressBytes;
    }
    spans.push_back({at, n, compress, {}});
    at += n;
  }
  const auto count = static_cast<std::ptrdiff_t>(spans.size());
#pragma omp parallel for schedule(dynamic, 1)
  for (std::ptrdiff_t i = 0; i < count; ++i) {
    Span& span = spans[static_cast<std::size_t>(i)];
    if (!span.compress) continue;
    const std::size_t bytes = span.size - 13;
    uLongf packed_bytes = compressBound(static_cast<uLong>(bytes));
    span.packed.resize(packed_bytes);
    const int status = compress2(span.packed.data(), &packed_bytes,
                                 reinterpret_cast<const Bytef*>(props.data() + span.at + 13),
                                 static_cast<uLong>(bytes), 1);
    if (status == Z_OK && packed_bytes < bytes)
      span.packed.resize(packed_bytes);
    else
      span.packed.clear();
  }
  std::string out;
  out.reserve(props.size());
  for (const Span& span : spans) {
    if (span.packed.empty()) {
      out.append(props, span.at, span.size);
      continue;
    }
    const std::uint32_t one = 1, size = static_cast<std::uint32_t>(span.packed.size());
    out.append(props, span.at, 5);  // type and element count
    out.append(reinterpret_cast<const char*>(&one), 4);
    out.append(reinterpret_cast<const char*>(&size), 4);
    out.append(reinterpret_cast<const char*>(span.packed.data()), span.packed.size());
  }
  return out;
}

bool is_string_property(const std::string& props, std::size_t at, const char* value) {
  if (at + 5 > props.size() || props[at] != 'S') return false;
  std::uint32_t n = 0;
  std::memcpy(&n, props.data() + at + 1, 4);
  return n == std::strlen(value) && at + 5 + n <= props.size() &&
         props.compare(at + 5, n, value) == 0;
}

Node* child(Node& n, const char* name) {
  for (Node& c : n.children)
    if (c.name == name) return &c;
  return nullptr;
}

/// Sets the double value (5th property) of the Properties70 "P" entries named `names`; returns
/// how many were set.
int set_global_double(std::vector<Node>& top, const std::vector<const char*>& names, double value) {
  int set = 0;
  for (Node& n : top) {
    if (n.name != "GlobalSettings") continue;
    Node* props70 = child(n, "Properties70");
    if (!props70) continue;
    for (Node& p : props70->children) {
      if (p.name != "P") continue;
      for (const char* name : names) {
        if (!is_string_property(p.properties, 0, name)) continue;
        const std::size_t at = property_offset(p.properties, 4);
        if (at == std::string::npos || p.properties[at] != 'D' || at + 9 > p.properties.size())
          throw Error(std::string("FBX binary document: ") + name + " is not a double");
        std::memcpy(&p.properties[at + 1], &value, 8);
        ++set;
      }
    }
  }
  return set;
}

std::string format_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

}  // namespace

std::string finalise_fbx_binary(std::string_view bytes, double unit_scale_cm) {
  if (bytes.size() < kBinaryHeaderBytes || bytes.compare(0, 20, kBinaryMagic) != 0)
    throw Error("FBX binary document: missing the 'Kaydara FBX Binary' header");
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + 23, 4);
  const bool wide = version >= 7500;
  const BinaryReader reader(bytes, wide);

  std::vector<Node> top;
  std::size_t cursor = kBinaryHeaderBytes;
  while (true) {
    if (cursor >= bytes.size()) reader.fail(cursor, "no top-level null record before the end");
    if (reader.offset(cursor) == 0) break;  // the top-level null record
    Node n;
    cursor = reader.node(cursor, bytes.size(), 0, n);
    top.push_back(std::move(n));
  }
  const std::size_t footer_id = cursor + reader.header_bytes();
  if (footer_id + kFooterIdBytes + kFooterMagicBytes > bytes.size())
    reader.fail(footer_id, "footer truncated");

  if (set_global_double(top, {"UnitScaleFactor", "OriginalUnitScaleFactor"}, unit_scale_cm) < 1)
    throw Error("FBX binary document: GlobalSettings has no UnitScaleFactor");

  BinaryWriter w(wide);
  w.out.assign(bytes.data(), kBinaryHeaderBytes);
  for (const Node& n : top) w.node(n);
  w.null_record();
  w.out.append(bytes.data() + footer_id, kFooterIdBytes);
  // Alignment to 16 bytes (a full 16 when already aligned), 4 zero bytes, the version, 120 zero
  // bytes and the closing magic, as the FBX SDK writes them.
  w.out.append(16 - w.out.size() % 16, '\0');
  w.out.append(4, '\0');
  w.out.append(reinterpret_cast<const char*>(&version), 4);
  w.out.append(120, '\0');
  w.out.append(bytes.data() + bytes.size() - kFooterMagicBytes, kFooterMagicBytes);
  return w.out;
}

std::string finalise_fbx_ascii(std::string_view text, double unit_scale_cm,
                               const std::string& comment) {
  std::string out(text);
  int set = 0;
  for (const char* key : {"\"UnitScaleFactor\"", "\"OriginalUnitScaleFactor\""}) {
    const std::string prefix = std::string("P: ") + key + ", \"double\", \"Number\", \"\", ";
    const std::size_t at = out.find(prefix);
    if (at == std::string::npos) continue;
    const std::size_t value = at + prefix.size();
    const std::size_t eol = out.find('\n', value);
    out.replace(value, (eol == std::string::npos ? out.size() : eol) - value,
                format_double(unit_scale_cm));
    ++set;
  }
  require(set > 0, "FBX ASCII document: GlobalSettings has no UnitScaleFactor");
  std::string lines;
  std::size_t begin = 0;
  while (begin <= comment.size()) {
    const std::size_t end = comment.find('\n', begin);
    lines += "; " +
             comment.substr(begin, end == std::string::npos ? std::string::npos : end - begin) +
             "\n";
    if (end == std::string::npos) break;
    begin = end + 1;
  }
  const std::size_t first_eol = out.find('\n');
  out.insert(first_eol == std::string::npos ? out.size() : first_eol + 1, lines);
  return out;
}

double fbx_unit_scale(std::string_view bytes) {
  if (bytes.size() >= kBinaryHeaderBytes && bytes.compare(0, 20, kBinaryMagic) == 0) {
    std::uint32_t version = 0;
    std::memcpy(&version, bytes.data() + 23, 4);
    const BinaryReader reader(bytes, version >= 7500);
    std::size_t cursor = kBinaryHeaderBytes;
    while (cursor < bytes.size() && reader.offset(cursor) != 0) {
      Node n;
      cursor = reader.node(cursor, bytes.size(), 0, n);
      if (n.name != "GlobalSettings") continue;
      Node* props70 = child(n, "Properties70");
      for (Node& p : props70 ? props70->children : n.children) {
        if (p.name != "P" || !is_string_property(p.properties, 0, "UnitScaleFactor")) continue;
        const std::size_t at = property_offset(p.properties, 4);
        if (at == std::string::npos || p.properties[at] != 'D' || at + 9 > p.properties.size())
          break;
        double v;
        std::memcpy(&v, p.properties.data() + at + 1, 8);
        return v;
      }
    }
    throw Error("FBX binary document: no UnitScaleFactor");
  }
  const std::string prefix = "P: \"UnitScaleFactor\", \"double\", \"Number\", \"\", ";
  const std::size_t at = bytes.find(prefix);
  if (at == std::string_view::npos) throw Error("FBX ASCII document: no UnitScaleFactor");
  return std::stod(std::string(bytes.substr(at + prefix.size(), 32)));
}

}  // namespace tsf::exporter
