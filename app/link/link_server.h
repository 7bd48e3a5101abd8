// The network side of a live link (docs/live.md): one thread that listens for OpenIGTLink peers
// (3D Slicer's OpenIGTLinkIF as a client, a tracker or haptic bridge), connects to servers (a
// PlusServer), reads their TRANSFORM and STRING messages, streams the newest surface as POLYDATA
// and sends forces back as SENSOR.
//
//   simulation thread                       link thread (poll loop)
//   pose("Tracker") → the newest TRANSFORM  reads peers: header checked, body sized by the
//   publish_surface(name, mesh)             header only within limits, CRC checked
//   send_force("Tracker", F, stamp)         streams the newest surface to every listener and
//                                           answers GET_POLYDATA; packs it once, when the first
//                                           peer that can take it does (none: never packed)
// Neither side waits for the other longer than a copy under a mutex. Memory is bounded: per peer
// at most the message being sent, the next surface (shared, not copied) and max_queued_bytes of
// small messages; a slow peer is sent the newest surface when it can take one (frames in between
// are skipped and counted), never a backlog. A peer that breaks the protocol (a header that is not
// OpenIGTLink's, a body larger than its type allows, more peers than max_peers) is disconnected
// with the reason logged; a message with a bad CRC is dropped and counted.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "link/igtl_codec.h"
#include "tsf/common/vec3.h"
#include "tsf/imt/surface_mesh.h"

namespace tsf::link {

struct Endpoint {
  std::string host;
  int port = 0;
};

/// "HOST:PORT" (or "PORT": localhost); throws tsf::Error naming `option` and the text.
Endpoint parse_endpoint(const std::string& text, const std::string& option);

struct ServerOptions {
  /// Listen here; port −1: do not listen; port 0: any free port (tests; LinkServer::port()).
  Endpoint listen{"127.0.0.1", 18944};
  /// Servers to connect to (a PlusServer); reconnected every second while down.
  std::vector<Endpoint> connect;
  int max_peers = 16;
  BodyLimits limits;
  std::size_t max_queued_bytes = 1 << 20;  ///< small messages waiting for one peer
  /// A peer that connected to us is sent the surface stream unless it asks for surfaces
  /// (GET_POLYDATA) within this time; peers we connected to get it only when they ask.
  double listener_grace_s = 0.1;
  /// Connect, disconnect and refusal messages (from the link thread); null: stderr.
  std::function<void(const std::string&)> log;
};

/// The newest TRANSFORM of a device.
struct PoseUpdate {
  Matrix4 matrix = identity_matrix();  ///< the wire frame, mm
  std::uint64_t timestamp = 0;         ///< the message's
  std::uint64_t count = 0;             ///< TRANSFORMs of this device received so far
  int peer = -1;
};

struct LinkStatistics {
  std::int64_t peers_connected = 0, peers_refused = 0, peers_now = 0;
  std::int64_t messages_in = 0, transforms_in = 0, strings_in = 0, polydata_requests = 0;
  std::int64_t bad_crc = 0, bad_content = 0, skipped_messages = 0;
  std::int64_t polydata_sent = 0, polydata_skipped = 0;  ///< skipped: a newer one replaced it
  std::int64_t sensors_sent = 0, sensors_dropped = 0;
  std::int64_t bytes_in = 0, bytes_out = 0;
  std::int64_t surfaces_packed = 0;
  double pack_s = 0;                    ///< time spent packing POLYDATA
  std::size_t last_polydata_bytes = 0;  ///< size of the newest POLYDATA message
};

class LinkServer {
 public:
  /// Binds (throws tsf::Error naming the address when it cannot) and starts the link thread.
  explicit LinkServer(ServerOptions options);
  ~LinkServer();  ///< stops the thread and closes every connection
  LinkServer(const LinkServer&) = delete;
  LinkServer& operator=(const LinkServer&) = delete;

  /// The port listened on (−1 when not listening).
  int port() const { return port_; }
  const ServerOptions& options() const { return options_; }

  /// The newest pose of `device`; empty before its first TRANSFORM and after its peer left.
  std::optional<PoseUpdate> pose(const std::string& device) const;
  /// The newest STRING of `device` (and how many arrived); empty before the first.
  std::optional<std::pair<std::string, std::uint64_t>> text(const std::string& device) const;

  /// Serves `mesh` (wire frame) as POLYDATA named `device` (cut to 20 characters). Packed on the
  /// link thread; a newer call before it was packed replaces it.
  void publish_surface(const std::string& device, std::shared_ptr<const imt::SurfaceMesh> mesh,
                       std::uint64_t timestamp);
  /// Sends `force_n` (wire frame, newtons) as SENSOR `device` to the peer that sent `device`'s
  /// newest TRANSFORM, with `timestamp` (the pose's: the reply says which pose it answers). A
  /// newer force for the same device before the link thread sent it replaces it.
  void send_force(const std::string& device, const Vec3d& force_n, std::uint64_t timestamp);

  LinkStatistics statistics() const;

 private:
  struct Peer;
  void run();
  void say(const std::string& message) const;

  ServerOptions options_;
  int listen_fd_ = -1;
  int wake_fd_ = -1;
  int port_ = -1;
  std::atomic<bool> stop_{false};

  mutable std::mutex mutex_;  // guards everything below it
  std::map<std::string, PoseUpdate> poses_;
  std::map<std::string, std::pair<std::string, std::uint64_t>> texts_;
  struct PendingSurface {
    std::shared_ptr<const imt::SurfaceMesh> mesh;
    std::uint64_t timestamp = 0;
  };
  std::map<std::string, PendingSurface> pending_surfaces_;
  struct PendingForce {
    Vec3d force_n;
    std::uint64_t timestamp = 0;
  };
  std::map<std::string, PendingForce> pending_forces_;
  LinkStatistics stats_;

  std::thread thread_;  // last: starts after everything above exists
};

}  // namespace tsf::link
