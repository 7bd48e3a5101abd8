#include "link/link_server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <deque>
#include <set>

#include "tsf/common/error.h"

namespace tsf::link {
namespace {

using Clock = std::chrono::steady_clock;
using Bytes = std::shared_ptr<const std::vector<std::uint8_t>>;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

void set_nonblocking(int fd) {
  const int flags = ::fcntl(fd, F_GETFL, 0);
  ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
}

void set_no_delay(int fd) {
  int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}

/// The first IPv4 address of `host` ("" and "localhost": 127.0.0.1). False when unknown.
bool resolve(const std::string& host, sockaddr_in& out) {
  std::memset(&out, 0, sizeof out);
  out.sin_family = AF_INET;
  const std::string h = host.empty() || host == "localhost" ? "127.0.0.1" : host;
  if (::inet_pton(AF_INET, h.c_str(), &out.sin_addr) == 1) return true;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (::getaddrinfo(h.c_str(), nullptr, &hints, &found) != 0 || found == nullptr) return false;
  out.sin_addr = reinterpret_cast<const sockaddr_in*>(found->ai_addr)->sin_addr;
  ::freeaddrinfo(found);
  return true;
}

std::string address_text(const sockaddr_in& a) {
  char text[INET_ADDRSTRLEN] = "?";
  ::inet_ntop(AF_INET, &a.sin_addr, text, sizeof text);
  return std::string(text) + ":" + std::to_string(ntohs(a.sin_port));
}

std::string cut_name(const std::string& name) {
  return name.substr(0, kDeviceNameSize);
}

}  // namespace

Endpoint parse_endpoint(const std::string& text, const std::string& option) {
  Endpoint e;
  const std::size_t colon = text.rfind(':');
  const std::string port = colon == std::string::npos ? text : text.substr(colon + 1);
  e.host = colon == std::string::npos ? "127.0.0.1" : text.substr(0, colon);
  char* end = nullptr;
  const long p = std::strtol(port.c_str(), &end, 10);
  if (port.empty() || end == nullptr || *end != '\0' || p < 1 || p > 65535 || e.host.empty())
    throw Error(option +
                ": expected HOST:PORT with a port in 1…65535 (e.g. 127.0.0.1:18944), "
                "got '" +
                text + "'");
  e.port = static_cast<int>(p);
  return e;
}

/// One connection, owned by the link thread.
struct LinkServer::Peer {
  int id = 0;
  int fd = -1;
  std::string address;
  bool outgoing = false;     ///< we connected to it
  std::size_t endpoint = 0;  ///< outgoing: index into options.connect
  bool connecting = false;   ///< outgoing: connect() in progress
  Clock::time_point since = Clock::now();
  // Surface policy: streamed (listeners after the grace time, or after STT_POLYDATA), or sent
  // when asked (GET_POLYDATA).
  bool streaming = false;
  bool asked = false;     ///< ever sent GET_POLYDATA or STT/STP: no automatic stream
  int replies_owed = 0;   ///< GET_POLYDATA not yet answered
  std::string requested;  ///< the device name of the last GET_POLYDATA
  std::map<std::string, std::uint64_t> surface_version_sent;
  // Reading.
  std::uint8_t header_bytes[kHeaderSize];
  std::size_t header_filled = 0;
  bool in_body = false;
  Header header;
  BodyAction action = BodyAction::kSkip;
  std::vector<std::uint8_t> body;
  std::uint64_t body_filled = 0;
  // Writing.
  struct Out {
    Bytes bytes;
    std::size_t offset = 0;
    bool surface = false;
  };
  std::optional<Out> current;
  std::deque<Bytes> control;
  std::size_t control_bytes = 0;
  std::set<std::string> surface_next;  ///< devices whose newest surface it is owed
  bool wants_write() const {
    return current.has_value() || !control.empty() || !surface_next.empty();
  }
};

LinkServer::LinkServer(ServerOptions options) : options_(std::move(options)) {
  wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd_ < 0) throw Error(std::string("OpenIGTLink link: eventfd: ") + std::strerror(errno));
  if (options_.listen.port >= 0) {
    sockaddr_in a;
    const std::string where = options_.listen.host + ":" + std::to_string(options_.listen.port);
    if (!resolve(options_.listen.host, a)) {
      ::close(wake_fd_);
      throw Error("OpenIGTLink link: cannot listen on " + where + ": unknown host");
    }
    a.sin_port = htons(static_cast<std::uint16_t>(options_.listen.port));
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    int one = 1;
    ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (listen_fd_ < 0 || ::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::listen(listen_fd_, 64) != 0) {
      const std::string why = std::strerror(errno);
      if (listen_fd_ >= 0) ::close(listen_fd_);
      ::close(wake_fd_);
      throw Error("OpenIGTLink link: cannot listen on " + where + ": " + why +
                  (errno == EADDRINUSE ? " (another program, or another tsf, serves that port: "
                                         "choose another with --igtl-port)"
                                       : ""));
    }
    set_nonblocking(listen_fd_);
    socklen_t len = sizeof a;
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
  }
  thread_ = std::thread([this] { run(); });
}

LinkServer::~LinkServer() {
  stop_ = true;
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
  if (thread_.joinable()) thread_.join();
  if (listen_fd_ >= 0) ::close(listen_fd_);
  ::close(wake_fd_);
}

void LinkServer::say(const std::string& message) const {
  if (options_.log)
    options_.log(message);
  else
    std::fprintf(stderr, "tsf link: %s\n", message.c_str());
}

std::optional<PoseUpdate> LinkServer::pose(const std::string& device) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = poses_.find(cut_name(device));
  if (it == poses_.end()) return std::nullopt;
  return it->second;
}

std::optional<std::pair<std::string, std::uint64_t>> LinkServer::text(
    const std::string& device) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto it = texts_.find(cut_name(device));
  if (it == texts_.end()) return std::nullopt;
  return it->second;
}

void LinkServer::publish_surface(const std::string& device,
                                 std::shared_ptr<const imt::SurfaceMesh> mesh,
                                 std::uint64_t timestamp) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pending_surfaces_[cut_name(device)] = {std::move(mesh), timestamp};
  }
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
}

void LinkServer::send_force(const std::string& device, const Vec3d& force_n,
                            std::uint64_t timestamp) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pending_forces_[cut_name(device)] = {force_n, timestamp};
  }
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
}

LinkStatistics LinkServer::statistics() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

void LinkServer::run() {
  std::vector<std::unique_ptr<Peer>> peers;
  int next_id = 1;
  // Outgoing endpoints: when each may be tried again, and whether its last attempt was said.
  std::vector<Clock::time_point> retry_at(options_.connect.size(), Clock::now());
  std::vector<bool> said_down(options_.connect.size(), false);
  // The newest surface of each device and its version, packed when a peer first takes it (a
  // surface no peer can take now costs nothing).
  struct Served {
    std::shared_ptr<const imt::SurfaceMesh> mesh;
    std::uint64_t timestamp = 0;
    Bytes bytes;  ///< POLYDATA of `mesh`; null until packed
    std::uint64_t version = 0;
  };
  std::map<std::string, Served> served;
  std::vector<std::uint8_t> scratch(64 * 1024);

  auto count = [&](auto&& f) {
    std::lock_guard<std::mutex> lock(mutex_);
    f(stats_);
  };
  auto close_peer = [&](Peer& p, const std::string& why) {
    if (p.fd >= 0) ::close(p.fd);
    p.fd = -1;
    say((p.outgoing ? "server " : "peer ") + p.address + " " + why);
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = poses_.begin(); it != poses_.end();)  // its tools lift
      it = it->second.peer == p.id ? poses_.erase(it) : std::next(it);
    --stats_.peers_now;
    if (p.outgoing) {
      retry_at[p.endpoint] = Clock::now() + std::chrono::seconds(1);
      said_down[p.endpoint] = true;
    }
  };
  auto enqueue_control = [&](Peer& p, Bytes bytes) {
    if (p.control_bytes + bytes->size() > options_.max_queued_bytes) return false;
    p.control_bytes += bytes->size();
    p.control.push_back(std::move(bytes));
    return true;
  };
  auto offer_surface = [&](Peer& p, const std::string& device, const Served& s) {
    if (!p.surface_next.insert(device).second)
      count([](LinkStatistics& st) { ++st.polydata_skipped; });
    p.surface_version_sent[device] = s.version;
  };
  auto packed = [&](Served& sv, const std::string& device) {
    if (!sv.bytes) {
      const auto t0 = Clock::now();
      sv.bytes = std::make_shared<const std::vector<std::uint8_t>>(
          pack_polydata(*sv.mesh, device, sv.timestamp));
      const double took = seconds_since(t0);
      const std::size_t size = sv.bytes->size();
      count([took, size](LinkStatistics& st) {
        ++st.surfaces_packed;
        st.pack_s += took;
        st.last_polydata_bytes = size;
      });
    }
    return sv.bytes;
  };

  // One message read whole: act on it.
  auto handle_message = [&](Peer& p) {
    const Header& h = p.header;
    if (!body_crc_ok(h, p.body.data(), p.body.size())) {
      count([](LinkStatistics& st) { ++st.bad_crc; });
      say("peer " + p.address + ": dropped a " + h.type + " '" + h.device +
          "' whose CRC does not match its body");
      return;
    }
    std::string why;
    const std::optional<Span> content = message_content(h, p.body.data(), p.body.size(), why);
    if (h.type == "TRANSFORM") {
      std::optional<Matrix4> m = content ? unpack_transform(*content, why) : std::nullopt;
      if (!m) {
        count([](LinkStatistics& st) { ++st.bad_content; });
        say("peer " + p.address + ": dropped " + why);
        return;
      }
      std::lock_guard<std::mutex> lock(mutex_);
      PoseUpdate& u = poses_[h.device];
      u.matrix = *m;
      u.timestamp = h.timestamp;
      ++u.count;
      u.peer = p.id;
      ++stats_.transforms_in;
    } else if (h.type == "STRING") {
      std::optional<std::string> s = content ? unpack_string(*content, why) : std::nullopt;
      if (!s) {
        count([](LinkStatistics& st) { ++st.bad_content; });
        say("peer " + p.address + ": dropped " + why);
        return;
      }
      std::lock_guard<std::mutex> lock(mutex_);
      auto& t = texts_[h.device];
      t.first = *s;
      ++t.second;
      ++stats_.strings_in;
    } else if (h.type == "GET_POLYDATA") {
      p.asked = true;
      p.streaming = false;
      ++p.replies_owed;
      p.requested = h.device;
      count([](LinkStatistics& st) { ++st.polydata_requests; });
    } else if (h.type == "STT_POLYDATA") {
      p.asked = true;
      p.streaming = true;
    } else if (h.type == "STP_POLYDATA") {
      p.asked = true;
      p.streaming = false;
    }
  };

  // Reads what is there; false when the peer must go (the reason already said).
  auto read_peer = [&](Peer& p) {
    for (int round = 0; round < 64; ++round) {
      const ssize_t n = ::recv(p.fd, scratch.data(), scratch.size(), 0);
      if (n == 0) {
        close_peer(p, "disconnected");
        return false;
      }
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return true;
        close_peer(p, std::string("disconnected: ") + std::strerror(errno));
        return false;
      }
      count([n](LinkStatistics& st) { st.bytes_in += n; });
      const std::uint8_t* at = scratch.data();
      std::size_t left = static_cast<std::size_t>(n);
      while (left > 0) {
        if (!p.in_body) {
          const std::size_t take = std::min(left, kHeaderSize - p.header_filled);
          std::memcpy(p.header_bytes + p.header_filled, at, take);
          p.header_filled += take;
          at += take;
          left -= take;
          if (p.header_filled < kHeaderSize) break;
          p.header_filled = 0;
          const std::string bad = parse_header(p.header_bytes, p.header);
          if (!bad.empty()) {
            count([](LinkStatistics& st) { ++st.peers_refused; });
            close_peer(p, "refused: not an OpenIGTLink message: " + bad);
            return false;
          }
          const BodyPlan plan = plan_body(p.header, options_.limits);
          if (plan.action == BodyAction::kRefuse) {
            count([](LinkStatistics& st) { ++st.peers_refused; });
            close_peer(p, "refused: " + plan.why);
            return false;
          }
          count([](LinkStatistics& st) { ++st.messages_in; });
          p.action = plan.action;
          p.in_body = true;
          p.body_filled = 0;
          if (p.action == BodyAction::kRead)
            p.body.assign(static_cast<std::size_t>(p.header.body_size), 0);
          else
            count([](LinkStatistics& st) { ++st.skipped_messages; });
        }
        if (p.in_body) {
          const std::uint64_t want = p.header.body_size - p.body_filled;
          const std::size_t take = static_cast<std::size_t>(std::min<std::uint64_t>(left, want));
          if (p.action == BodyAction::kRead && take > 0)  // an empty body has no storage
            std::memcpy(p.body.data() + p.body_filled, at, take);
          p.body_filled += take;
          at += take;
          left -= take;
          if (p.body_filled == p.header.body_size) {
            p.in_body = false;
            if (p.action == BodyAction::kRead) handle_message(p);
          }
        }
      }
    }
    return true;  // more may wait: the next poll round reads on (fairness between peers)
  };

  // Writes what it can; false when the peer must go.
  auto write_peer = [&](Peer& p) {
    while (true) {
      if (!p.current) {
        if (!p.control.empty()) {
          p.control_bytes -= p.control.front()->size();
          p.current = Peer::Out{std::move(p.control.front()), 0, false};
          p.control.pop_front();
        } else if (!p.surface_next.empty()) {
          const std::string device = *p.surface_next.begin();
          p.surface_next.erase(p.surface_next.begin());
          Served& sv = served.at(device);
          p.current = Peer::Out{packed(sv, device), 0, true};
          p.surface_version_sent[device] = sv.version;  // the newest, maybe newer than offered
        } else {
          return true;
        }
      }
      Peer::Out& o = *p.current;
      const ssize_t n = ::send(p.fd, o.bytes->data() + o.offset, o.bytes->size() - o.offset,
                               MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return true;
        close_peer(p, std::string("disconnected: ") + std::strerror(errno));
        return false;
      }
      o.offset += static_cast<std::size_t>(n);
      count([n](LinkStatistics& st) { st.bytes_out += n; });
      if (o.offset == o.bytes->size()) {
        const bool surface = o.surface;
        count([surface](LinkStatistics& st) { ++(surface ? st.polydata_sent : st.sensors_sent); });
        p.current.reset();
      }
    }
  };

  auto add_peer = [&](int fd, const std::string& address, bool outgoing, std::size_t endpoint) {
    auto p = std::make_unique<Peer>();
    p->id = next_id++;
    p->fd = fd;
    p->address = address;
    p->outgoing = outgoing;
    p->endpoint = endpoint;
    set_nonblocking(fd);
    set_no_delay(fd);
    count([](LinkStatistics& st) {
      ++st.peers_now;
      ++st.peers_connected;
    });
    peers.push_back(std::move(p));
    return peers.back().get();
  };

  std::vector<pollfd> fds;
  std::vector<Peer*> fd_peer;
  // What poll() found: the wake-up, new peers, reads and writes.
  auto poll_ready = [&] {
    if (fds[0].revents & POLLIN) {
      std::uint64_t v;
      while (::read(wake_fd_, &v, sizeof v) > 0) {
      }
    }
    if (listen_fd_ >= 0 && (fds[1].revents & POLLIN)) {
      while (true) {
        sockaddr_in a;
        socklen_t len = sizeof a;
        const int fd = ::accept4(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len, SOCK_CLOEXEC);
        if (fd < 0) break;
        const long live =
            std::count_if(peers.begin(), peers.end(), [](const auto& p) { return p->fd >= 0; });
        if (live >= options_.max_peers) {
          ::close(fd);
          count([](LinkStatistics& st) { ++st.peers_refused; });
          say("peer " + address_text(a) + " refused: already " + std::to_string(live) +
              " peers (the most this session takes)");
          continue;
        }
        add_peer(fd, address_text(a), false, 0);
        say("peer " + address_text(a) + " connected");
      }
    }
    for (std::size_t i = 0; i < fds.size(); ++i) {
      Peer* p = fd_peer[i];
      if (p == nullptr || p->fd < 0 || fds[i].revents == 0) continue;
      if (p->connecting) {
        int err = 0;
        socklen_t len = sizeof err;
        ::getsockopt(p->fd, SOL_SOCKET, SO_ERROR, &err, &len);
        if (err != 0) {
          const std::size_t e = p->endpoint;
          ::close(p->fd);
          p->fd = -1;
          {
            std::lock_guard<std::mutex> lock(mutex_);
            --stats_.peers_now;
            --stats_.peers_connected;
          }
          if (!said_down[e])
            say("server " + p->address + ": " + std::strerror(err) + " (trying every second)");
          said_down[e] = true;
          retry_at[e] = Clock::now() + std::chrono::seconds(1);
          continue;
        }
        p->connecting = false;
        said_down[p->endpoint] = false;
        say("server " + p->address + " connected");
        continue;
      }
      if ((fds[i].revents & (POLLIN | POLLHUP | POLLERR)) && !read_peer(*p)) continue;
      if ((fds[i].revents & POLLOUT) && !write_peer(*p)) continue;
    }
    // Peers with something to send write at once (a force right after it was queued).
    for (auto& p : peers)
      if (p->fd >= 0 && !p->connecting && p->wants_write()) write_peer(*p);
  };

  while (!stop_) {
    // Outgoing connections that are due.
    for (std::size_t e = 0; e < options_.connect.size(); ++e) {
      const bool up = std::any_of(peers.begin(), peers.end(), [&](const auto& p) {
        return p->outgoing && p->endpoint == e && p->fd >= 0;
      });
      if (up || Clock::now() < retry_at[e]) continue;
      sockaddr_in a;
      const Endpoint& ep = options_.connect[e];
      const std::string where = ep.host + ":" + std::to_string(ep.port);
      retry_at[e] = Clock::now() + std::chrono::seconds(1);
      if (!resolve(ep.host, a)) {
        if (!said_down[e]) say("server " + where + ": unknown host (trying every second)");
        said_down[e] = true;
        continue;
      }
      a.sin_port = htons(static_cast<std::uint16_t>(ep.port));
      const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
      if (fd < 0) continue;
      set_nonblocking(fd);
      const int r = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
      if (r != 0 && errno != EINPROGRESS) {
        ::close(fd);
        continue;
      }
      Peer* p = add_peer(fd, where, true, e);
      p->connecting = r != 0;
      if (!p->connecting) say("server " + where + " connected");
    }

    // Surfaces and forces the simulation left.
    std::map<std::string, PendingSurface> surfaces;
    std::map<std::string, PendingForce> forces;
    std::map<std::string, int> owner;  // device → the peer of its newest pose
    {
      std::lock_guard<std::mutex> lock(mutex_);
      surfaces.swap(pending_surfaces_);
      forces.swap(pending_forces_);
      for (const auto& [device, u] : poses_) owner[device] = u.peer;
    }
    for (auto& [device, s] : surfaces) {
      Served& sv = served[device];
      sv.mesh = std::move(s.mesh);
      sv.timestamp = s.timestamp;
      sv.bytes.reset();
      ++sv.version;
    }
    for (const auto& [device, f] : forces) {
      const auto it = owner.find(device);
      Peer* to = nullptr;
      if (it != owner.end())
        for (auto& p : peers)
          if (p->id == it->second && p->fd >= 0 && !p->connecting) to = p.get();
      const bool sent =
          to != nullptr &&
          enqueue_control(*to, std::make_shared<const std::vector<std::uint8_t>>(
                                   pack_force_sensor(f.force_n, device, f.timestamp)));
      if (!sent) count([](LinkStatistics& st) { ++st.sensors_dropped; });
    }
    // Surfaces to peers: streams, and answers to GET_POLYDATA.
    for (auto& p : peers) {
      if (p->fd < 0 || p->connecting) continue;
      if (!p->asked && !p->outgoing && seconds_since(p->since) >= options_.listener_grace_s)
        p->streaming = true;
      if (p->streaming)
        for (const auto& [device, s] : served)
          if (p->surface_version_sent[device] != s.version) offer_surface(*p, device, s);
      while (p->replies_owed > 0 && !served.empty()) {
        auto it = served.find(cut_name(p->requested));
        if (it == served.end()) it = served.begin();  // a name tsf does not serve: the first
        offer_surface(*p, it->first, it->second);
        --p->replies_owed;
      }
    }

    // Poll.
    fds.clear();
    fd_peer.clear();
    fds.push_back({wake_fd_, POLLIN, 0});
    fd_peer.push_back(nullptr);
    if (listen_fd_ >= 0) {
      fds.push_back({listen_fd_, POLLIN, 0});
      fd_peer.push_back(nullptr);
    }
    for (auto& p : peers) {
      if (p->fd < 0) continue;
      short events = p->connecting ? POLLOUT : POLLIN;
      if (!p->connecting && p->wants_write()) events |= POLLOUT;
      fds.push_back({p->fd, events, 0});
      fd_peer.push_back(p.get());
    }
    const int ready = ::poll(fds.data(), fds.size(), 50);
    if (ready < 0 && errno != EINTR) break;
    if (ready > 0) poll_ready();
    peers.erase(std::remove_if(peers.begin(), peers.end(), [](const auto& p) { return p->fd < 0; }),
                peers.end());
  }
  for (auto& p : peers)
    if (p->fd >= 0) ::close(p->fd);
}

}  // namespace tsf::link
