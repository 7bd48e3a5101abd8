#include "link/link_session.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>

#include "tsf/common/error.h"

namespace tsf::link {
namespace {

using nlohmann::json;

constexpr std::size_t kTraceLength = 2000;  // applied poses kept for the report

bool valid_name(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](unsigned char c) {
    return std::isprint(c) && c != ':' && c != '=' && c != ',';
  });
}

Vec3d column(const Matrix4& m, int c) {
  return {m[0][c], m[1][c], m[2][c]};
}

/// The wire frame's 3×3 map to patient LPS (diagonal).
Vec3d frame_signs(WireFrame f) {
  return f == WireFrame::kRas ? Vec3d{-1, -1, 1} : Vec3d{1, 1, 1};
}

}  // namespace

void add_link_options(CLI::App& sub, LinkOptions& o, int default_port, bool tools) {
  o.port = default_port;
  const std::string g = "Live link (OpenIGTLink, docs/live.md)";
  sub.add_option("--igtl-port", o.port,
                 tools ? "Serve OpenIGTLink on this TCP port (3D Slicer's default is 18944; 0: any "
                         "free port, printed; -1: do not listen, only --igtl-connect)"
                       : "Serve the deformed, cut surface as OpenIGTLink POLYDATA on this TCP "
                         "port (3D Slicer's default is 18944; 0: any free port, printed)")
      ->check(CLI::Range(-1, 65535))
      ->group(g);
  sub.add_option("--igtl-bind", o.bind,
                 "Address to listen on (default 127.0.0.1: this machine only; 0.0.0.0: every "
                 "network interface, for a Slicer on another machine)")
      ->group(g);
  if (tools) {
    sub.add_option("--igtl-connect", o.connect,
                   "Also connect to an OpenIGTLink server at HOST:PORT (a PlusServer, or Slicer "
                   "as a server) and take its TRANSFORMs; repeatable")
        ->group(g);
    sub.add_option("--igtl-tool", o.tools,
                   "TOOL[=DEVICE][:MODE]: the scene's TOOL follows the TRANSFORM named DEVICE "
                   "(default: TOOL) in MODE (press, ablate, cut or idle; default press); "
                   "repeatable (default: every scene tool follows the TRANSFORM of its own name)")
        ->group(g);
  }
  sub.add_option("--igtl-frame", o.frame,
                 "Frame of the coordinates on the wire: ras (3D Slicer's scene, the default) or "
                 "lps (DICOM's patient frame)")
      ->check(CLI::IsMember({"ras", "lps"}))
      ->group(g);
  sub.add_option("--igtl-rate", o.rate_hz, "POLYDATA per second at most (default 30)")
      ->check(CLI::Range(0.1, 1000.0))
      ->group(g);
  if (tools)
    sub.add_option("--igtl-registration", o.registration,
                   "Text file of a rigid 4x4 matrix (rows, mm) from the tracker's reference frame "
                   "to the wire frame, applied to every TRANSFORM received")
        ->check(CLI::ExistingFile)
        ->group(g);
  sub.add_option("--igtl-name", o.name,
                 "Device name of the POLYDATA (default: the scene's name; at most 20 characters)")
      ->group(g);
}

ToolBinding parse_tool_binding(const std::string& text) {
  ToolBinding b;
  std::string rest = text;
  const std::size_t colon = rest.rfind(':');
  if (colon != std::string::npos) {
    const std::string mode = rest.substr(colon + 1);
    rest = rest.substr(0, colon);
    try {
      b.mode = interaction::tool_mode_from_string(mode);
    } catch (const Error&) {
      throw Error("--igtl-tool " + text + ": mode '" + mode +
                  "': expected press, ablate, cut or idle");
    }
  }
  const std::size_t eq = rest.find('=');
  b.tool = rest.substr(0, eq);
  b.device = eq == std::string::npos ? b.tool : rest.substr(eq + 1);
  if (!valid_name(b.tool) || !valid_name(b.device))
    throw Error("--igtl-tool " + text +
                ": expected TOOL[=DEVICE][:MODE] (a scene tool's name, the TRANSFORM's device "
                "name, e.g. wand=StylusTipToReference:ablate)");
  if (b.device.size() > kDeviceNameSize)
    throw Error("--igtl-tool " + text + ": device name '" + b.device + "' is longer than " +
                std::to_string(kDeviceNameSize) + " characters (OpenIGTLink's limit)");
  return b;
}

Matrix4 read_registration(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw Error(file + ": cannot read the registration matrix");
  std::vector<double> v;
  std::string word;
  while (in >> word) {
    char* end = nullptr;
    const double x = std::strtod(word.c_str(), &end);
    if (end == nullptr || *end != '\0' || !std::isfinite(x))
      throw Error(file + ": '" + word +
                  "' is not a number (expected 12 or 16 numbers: a 4x4 "
                  "matrix, rows, mm)");
    v.push_back(x);
  }
  if (v.size() != 12 && v.size() != 16)
    throw Error(file + ": " + std::to_string(v.size()) +
                " numbers (expected 12 or 16: a 4x4 matrix, rows, mm)");
  Matrix4 m = identity_matrix();
  for (std::size_t i = 0; i < v.size(); ++i) m[i / 4][i % 4] = v[i];
  if (v.size() == 16 && (std::abs(m[3][0]) + std::abs(m[3][1]) + std::abs(m[3][2]) > 1e-9 ||
                         std::abs(m[3][3] - 1.0) > 1e-9))
    throw Error(file + ": the last row is not 0 0 0 1");
  if (!rotation_of(m))
    throw Error(file + ": the 3x3 part is not a rotation (a rigid registration is expected)");
  return m;
}

std::optional<Rotation> rotation_of(const Matrix4& m) {
  const Vec3d c0 = column(m, 0), c1 = column(m, 1), c2 = column(m, 2);
  const double det = dot(c0, cross(c1, c2));
  if (!(det > 0.5) || std::abs(length(c0) - 1) > 0.05 || std::abs(length(c1) - 1) > 0.05 ||
      std::abs(length(c2) - 1) > 0.05 || std::abs(dot(c0, c1)) > 0.05 ||
      std::abs(dot(c0, c2)) > 0.05 || std::abs(dot(c1, c2)) > 0.05)
    return std::nullopt;
  // Shepperd: the largest of w², x², y², z² first (stable for every rotation).
  const double t = m[0][0] + m[1][1] + m[2][2];
  Rotation q;
  if (t > m[0][0] && t > m[1][1] && t > m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + t);
    q = {0.25 * s, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s};
  } else if (m[0][0] >= m[1][1] && m[0][0] >= m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]);
    q = {(m[2][1] - m[1][2]) / s, 0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s};
  } else if (m[1][1] >= m[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]);
    q = {(m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]);
    q = {(m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s};
  }
  return q.normalized();
}

ToolPose patient_pose_to_tissue(const ToolPose& lps, const VolumeGeometry& frame) {
  ToolPose t;
  t.position = frame.index_to_tissue(frame.physical_to_index(lps.position));
  // R_tissue = Dᵀ·R (and the tool's own z mirrored when D mirrors): as a matrix, then back to a
  // quaternion.
  Matrix4 m = identity_matrix();
  for (int c = 0; c < 3; ++c) {
    Vec3d axis{c == 0 ? 1.0 : 0.0, c == 1 ? 1.0 : 0.0, c == 2 ? 1.0 : 0.0};
    Vec3d v = frame.direction_to_tissue(lps.orientation.apply(axis));
    if (c == 2 && frame.mirrors()) v = v * -1.0;
    m[0][c] = v.x;
    m[1][c] = v.y;
    m[2][c] = v.z;
  }
  t.orientation = rotation_of(m).value_or(Rotation{});
  return t;
}

std::optional<ToolPose> wire_matrix_to_patient_pose(const Matrix4& wire, WireFrame frame,
                                                    const std::optional<Matrix4>& registration) {
  Matrix4 m = registration ? multiply(*registration, wire) : wire;
  // Wire → LPS: the diagonal F on the left (F·M; F = F⁻¹).
  const Vec3d sign = frame_signs(frame);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) m[r][c] *= sign[r];
  const std::optional<Rotation> rot = rotation_of(m);
  if (!rot) return std::nullopt;
  return ToolPose{{m[0][3], m[1][3], m[2][3]}, *rot};
}

LinkSession::LinkSession(const LinkOptions& options, std::vector<NamedTool> tools,
                         const std::string& surface_name)
    : options_(options), tools_(std::move(tools)) {
  frame_ = wire_frame_from_string(options.frame, "--igtl-frame");
  if (!options.registration.empty()) registration_ = read_registration(options.registration);
  if (options.tools.empty())
    for (const NamedTool& t : tools_) bindings_.push_back({t.name, t.name.substr(0, 20), {}});
  for (const std::string& text : options.tools) bindings_.push_back(parse_tool_binding(text));
  for (const ToolBinding& b : bindings_) {
    const auto it = std::find_if(tools_.begin(), tools_.end(),
                                 [&](const NamedTool& t) { return t.name == b.tool; });
    if (it == tools_.end()) {
      std::string names;
      for (const NamedTool& t : tools_) names += (names.empty() ? "" : ", ") + t.name;
      throw Error("--igtl-tool: the scene has no tool '" + b.tool +
                  "' (its tools: " + (names.empty() ? "none" : names) + ")");
    }
    if (!it->tool.supports(b.mode))
      throw Error("--igtl-tool: tool '" + b.tool + "' cannot " + interaction::to_string(b.mode) +
                  " (ablate: a sphere or capsule; cut: a blade)");
    for (std::size_t k = 0; k < binding_tool_.size(); ++k)
      if (bindings_[k].tool == b.tool)
        throw Error("--igtl-tool: tool '" + b.tool + "' is bound twice");
    binding_tool_.push_back(static_cast<std::size_t>(it - tools_.begin()));
  }
  state_.resize(bindings_.size());
  surface_name_ = options.name.empty() ? surface_name : options.name;
  if (surface_name_.size() > kDeviceNameSize) surface_name_.resize(kDeviceNameSize);
  ServerOptions so;
  so.listen = {options.bind, options.port};
  for (const std::string& c : options.connect)
    so.connect.push_back(parse_endpoint(c, "--igtl-connect"));
  server_ = std::make_unique<LinkServer>(so);
  start_ = std::chrono::steady_clock::now();
}

std::vector<LinkSession::Drive> LinkSession::drives(const VolumeGeometry& frame, double time_s) {
  std::vector<Drive> out;
  for (std::size_t b = 0; b < bindings_.size(); ++b) {
    BindingState& st = state_[b];
    Drive d;
    d.binding = b;
    d.tool = binding_tool_[b];
    d.mode = bindings_[b].mode;
    if (const auto text = server_->text(bindings_[b].device);
        text && text->second != st.mode_seen) {
      st.mode_seen = text->second;
      // A mode the tool cannot do, or text that is no mode, is ignored (the mode stays).
      try {
        const interaction::ToolMode m = interaction::tool_mode_from_string(text->first);
        if (tools_[d.tool].tool.supports(m)) st.mode_override = m;
      } catch (const Error&) {
      }
    }
    if (st.mode_override) d.mode = *st.mode_override;
    const std::optional<PoseUpdate> u = server_->pose(bindings_[b].device);
    if (u) {
      const std::optional<ToolPose> lps =
          wire_matrix_to_patient_pose(u->matrix, frame_, registration_);
      if (!lps) {
        if (u->count != st.seen) ++st.rejected;
        st.seen = u->count;
      } else {
        d.held = true;
        d.fresh = u->count != st.seen;
        d.pose = patient_pose_to_tissue(*lps, frame);
        if (d.fresh) {
          st.seen = u->count;
          st.stamp = u->timestamp;
          ++st.applied;
          st.trace.push_back({time_s, lps->position.x, lps->position.y, lps->position.z,
                              static_cast<double>(u->count)});
          if (st.trace.size() > kTraceLength) st.trace.pop_front();
        }
      }
    }
    st.held = d.held;
    out.push_back(d);
  }
  return out;
}

void LinkSession::send_force(std::size_t b, const Vec3d& force_tissue_un,
                             const VolumeGeometry& frame) {
  const Vec3d lps = frame.direction_to_patient(force_tissue_un) * 1e-6;  // µN → N
  server_->send_force(bindings_.at(b).device, lps_to_wire(lps, frame_), state_.at(b).stamp);
}

bool LinkSession::surface_due() const {
  return surfaces_published_ == 0 ||
         std::chrono::duration<double>(std::chrono::steady_clock::now() - last_surface_).count() >=
             1.0 / options_.rate_hz;
}

void LinkSession::publish_surface(const imt::SurfaceMesh& mesh_lps, const std::string& suffix) {
  auto wire = std::make_shared<imt::SurfaceMesh>(mesh_lps);
  if (frame_ == WireFrame::kRas) {
    for (Vec3f& p : wire->positions) p = {-p.x, -p.y, p.z};
    for (Vec3f& n : wire->normals) n = {-n.x, -n.y, n.z};
  }
  last_vertices_ = wire->positions.size();
  last_triangles_ = wire->triangles.size();
  std::string name = suffix.empty() ? surface_name_ : surface_name_ + "-" + suffix;
  if (name.size() > kDeviceNameSize) name.resize(kDeviceNameSize);
  server_->publish_surface(name, std::move(wire), timestamp_now());
  last_surface_ = std::chrono::steady_clock::now();
  ++surfaces_published_;
}

std::string LinkSession::describe() const {
  std::string s;
  if (server_->port() >= 0)
    s = "listening on " + options_.bind + ":" + std::to_string(server_->port());
  for (const std::string& c : options_.connect)
    s += (s.empty() ? "connecting to " : ", connecting to ") + c;
  s += std::string(" (coordinates ") + (frame_ == WireFrame::kRas ? "RAS" : "LPS") + ", surface '" +
       surface_name_ + "'";
  if (registration_) s += ", registration " + options_.registration;
  s += ")";
  if (!bindings_.empty()) s += "; tools:";
  for (const ToolBinding& b : bindings_)
    s += " " + b.tool + " <- TRANSFORM '" + b.device + "' (" + interaction::to_string(b.mode) + ")";
  return s;
}

json LinkSession::report_json(double session_s) const {
  const LinkStatistics st = server_->statistics();
  json tools = json::array();
  for (std::size_t b = 0; b < bindings_.size(); ++b) {
    const BindingState& s = state_[b];
    json trace = json::array();
    for (const auto& t : s.trace) trace.push_back({t[0], t[1], t[2], t[3], t[4]});
    tools.push_back({{"tool", bindings_[b].tool},
                     {"device", bindings_[b].device},
                     {"mode", interaction::to_string(bindings_[b].mode)},
                     {"poses_applied", s.applied},
                     {"poses_rejected_not_rigid", s.rejected},
                     {"trace_columns", {"time_s", "x_mm", "y_mm", "z_mm", "transform_number"}},
                     {"trace", std::move(trace)}});
  }
  json connect = json::array();
  for (const std::string& c : options_.connect) connect.push_back(c);
  return {
      {"frame_on_wire",
       frame_ == WireFrame::kRas ? "RAS (3D Slicer's scene), mm" : "LPS (patient), mm"},
      {"trace_frame", "patient (LPS), mm"},
      {"listen", server_->port() >= 0 ? json(options_.bind + ":" + std::to_string(server_->port()))
                                      : json(nullptr)},
      {"connect", connect},
      {"registration", registration_ ? json(options_.registration) : json(nullptr)},
      {"surface",
       {{"device", surface_name_},
        {"published", surfaces_published_},
        {"rate_hz_target", options_.rate_hz},
        {"rate_hz", session_s > 0 ? static_cast<double>(surfaces_published_) / session_s : 0.0},
        {"vertices", last_vertices_},
        {"triangles", last_triangles_},
        {"message_bytes", st.last_polydata_bytes},
        {"packed", st.surfaces_packed},
        {"pack_ms_mean", st.surfaces_packed > 0 ? 1e3 * st.pack_s / st.surfaces_packed : 0.0}}},
      {"tools", tools},
      {"peers",
       {{"connected", st.peers_connected},
        {"refused", st.peers_refused},
        {"at_end", st.peers_now}}},
      {"messages",
       {{"in", st.messages_in},
        {"transforms_in", st.transforms_in},
        {"strings_in", st.strings_in},
        {"polydata_requests", st.polydata_requests},
        {"skipped_types", st.skipped_messages},
        {"bad_crc", st.bad_crc},
        {"bad_content", st.bad_content},
        {"polydata_sent", st.polydata_sent},
        {"polydata_skipped_slow_peer", st.polydata_skipped},
        {"sensors_sent", st.sensors_sent},
        {"sensors_dropped", st.sensors_dropped},
        {"bytes_in", st.bytes_in},
        {"bytes_out", st.bytes_out}}},
  };
}

}  // namespace tsf::link
