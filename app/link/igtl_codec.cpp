#include "link/igtl_codec.h"

#include <igtl_header.h>
#include <igtl_polydata.h>
#include <igtl_sensor.h>
#include <igtl_transform.h>
#include <igtl_unit.h>
#include <igtl_util.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "tsf/common/error.h"

namespace tsf::link {
namespace {

std::uint16_t be16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}
std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}
std::uint64_t be64(const std::uint8_t* p) {
  return (std::uint64_t{be32(p)} << 32) | be32(p + 4);
}

/// `n` bytes of a NUL-padded text field; false when a byte is not allowed or text follows a NUL.
template <typename Allowed>
bool text_field(const std::uint8_t* p, std::size_t n, Allowed allowed, std::string& out) {
  out.clear();
  bool ended = false;
  for (std::size_t i = 0; i < n; ++i) {
    if (p[i] == 0) {
      ended = true;
      continue;
    }
    if (ended || !allowed(p[i])) return false;
    out.push_back(static_cast<char>(p[i]));
  }
  return true;
}

bool is_type_char(std::uint8_t c) {
  return (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}
bool is_name_char(std::uint8_t c) {
  return c >= 0x20 && c < 0x7f;
}

/// The types tsf reads: what it acts on.
bool read_type(const std::string& t) {
  return t == "TRANSFORM" || t == "STRING" || t == "GET_POLYDATA" || t == "STT_POLYDATA" ||
         t == "STP_POLYDATA";
}

/// Fills an igtl_header for `body` and writes it (network order) at `out`.
void write_header(const std::string& type, const std::string& device, std::uint64_t timestamp,
                  const std::uint8_t* body, std::size_t body_size, std::uint8_t* out) {
  igtl_header h;
  std::memset(&h, 0, sizeof h);
  h.version = 1;
  // NUL-padded, not NUL-terminated at full length (OpenIGTLink's fields).
  std::memcpy(h.name, type.data(), std::min<std::size_t>(type.size(), IGTL_HEADER_TYPE_SIZE));
  std::memcpy(h.device_name, device.data(),
              std::min<std::size_t>(device.size(), IGTL_HEADER_NAME_SIZE));
  h.timestamp = timestamp;
  h.body_size = body_size;
  h.crc = crc64(const_cast<unsigned char*>(body), body_size, 0);
  igtl_header_convert_byte_order(&h);
  std::memcpy(out, &h, kHeaderSize);
}

}  // namespace

const char* to_string(WireFrame frame) {
  return frame == WireFrame::kRas ? "ras" : "lps";
}

WireFrame wire_frame_from_string(const std::string& text, const std::string& option) {
  if (text == "ras") return WireFrame::kRas;
  if (text == "lps") return WireFrame::kLps;
  throw Error(option + ": expected ras (3D Slicer's scene) or lps (DICOM's patient frame), got '" +
              text + "'");
}

std::string parse_header(const std::uint8_t* bytes, Header& out) {
  static_assert(sizeof(igtl_header) == kHeaderSize, "the OpenIGTLink header is 58 bytes");
  out.version = be16(bytes);
  if (out.version != 1 && out.version != 2)
    return "header version " + std::to_string(out.version) + " (expected 1 or 2)";
  if (!text_field(bytes + 2, IGTL_HEADER_TYPE_SIZE, is_type_char, out.type) || out.type.empty())
    return "the message type is not OpenIGTLink's (upper-case letters, digits, '_')";
  if (!text_field(bytes + 14, IGTL_HEADER_NAME_SIZE, is_name_char, out.device))
    return "the device name of a " + out.type + " is not printable text";
  out.timestamp = be64(bytes + 34);
  out.body_size = be64(bytes + 42);
  out.crc = be64(bytes + 50);
  return {};
}

BodyPlan plan_body(const Header& h, const BodyLimits& limits) {
  BodyPlan plan;
  const std::string what = h.type + " '" + h.device + "'";
  if (!read_type(h.type)) {
    if (h.body_size > limits.max_skip_bytes) {
      plan.action = BodyAction::kRefuse;
      plan.why = what + " claims a body of " + std::to_string(h.body_size) +
                 " bytes (more than the " + std::to_string(limits.max_skip_bytes) +
                 " a message may have)";
    }
    return plan;  // skipped
  }
  plan.action = BodyAction::kRead;
  if (h.body_size > limits.max_read_bytes) {
    plan.action = BodyAction::kRefuse;
    plan.why = what + " claims a body of " + std::to_string(h.body_size) + " bytes (at most " +
               std::to_string(limits.max_read_bytes) + " expected)";
  } else if (h.type == "TRANSFORM" && h.version == 1 && h.body_size != 48) {
    plan.action = BodyAction::kRefuse;
    plan.why = what + " has a body of " + std::to_string(h.body_size) + " bytes (48 expected)";
  }
  return plan;
}

bool body_crc_ok(const Header& header, const std::uint8_t* body, std::size_t size) {
  return crc64(const_cast<unsigned char*>(body), size, 0) == header.crc;
}

std::optional<Span> message_content(const Header& header, const std::uint8_t* body,
                                    std::size_t size, std::string& why) {
  if (header.version == 1) return Span{body, size};
  // Version 2: extended header (its size, the meta-data header's size, the meta data's size, a
  // message id), the content, then the meta-data header and the meta data.
  if (size < 12) {
    why = "a version 2 body shorter than its 12-byte extended header";
    return std::nullopt;
  }
  const std::uint64_t ext = be16(body);
  const std::uint64_t meta = std::uint64_t{be16(body + 2)} + be32(body + 4);
  if (ext < 12 || ext + meta > size) {
    why = "a version 2 extended header (" + std::to_string(ext) + " + " + std::to_string(meta) +
          " bytes of meta data) larger than its body (" + std::to_string(size) + " bytes)";
    return std::nullopt;
  }
  return Span{body + ext, static_cast<std::size_t>(size - ext - meta)};
}

Matrix4 identity_matrix() {
  Matrix4 m{};
  for (int i = 0; i < 4; ++i) m[i][i] = 1.0;
  return m;
}

Matrix4 multiply(const Matrix4& a, const Matrix4& b) {
  Matrix4 c{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) c[i][j] += a[i][k] * b[k][j];
  return c;
}

std::optional<Matrix4> unpack_transform(const Span& content, std::string& why) {
  if (content.size != 48) {
    why = "a TRANSFORM of " + std::to_string(content.size) + " bytes (48 expected)";
    return std::nullopt;
  }
  igtl_float32 v[12];
  std::memcpy(v, content.data, sizeof v);
  igtl_transform_convert_byte_order(v);
  Matrix4 m = identity_matrix();
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) m[r][c] = v[3 * c + r];
  for (int r = 0; r < 3; ++r) m[r][3] = v[9 + r];
  for (const auto& row : m)
    for (double x : row)
      if (!std::isfinite(x)) {
        why = "a TRANSFORM with a value that is not finite";
        return std::nullopt;
      }
  return m;
}

std::optional<std::string> unpack_string(const Span& content, std::string& why) {
  if (content.size < 4 || be16(content.data + 2) > content.size - 4) {
    why = "a STRING whose length does not fit its body";
    return std::nullopt;
  }
  return std::string(reinterpret_cast<const char*>(content.data + 4), be16(content.data + 2));
}

std::vector<std::uint8_t> pack_message(const std::string& type, const std::string& device,
                                       std::uint64_t timestamp,
                                       const std::vector<std::uint8_t>& body) {
  std::vector<std::uint8_t> m(kHeaderSize + body.size());
  std::copy(body.begin(), body.end(), m.begin() + kHeaderSize);
  write_header(type, device, timestamp, m.data() + kHeaderSize, body.size(), m.data());
  return m;
}

std::vector<std::uint8_t> pack_polydata(const imt::SurfaceMesh& mesh, const std::string& device,
                                        std::uint64_t timestamp) {
  if (mesh.positions.size() > 0xffffffffu || mesh.triangles.size() > 0x3fffffffu)
    throw Error("POLYDATA: the surface is too large for OpenIGTLink's 32-bit counts");
  std::vector<igtl_uint32> polygons;
  polygons.reserve(4 * mesh.triangles.size());
  for (const auto& t : mesh.triangles) polygons.insert(polygons.end(), {3u, t[0], t[1], t[2]});
  std::vector<igtl_float32> labels;
  char normals_name[] = "Normals";
  char labels_name[] = "TissueLabel";
  igtl_polydata_attribute attributes[2];
  igtl_polydata_info info;
  igtl_polydata_init_info(&info);
  info.header.npoints = static_cast<igtl_uint32>(mesh.positions.size());
  info.header.npolygons = static_cast<igtl_uint32>(mesh.triangles.size());
  info.header.size_polygons = static_cast<igtl_uint32>(polygons.size() * sizeof(igtl_uint32));
  // The codec reads the arrays only; it takes non-const pointers.
  info.points =
      const_cast<igtl_float32*>(reinterpret_cast<const igtl_float32*>(mesh.positions.data()));
  info.polygons = polygons.empty() ? nullptr : polygons.data();
  static_assert(sizeof(Vec3f) == 3 * sizeof(igtl_float32), "Vec3f is three packed floats");
  if (!mesh.normals.empty() && mesh.normals.size() == mesh.positions.size())
    attributes[info.header.nattributes++] = {
        IGTL_POLY_ATTR_TYPE_NORMAL, 3, info.header.npoints, normals_name,
        const_cast<igtl_float32*>(reinterpret_cast<const igtl_float32*>(mesh.normals.data()))};
  if (!mesh.labels.empty() && mesh.labels.size() == mesh.positions.size()) {
    labels.assign(mesh.labels.begin(), mesh.labels.end());
    attributes[info.header.nattributes++] = {IGTL_POLY_ATTR_TYPE_SCALAR, 1, info.header.npoints,
                                             labels_name, labels.data()};
  }
  info.attributes = info.header.nattributes > 0 ? attributes : nullptr;
  const igtl_uint64 size = igtl_polydata_get_size(&info, IGTL_TYPE_PREFIX_NONE);
  std::vector<std::uint8_t> m(kHeaderSize + size);
  if (igtl_polydata_pack(&info, m.data() + kHeaderSize, IGTL_TYPE_PREFIX_NONE) == 0)
    throw Error("POLYDATA: the OpenIGTLink codec refused the surface");
  write_header("POLYDATA", device, timestamp, m.data() + kHeaderSize, size, m.data());
  return m;  // info's arrays are ours: igtl_polydata_free_info is not called
}

std::vector<std::uint8_t> pack_transform(const Matrix4& m, const std::string& device,
                                         std::uint64_t timestamp) {
  igtl_float32 v[12];
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) v[3 * c + r] = static_cast<igtl_float32>(m[r][c]);
  for (int r = 0; r < 3; ++r) v[9 + r] = static_cast<igtl_float32>(m[r][3]);
  igtl_transform_convert_byte_order(v);
  std::vector<std::uint8_t> body(sizeof v);
  std::memcpy(body.data(), v, sizeof v);
  return pack_message("TRANSFORM", device, timestamp, body);
}

std::vector<std::uint8_t> pack_string(const std::string& text, const std::string& device,
                                      std::uint64_t timestamp) {
  const std::size_t n = std::min<std::size_t>(text.size(), 0xffff);
  std::vector<std::uint8_t> body(4 + n);
  body[0] = 0;
  body[1] = 3;  // IANA MIBenum 3: US-ASCII
  body[2] = static_cast<std::uint8_t>(n >> 8);
  body[3] = static_cast<std::uint8_t>(n & 0xff);
  std::copy(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(n), body.begin() + 4);
  return pack_message("STRING", device, timestamp, body);
}

std::vector<std::uint8_t> pack_empty(const std::string& type, const std::string& device,
                                     std::uint64_t timestamp) {
  return pack_message(type, device, timestamp, {});
}

std::vector<std::uint8_t> pack_force_sensor(const Vec3d& force_n, const std::string& device,
                                            std::uint64_t timestamp) {
  igtl_unit_data unit;
  igtl_unit_init(&unit);
  unit.unit[0] = IGTL_UNIT_SI_DERIVED_NEWTON;
  unit.exp[0] = 1;
  igtl_sensor_header h;
  h.larray = 3;
  h.status = 0;
  h.unit = igtl_unit_pack(&unit);
  igtl_float64 data[3] = {force_n.x, force_n.y, force_n.z};
  igtl_sensor_convert_byte_order(&h, data);
  std::vector<std::uint8_t> body(IGTL_SENSOR_HEADER_SIZE + sizeof data);
  std::memcpy(body.data(), &h, IGTL_SENSOR_HEADER_SIZE);
  std::memcpy(body.data() + IGTL_SENSOR_HEADER_SIZE, data, sizeof data);
  return pack_message("SENSOR", device, timestamp, body);
}

std::uint64_t timestamp_now() {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  const auto sec = static_cast<std::uint64_t>(ns / 1'000'000'000);
  const auto nsec = static_cast<igtl_uint32>(ns % 1'000'000'000);
  return (sec << 32) | igtl_nanosec_to_frac(nsec);
}

double timestamp_seconds(std::uint64_t timestamp) {
  return static_cast<double>(timestamp >> 32) +
         igtl_frac_to_nanosec(static_cast<igtl_uint32>(timestamp & 0xffffffffu)) * 1e-9;
}

}  // namespace tsf::link
