#include "link/igtl_device.h"

#include "link/link_session.h"

#include <cstdlib>

#include "tsf/common/error.h"

namespace tsf::link {

IgtlDevice::IgtlDevice(IgtlDeviceOptions options) : options_(std::move(options)) {
  server_ = std::make_unique<LinkServer>(options_.server);
}

haptics::DeviceState IgtlDevice::read() {
  haptics::DeviceState s;
  s.valid = false;
  s.pressing = false;  // no pose: the tool lifts (the loop renders no force, the tissue is free)
  const std::optional<PoseUpdate> u = server_->pose(options_.transform);
  if (!u) return s;
  const std::optional<ToolPose> lps =
      wire_matrix_to_patient_pose(u->matrix, options_.frame, options_.registration);
  if (!lps) return s;
  if (u->count != seen_) {
    seen_ = u->count;
    stamp_ = u->timestamp;
    ++poses_;
  }
  s.pose = *lps;
  s.valid = true;
  s.pressing = true;
  return s;
}

void IgtlDevice::apply_force(const Vec3d& force_un) {
  if (seen_ == 0) return;  // nobody to send it to yet
  server_->send_force(options_.transform, lps_to_wire(force_un * 1e-6, options_.frame), stamp_);
}

std::string IgtlDevice::describe() const {
  std::string s = "OpenIGTLink TRANSFORM '" + options_.transform + "'";
  if (server_->port() >= 0)
    s += " on " + options_.server.listen.host + ":" + std::to_string(server_->port());
  for (const Endpoint& e : options_.server.connect)
    s += " from " + e.host + ":" + std::to_string(e.port);
  s += options_.frame == WireFrame::kRas ? " (RAS)" : " (LPS)";
  return s;
}

namespace {

std::unique_ptr<haptics::HapticDevice> make_igtl_device(const haptics::DeviceRequest& q) {
  q.expect_only({"port", "bind", "connect", "transform", "frame", "registration", "max_force"});
  IgtlDeviceOptions o;
  o.server.listen = {q.get("bind", "127.0.0.1"), 18944};
  const std::string what = "--device " + q.text + ": ";
  if (!q.get("port").empty()) {
    char* end = nullptr;
    const long p = std::strtol(q.get("port").c_str(), &end, 10);
    if (end == nullptr || *end != '\0' || p < -1 || p > 65535)
      throw Error(what + "port: expected 0…65535 (or -1: do not listen), got '" + q.get("port") +
                  "'");
    o.server.listen.port = static_cast<int>(p);
  }
  if (!q.get("connect").empty())
    o.server.connect.push_back(parse_endpoint(q.get("connect"), what + "connect"));
  if (o.server.listen.port < 0 && o.server.connect.empty())
    throw Error(what + "port=-1 and no connect=HOST:PORT: nothing to link");
  o.transform = q.get("transform", "Tracker");
  if (o.transform.empty() || o.transform.size() > kDeviceNameSize)
    throw Error(what + "transform: a TRANSFORM device name of 1 to 20 characters, got '" +
                o.transform + "'");
  o.frame = wire_frame_from_string(q.get("frame", "ras"), what + "frame");
  if (!q.get("registration").empty()) o.registration = read_registration(q.get("registration"));
  if (!q.get("max_force").empty()) {
    char* end = nullptr;
    o.max_force_n = std::strtod(q.get("max_force").c_str(), &end);
    if (end == nullptr || *end != '\0' || !(o.max_force_n > 0 && o.max_force_n <= 1000))
      throw Error(what + "max_force: expected newtons in (0, 1000], got '" + q.get("max_force") +
                  "'");
  }
  return std::make_unique<IgtlDevice>(std::move(o));
}

}  // namespace

void add_igtl_device(haptics::DeviceRegistry& registry) {
  registry.add("igtl",
               "OpenIGTLink: the pose of TRANSFORM transform=NAME (default Tracker) from a "
               "tracker or haptic bridge, the force back as SENSOR (port=18944, connect=HOST:PORT, "
               "frame=ras|lps, registration=FILE, max_force=N)",
               make_igtl_device);
}

}  // namespace tsf::link
