#include "link/igtl_device.h"

#include "link/link_session.h"

namespace tsf::link {

IgtlDevice::IgtlDevice(IgtlDeviceOptions options) : options_(std::move(options)) {
  server_ = std::make_unique<LinkServer>(options_.server);
}

haptics::DeviceState IgtlDevice::read() {
  haptics::DeviceState s;
  s.valid = false;
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
  return s;
}

void IgtlDevice::apply_force(const Vec3d& force_un) {
  if (seen_ == 0) return;  // nobody to send it to yet
  server_->send_force(options_.transform, lps_to_wire(force_un * 1e-6, options_.frame), stamp_);
}

std::string IgtlDevice::describe_link() const {
  std::string s = "OpenIGTLink TRANSFORM '" + options_.transform + "'";
  if (server_->port() >= 0)
    s += " on " + options_.server.listen.host + ":" + std::to_string(server_->port());
  for (const Endpoint& e : options_.server.connect)
    s += " from " + e.host + ":" + std::to_string(e.port);
  s += options_.frame == WireFrame::kRas ? " (RAS)" : " (LPS)";
  return s;
}

}  // namespace tsf::link
