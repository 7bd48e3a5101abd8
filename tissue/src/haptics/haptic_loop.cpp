#include "tsf/haptics/haptic_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "tsf/common/error.h"

namespace tsf::haptics {

using Clock = std::chrono::steady_clock;

void HapticLoopOptions::validate() const {
  require(std::isfinite(rate_hz) && rate_hz > 0 && rate_hz <= 20000,
          "haptic rate: expected (0, 20000] Hz, got " + std::to_string(rate_hz));
  require(filter_window >= 1 && filter_window <= 1000,
          "filter window: expected 1..1000 samples, got " + std::to_string(filter_window));
  require(
      std::isfinite(max_force_un) && max_force_un >= 0,
      "haptic max force: expected ≥ 0 µN (0: the device's), got " + std::to_string(max_force_un));
}

double percentile(std::vector<float> values, double p) {
  if (values.empty()) return 0.0;
  const std::size_t n = values.size();
  const auto rank =
      static_cast<std::size_t>(std::ceil(std::clamp(p, 0.0, 1.0) * static_cast<double>(n)));
  const std::size_t at = rank == 0 ? 0 : rank - 1;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(at), values.end());
  return values[at];
}

HapticLoop::HapticLoop(HapticDevice& device, const ForceModel& model,
                       TripleBuffer<HapticFrame>& frames, const HapticLoopOptions& options)
    : device_(device),
      model_(model),
      frames_(frames),
      options_(options),
      filter_(options.filter_window),
      max_force_(options.max_force_un > 0 ? std::min(options.max_force_un, device.max_force_un())
                                          : device.max_force_un()) {
  options_.validate();
  compute_us_.reserve(std::min<std::size_t>(options_.max_ticks, 1 << 16));
  latency_us_.reserve(std::min<std::size_t>(options_.max_ticks, 1 << 16));
}

HapticLoop::~HapticLoop() {
  stop();
}

void HapticLoop::start() {
  require(!running_.load() && !thread_.joinable(), "haptic loop: already started");
  samples_.clear();
  compute_us_.clear();
  latency_us_.clear();
  compute_us_.reserve(options_.max_ticks);
  latency_us_.reserve(options_.max_ticks);
  if (options_.record_samples) samples_.reserve(options_.max_ticks);
  ticks_ = late_ = missed_ = 0;
  live_ticks_ = 0;
  max_late_us_ = 0;
  stop_ = false;
  running_ = true;
  device_.on_loop_start();
  thread_ = std::thread([this] { run(); });
}

void HapticLoop::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  running_ = false;
}

void HapticLoop::run() {
  if (options_.on_thread_start) scheduling_ = options_.on_thread_start();
  const auto period = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(1.0 / options_.rate_hz));
  const auto start = Clock::now();
  auto deadline = start;
  Clock::time_point last_deadline = start;
  while (!stop_.load(std::memory_order_relaxed)) {
    std::this_thread::sleep_until(deadline);
    const auto t0 = Clock::now();
    if (t0 - deadline > 2 * period) {
      // A stall: skip the deadlines it swallowed rather than burst through them.
      const auto behind = (t0 - deadline) / period;
      missed_ += behind;
      deadline += behind * period;
    }
    if (t0 - deadline > period) ++late_;
    max_late_us_ =
        std::max(max_late_us_, std::chrono::duration<double, std::micro>(t0 - deadline).count());
    tick(t0, deadline, start);
    last_deadline = deadline;
    deadline += period;
  }
  elapsed_s_ = std::chrono::duration<double>(last_deadline - start).count();
}

Vec3d HapticLoop::tick_now() {
  require(!running_.load(), "haptic loop: tick_now() while the loop's thread runs");
  const auto t0 = Clock::now();
  if (ticks_ == 0) first_tick_ = t0;
  tick(t0, t0, first_tick_);
  elapsed_s_ = std::chrono::duration<double>(t0 - first_tick_).count();
  return force_.load();
}

void HapticLoop::tick(Clock::time_point t0, Clock::time_point deadline, Clock::time_point start) {
  const bool patient = device_.frame() == PoseFrame::kPatient;
  DeviceState state = device_.read();
  if (patient) state.pose = options_.frame.to_tissue(state.pose);
  const HapticFrame& frame = frames_.acquire();
  const HapticFrameView view = frame.view();
  const HapticForce raw = model_.evaluate(view, state.pose);
  Vec3d f = filter_.filter(state.pressing ? raw.force_un : Vec3d{0, 0, 0});
  const double fm = length(f);
  if (fm > max_force_) f = f * (max_force_ / fm);
  device_.apply_force(patient ? options_.frame.vector_to_patient(f) : f);
  device_state_.store(state);
  force_.store(f);

  const auto t1 = Clock::now();
  const float us = static_cast<float>(std::chrono::duration<double, std::micro>(t1 - t0).count());
  if (compute_us_.size() < options_.max_ticks) {
    compute_us_.push_back(us);
    latency_us_.push_back(
        static_cast<float>(std::chrono::duration<double, std::micro>(t1 - deadline).count()));
  }
  if (options_.record_samples && samples_.size() < options_.max_ticks) {
    HapticSample s;
    s.time_s = std::chrono::duration<double>(t0 - start).count();
    s.position_mm = state.pose.position;
    s.raw_force_un = raw.force_un;
    s.force_un = f;
    s.intersection_mm3 = raw.intersection_mm3;
    s.contacts = raw.contacts;
    // Wall clock: the frame's age is the time since its publisher stamped it.
    if (view.published_ns > 0) {
      const std::int64_t now_ns =
          std::chrono::duration_cast<std::chrono::nanoseconds>(t0.time_since_epoch()).count();
      s.frame_age_s = std::max(0.0, 1e-9 * static_cast<double>(now_ns - view.published_ns));
    }
    s.compute_us = us;
    samples_.push_back(s);
  }
  ++ticks_;
  live_ticks_.store(ticks_, std::memory_order_relaxed);
}

LoopStatistics HapticLoop::statistics() const {
  LoopStatistics s;
  s.ticks = ticks_;
  s.elapsed_s = elapsed_s_;
  s.rate_hz = elapsed_s_ > 0 ? static_cast<double>(ticks_ - 1) / elapsed_s_ : 0.0;
  s.target_rate_hz = options_.rate_hz;
  s.late_ticks = late_;
  s.missed_ticks = missed_;
  s.max_lateness_us = max_late_us_;
  s.latency_p50_us = percentile(latency_us_, 0.5);
  s.latency_p99_us = percentile(latency_us_, 0.99);
  s.latency_p999_us = percentile(latency_us_, 0.999);
  s.latency_max_us = percentile(latency_us_, 1.0);
  s.scheduling = scheduling_;
  s.compute_p50_us = percentile(compute_us_, 0.5);
  s.compute_p99_us = percentile(compute_us_, 0.99);
  s.compute_p999_us = percentile(compute_us_, 0.999);
  s.compute_max_us = percentile(compute_us_, 1.0);
  return s;
}

void HapticFrame::stamp_now() {
  published_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

// ---- simulation pump -----------------------------------------------------------------------

SimulationPump::SimulationPump(FrameSource& source, TripleBuffer<HapticFrame>& frames,
                               const HapticLoop& loop, double rate_hz,
                               std::function<void()> on_start)
    : source_(source),
      frames_(frames),
      loop_(loop),
      rate_hz_(rate_hz),
      on_start_(std::move(on_start)) {
  require(std::isfinite(rate_hz) && rate_hz > 0,
          "simulation rate: expected a finite number > 0 Hz, got " + std::to_string(rate_hz));
}

SimulationPump::~SimulationPump() {
  stop();
}

void SimulationPump::start() {
  require(!thread_.joinable(), "simulation pump: already started");
  stop_ = false;
  thread_ = std::thread([this] { run(); });
}

void SimulationPump::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void SimulationPump::run() {
  if (on_start_) on_start_();
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_hz_));
  auto deadline = Clock::now();
  const double dt = 1.0 / rate_hz_;
  while (!stop_.load(std::memory_order_relaxed)) {
    const auto t0 = Clock::now();
    const DeviceState state = loop_.latest_device_state();
    source_.step(dt, state.pose, state.pressing, frames_.back());
    frames_.back().stamp_now();
    frames_.publish();
    steps_.fetch_add(1, std::memory_order_relaxed);
    max_step_us_ = std::max(max_step_us_,
                            std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
    deadline += period;
    // A simulation slower than its rate runs flat out instead of accumulating debt.
    if (Clock::now() > deadline) deadline = Clock::now();
    std::this_thread::sleep_until(deadline);
  }
}

}  // namespace tsf::haptics
