// The OpenIGTLink messages tsf speaks, as bytes (docs/live.md, "Messages"): the 58-byte header
// (versions 1 and 2), TRANSFORM and STRING in, GET_/STT_/STP_POLYDATA in, POLYDATA and SENSOR
// out. Packing, byte order and CRC-64 are libopenigtlink's C codec (igtl_*.h); what is checked
// before anything is believed (header text, body sizes, CRC) is here.
//
// Frames: OpenIGTLink's POLYDATA and TRANSFORM carry no frame. 3D Slicer's OpenIGTLinkIF copies
// their coordinates into its scene unchanged, and Slicer's scene is RAS; tsf works in patient
// LPS. So the link speaks RAS by default (WireFrame::kRas: x and y negated, a rotation by 180°
// about S, so windings are unchanged) and LPS on request.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "tsf/common/vec3.h"
#include "tsf/imt/surface_mesh.h"

namespace tsf::link {

/// The frame of the coordinates on the wire.
enum class WireFrame { kRas, kLps };
const char* to_string(WireFrame frame);
/// "ras" | "lps"; throws tsf::Error naming `option` and the text otherwise.
WireFrame wire_frame_from_string(const std::string& text, const std::string& option);

/// Patient LPS → wire frame, and back (the same map: it is its own inverse).
inline Vec3d lps_to_wire(const Vec3d& p, WireFrame f) {
  return f == WireFrame::kRas ? Vec3d{-p.x, -p.y, p.z} : p;
}
inline Vec3d wire_to_lps(const Vec3d& p, WireFrame f) {
  return lps_to_wire(p, f);
}

constexpr std::size_t kHeaderSize = 58;
constexpr std::size_t kDeviceNameSize = 20;  ///< device names longer than this are cut

struct Header {
  std::uint16_t version = 1;
  std::string type;             ///< "TRANSFORM", "GET_POLYDATA", …
  std::string device;           ///< the device name ("Tracker", "StylusToReference")
  std::uint64_t timestamp = 0;  ///< OpenIGTLink format: seconds << 32 | fraction of a second
  std::uint64_t body_size = 0;
  std::uint64_t crc = 0;
};

/// Reads and checks kHeaderSize bytes: version 1 or 2, a type name of upper-case letters,
/// digits and '_' padded with NULs, a device name of printable ASCII padded with NULs. Returns
/// an empty string when the header is well formed, else what is wrong with it.
std::string parse_header(const std::uint8_t* bytes, Header& out);

/// What the reader does with a message's body.
enum class BodyAction {
  kRead,    ///< read it whole (a message tsf acts on), then check its CRC
  kSkip,    ///< discard its bytes as they come (a type tsf does not act on); nothing is kept
  kRefuse,  ///< close the connection: the body cannot be what the header says
};

struct BodyPlan {
  BodyAction action = BodyAction::kSkip;
  std::string why;  ///< kRefuse: the reason
};

/// Limits of what a peer may send (docs/live.md, "A peer that misbehaves").
struct BodyLimits {
  std::uint64_t max_read_bytes = 64 * 1024;             ///< a message tsf reads (TRANSFORM, STRING)
  std::uint64_t max_skip_bytes = 256ull * 1024 * 1024;  ///< a message tsf skips
};

/// Decides from the header alone: TRANSFORM (48 bytes of matrix, plus the extended header and
/// meta data of a version 2 header), STRING, GET_/STT_/STP_POLYDATA are read (at most
/// max_read_bytes); other types are skipped up to max_skip_bytes; anything else is refused.
BodyPlan plan_body(const Header& header, const BodyLimits& limits);

/// Whether `body` (header.body_size bytes) has the header's CRC-64.
bool body_crc_ok(const Header& header, const std::uint8_t* body, std::size_t size);

/// The message's own content inside a body: the whole body for version 1; for version 2 the
/// part after the extended header and before the meta data. Empty optional (and `why`) when the
/// extended header does not fit the body.
struct Span {
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};
std::optional<Span> message_content(const Header& header, const std::uint8_t* body,
                                    std::size_t size, std::string& why);

/// A 4×4 homogeneous transform, row-major, millimetres.
using Matrix4 = std::array<std::array<double, 4>, 4>;
Matrix4 identity_matrix();
Matrix4 multiply(const Matrix4& a, const Matrix4& b);

/// TRANSFORM content (12 big-endian float32: the rotation's columns, then the translation).
/// Empty optional (and `why`) when it is not 48 bytes or a value is not finite.
std::optional<Matrix4> unpack_transform(const Span& content, std::string& why);
/// STRING content (encoding, length, bytes). Empty optional (and `why`) when the length does
/// not fit.
std::optional<std::string> unpack_string(const Span& content, std::string& why);

/// A whole message (header and body) of `type` for `device` with `body`, CRC computed.
std::vector<std::uint8_t> pack_message(const std::string& type, const std::string& device,
                                       std::uint64_t timestamp,
                                       const std::vector<std::uint8_t>& body);

/// POLYDATA of a triangle mesh whose positions and normals are already in the wire frame:
/// points, one polygon per triangle, and the point attributes "Normals" (POINT_NORMAL, when the
/// mesh has normals) and "TissueLabel" (POINT_SCALAR, when it has labels).
std::vector<std::uint8_t> pack_polydata(const imt::SurfaceMesh& mesh, const std::string& device,
                                        std::uint64_t timestamp);

/// TRANSFORM (tests and peers).
std::vector<std::uint8_t> pack_transform(const Matrix4& m, const std::string& device,
                                         std::uint64_t timestamp);
/// STRING, US-ASCII (tests and peers).
std::vector<std::uint8_t> pack_string(const std::string& text, const std::string& device,
                                      std::uint64_t timestamp);
/// A message with an empty body (GET_POLYDATA, STT_POLYDATA, …).
std::vector<std::uint8_t> pack_empty(const std::string& type, const std::string& device,
                                     std::uint64_t timestamp);

/// SENSOR of 3 float64 in newtons: a force.
std::vector<std::uint8_t> pack_force_sensor(const Vec3d& force_n, const std::string& device,
                                            std::uint64_t timestamp);

/// The wall clock (CLOCK_REALTIME) in OpenIGTLink's timestamp format.
std::uint64_t timestamp_now();
/// Seconds since the epoch of an OpenIGTLink timestamp.
double timestamp_seconds(std::uint64_t timestamp);

}  // namespace tsf::link
