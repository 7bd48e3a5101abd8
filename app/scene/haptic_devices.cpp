#include "scene/haptic_devices.h"

#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>

#include "tsf/common/error.h"
#include "tsf/haptics/input_device.h"
#include "tsf/haptics/scripted_device.h"
#ifdef TSF_HAVE_LINK_CMD
#include "link/igtl_device.h"  // `igtl`: the live link as a device (docs/live.md)
#endif

namespace tsf::app {

haptics::DeviceRegistry haptic_devices(const DeviceContext& context) {
  haptics::DeviceRegistry r;
  if (context.trajectory != nullptr) {
    const interaction::Trajectory path = *context.trajectory;
    r.add("scripted", "the scripted path played in wall-clock time",
          [path](const haptics::DeviceRequest& q) -> std::unique_ptr<haptics::HapticDevice> {
            q.expect_only({});
            if (path.empty())
              throw Error("--device " + q.text +
                          ": there is no scripted path to play (give a "
                          "view script with keyframes, or a scene with a "
                          "script)");
            return std::make_unique<haptics::ScriptedDevice>(path);
          });
  }
  if (context.window)
    r.add("mouse", "the window's mouse and keys (speed=MM_PER_S for held keys, default 10)",
          [](const haptics::DeviceRequest& q) -> std::unique_ptr<haptics::HapticDevice> {
            q.expect_only({"speed"});
            haptics::InputDeviceOptions o;
            o.speed_mm_s = 10.0;
            if (!q.get("speed").empty()) {
              char* end = nullptr;
              o.speed_mm_s = std::strtod(q.get("speed").c_str(), &end);
              if (end == nullptr || *end != '\0' || !(o.speed_mm_s > 0 && o.speed_mm_s <= 1000))
                throw Error("--device " + q.text + ": speed: expected mm/s in (0, 1000], got '" +
                            q.get("speed") + "'");
            }
            return std::make_unique<haptics::InputDevice>(o);
          });
#ifdef TSF_HAVE_LINK_CMD
  link::add_igtl_device(r);
#endif
  return r;
}

namespace {

/// Linux's sched_attr (SCHED_ATTR_SIZE_VER0).
struct SchedAttr {
  std::uint32_t size;
  std::uint32_t sched_policy;
  std::uint64_t sched_flags;
  std::int32_t sched_nice;
  std::uint32_t sched_priority;
  std::uint64_t sched_runtime, sched_deadline, sched_period;
};

/// A fair-scheduled thread asks for a 0.1 ms time slice: on EEVDF kernels (Linux ≥ 6.12) a short
/// slice lets it preempt the running task as soon as it wakes. Unprivileged; false when refused.
bool request_short_slice() {
#ifdef SYS_sched_setattr
  SchedAttr a{};
  a.size = sizeof a;
  a.sched_policy = SCHED_OTHER;
  a.sched_runtime = 100'000;  // ns
  return ::syscall(SYS_sched_setattr, 0, &a, 0) == 0;
#else
  return false;
#endif
}

/// The haptic thread's id (Linux tid), once it started.
std::atomic<long> g_haptic_tid{0};

}  // namespace

void lower_other_threads_priority() {
  // The haptic thread records its id as it starts: wait for it (a moment) so it is spared.
  for (int i = 0; i < 200 && g_haptic_tid.load() == 0; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const long keep = g_haptic_tid.load();
  if (keep == 0) return;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/task", ec)) {
    char* end = nullptr;
    const long tid = std::strtol(entry.path().filename().c_str(), &end, 10);
    if (end == nullptr || *end != '\0' || tid == keep) continue;
    errno = 0;
    const int now = ::getpriority(PRIO_PROCESS, static_cast<id_t>(tid));
    if (errno == 0 && now < 5) (void)::setpriority(PRIO_PROCESS, static_cast<id_t>(tid), 5);
  }
}

std::string request_haptic_thread_priority() {
  g_haptic_tid = static_cast<long>(::syscall(SYS_gettid));
  if (std::getenv("TSF_HAPTICS_NO_REALTIME") == nullptr) {
    sched_param p{};
    p.sched_priority = std::min(10, sched_get_priority_max(SCHED_FIFO));
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0)
      return "SCHED_FIFO priority " + std::to_string(p.sched_priority);
  }
  const std::string why = std::getenv("TSF_HAPTICS_NO_REALTIME") != nullptr
                              ? "TSF_HAPTICS_NO_REALTIME set"
                              : "SCHED_FIFO not permitted";
  return std::getenv("TSF_HAPTICS_NO_SLICE") == nullptr && request_short_slice()
             ? "normal scheduling, 0.1 ms slice (" + why + ")"
             : "normal scheduling (" + why + ")";
}

void lower_thread_priority() {
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  errno = 0;
  const int now = ::getpriority(PRIO_PROCESS, tid);
  if (errno == 0 && now < 5) (void)::setpriority(PRIO_PROCESS, tid, 5);
}

double stylus_radius_of(const interaction::Tool& tool) {
  switch (tool.shape) {
    case collision::ToolShape::kSphere:
    case collision::ToolShape::kCapsule:
      return tool.radius_mm;
    case collision::ToolShape::kBlade:
      return std::max(0.5, tool.half_extents_mm.z);
    case collision::ToolShape::kMesh: {
      const Vec3d size = tool.mesh->grid.hi() - tool.mesh->grid.lo();
      return std::max(0.5, 0.5 * std::min({size.x, size.y, size.z}));
    }
    default:
      return 2.0;
  }
}

nlohmann::json loop_statistics_json(const haptics::LoopStatistics& s) {
  return {{"ticks", s.ticks},
          {"seconds", s.elapsed_s},
          {"rate_hz", s.rate_hz},
          {"rate_hz_target", s.target_rate_hz},
          {"rate_fraction", s.target_rate_hz > 0 ? s.rate_hz / s.target_rate_hz : 0.0},
          {"missed_ticks", s.missed_ticks},
          {"late_ticks", s.late_ticks},
          {"max_lateness_us", s.max_lateness_us},
          {"tick_latency_us",
           {{"p50", s.latency_p50_us},
            {"p99", s.latency_p99_us},
            {"p999", s.latency_p999_us},
            {"max", s.latency_max_us}}},
          {"compute_us",
           {{"p50", s.compute_p50_us},
            {"p99", s.compute_p99_us},
            {"p999", s.compute_p999_us},
            {"max", s.compute_max_us}}},
          {"scheduling", s.scheduling}};
}

}  // namespace tsf::app
