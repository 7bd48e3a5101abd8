// A haptic device behind an OpenIGTLink link (docs/live.md, "As a haptic device"): the pose is
// the newest TRANSFORM of one device name from a tracker or a haptic-arm bridge, the force goes
// back to that peer as SENSOR (newtons), both in patient LPS mm once the wire frame (RAS for 3D
// Slicer and PLUS, or LPS) and an optional rigid registration are applied. The first real device
// behind haptics::HapticDevice: commands that run a haptic loop offer it by name (`--device
// igtl:…`, app/link/igtl_device.cpp lists the parameters).
//
//   haptic thread                 link thread (LinkServer)
//   read():  newest TRANSFORM     reads peers, keeps the newest TRANSFORM per device
//   apply_force(F)  ───────────►  SENSOR to the peer that sent the pose, stamped with its time
// Neither waits on the other longer than a copy under the server's mutex.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "link/igtl_codec.h"
#include "link/link_server.h"
#include "tsf/haptics/device_registry.h"
#include "tsf/haptics/haptic_device.h"

namespace tsf::link {

struct IgtlDeviceOptions {
  ServerOptions server;               ///< where to listen / connect
  std::string transform = "Tracker";  ///< the TRANSFORM device name followed
  WireFrame frame = WireFrame::kRas;
  std::optional<Matrix4> registration;  ///< tracker → wire frame, applied first
  double max_force_n = 10.0;            ///< the loop clamps to it
};

class IgtlDevice final : public haptics::HapticDevice {
 public:
  /// Starts the link (throws tsf::Error naming the address when it cannot listen).
  explicit IgtlDevice(IgtlDeviceOptions options);

  /// The newest pose in patient LPS; valid = false before the first TRANSFORM, after its peer
  /// left and while the newest one is not a rigid transform (the tool then lifts).
  haptics::DeviceState read() override;
  /// `force_un` (patient LPS, µN) → SENSOR (wire frame, N) to the peer of the newest pose.
  void apply_force(const Vec3d& force_un) override;
  double max_force_un() const override { return options_.max_force_n * 1e6; }
  haptics::PoseFrame frame() const override { return haptics::PoseFrame::kPatient; }
  /// "OpenIGTLink TRANSFORM 'Tracker' on 127.0.0.1:18944 (RAS)".
  std::string describe() const override;

  LinkServer& server() { return *server_; }
  std::uint64_t poses_read() const { return poses_; }

 private:
  IgtlDeviceOptions options_;
  std::unique_ptr<LinkServer> server_;
  std::uint64_t seen_ = 0, stamp_ = 0, poses_ = 0;
};

/// Offers the device as `igtl` in `registry` (`--device igtl[:KEY=VALUE,…]`): port=N (default
/// 18944; -1: do not listen), bind=ADDR, connect=HOST:PORT, transform=NAME (default Tracker),
/// frame=ras|lps, registration=FILE, max_force=N (newtons, default 10).
void add_igtl_device(haptics::DeviceRegistry& registry);

}  // namespace tsf::link
