// The haptic loop: its own thread ticking at a fixed rate (default 1 kHz, 5–10 kHz possible),
// each tick reading the device, the newest simulation frame (triple buffer: never waits for the
// solver or a renderer), evaluating the force model, filtering, clamping to the device and
// writing the force back.
//
// Ticks are scheduled on absolute deadlines (start + k·period): a late wake-up does not shift the
// ticks after it, so the long-run rate holds when the OS delays single wake-ups. A stall longer
// than two periods is not made up with a burst of back-to-back ticks (a device gains nothing from
// them): the missed deadlines are skipped and counted, so the achieved rate is what the device got.
// Each tick's latency (its deadline to the force written) and compute time are kept for
// percentiles. The stylus state is published through a seqlock so the simulation thread can press
// the tissue where the stylus is (SimulationPump below, or a viewer's simulation thread).
//
// The device's poses come in its own frame and its forces go back in it (device_frame.h): the
// loop works in tissue space.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "tsf/haptics/force_models.h"
#include "tsf/haptics/frame_capture.h"
#include "tsf/haptics/haptic_device.h"
#include "tsf/haptics/haptic_sample.h"
#include "tsf/haptics/moving_average.h"
#include "tsf/haptics/seqlock.h"
#include "tsf/haptics/triple_buffer.h"

namespace tsf::haptics {

struct HapticLoopOptions {
  double rate_hz = 1000.0;          ///< (0, 20000]
  int filter_window = 1;            ///< moving average, samples ≥ 1
  bool record_samples = false;      ///< keep every tick's HapticSample (up to max_ticks)
  std::size_t max_ticks = 1 << 20;  ///< tick-time records kept (the loop runs on past it)
  DeviceFrame frame;                ///< tissue ↔ patient, for devices that speak patient LPS
  double max_force_un = 0;          ///< clamp, µN (0: the device's max_force_un() only)
  /// Runs first on the haptic thread (e.g. the app asks for a real-time priority there); what it
  /// returns is reported as LoopStatistics::scheduling.
  std::function<std::string()> on_thread_start;

  void validate() const;
};

struct LoopStatistics {
  std::int64_t ticks = 0;
  double elapsed_s = 0;           ///< first tick's deadline to the last one's
  double rate_hz = 0;             ///< (ticks − 1) / elapsed: what the device got
  double target_rate_hz = 0;      ///< the rate asked for
  std::int64_t late_ticks = 0;    ///< started more than one period after their deadline
  std::int64_t missed_ticks = 0;  ///< deadlines skipped after a stall of more than two periods
  double max_lateness_us = 0;
  /// Tick latency: the tick's deadline to its force written (wake-up delay + compute), µs.
  double latency_p50_us = 0, latency_p99_us = 0, latency_p999_us = 0, latency_max_us = 0;
  /// Compute: device read + frame + model + filter + write, µs.
  double compute_p50_us = 0, compute_p99_us = 0, compute_p999_us = 0, compute_max_us = 0;
  std::string scheduling;  ///< what on_thread_start reported (empty: not asked)
};

/// p in [0, 1]: the nearest-rank percentile of `values` (0 when empty).
double percentile(std::vector<float> values, double p);

class HapticLoop {
 public:
  /// device, model and frames must outlive the loop.
  HapticLoop(HapticDevice& device, const ForceModel& model, TripleBuffer<HapticFrame>& frames,
             const HapticLoopOptions& options);
  ~HapticLoop();
  HapticLoop(const HapticLoop&) = delete;
  HapticLoop& operator=(const HapticLoop&) = delete;

  void start();
  /// Stops and joins the thread (idempotent).
  void stop();
  /// One tick now, on the calling thread, without starting the loop's thread (offscreen frames:
  /// one tick per rendered frame, reproducible); returns the force rendered (tissue space, µN).
  Vec3d tick_now();
  bool running() const { return running_.load(); }

  /// The device state of the latest tick, in tissue space (any thread).
  DeviceState latest_device_state() const { return device_state_.load(); }
  /// The force of the latest tick, tissue space, µN (any thread).
  Vec3d latest_force() const { return force_.load(); }
  /// Ticks so far (any thread; a live rate is its change over wall time).
  std::int64_t ticks() const { return live_ticks_.load(std::memory_order_relaxed); }

  // After stop():
  LoopStatistics statistics() const;
  const std::vector<HapticSample>& samples() const { return samples_; }
  const std::vector<float>& compute_us() const { return compute_us_; }
  const std::vector<float>& latency_us() const { return latency_us_; }

 private:
  using Clock = std::chrono::steady_clock;
  void run();
  /// Read, evaluate, filter, clamp, write; records the tick (t0: it began; deadline: it was due).
  void tick(Clock::time_point t0, Clock::time_point deadline, Clock::time_point start);

  HapticDevice& device_;
  const ForceModel& model_;
  TripleBuffer<HapticFrame>& frames_;
  HapticLoopOptions options_;
  MovingAverageFilter filter_;
  double max_force_;
  Clock::time_point first_tick_;
  std::thread thread_;
  std::atomic<bool> running_{false}, stop_{false};
  Seqlock<DeviceState> device_state_;
  Seqlock<Vec3d> force_;
  std::vector<HapticSample> samples_;
  std::vector<float> compute_us_, latency_us_;
  std::int64_t ticks_ = 0, late_ = 0, missed_ = 0;
  std::atomic<std::int64_t> live_ticks_{0};
  double elapsed_s_ = 0, max_late_us_ = 0;
  std::string scheduling_;
};

/// The simulation thread of a live session: steps a FrameSource at `rate_hz` with the stylus
/// where the loop last read it, publishing a frame after each step. (A viewer runs its own
/// simulation loop and calls source.step() + frames.publish() the same way.)
class SimulationPump {
 public:
  /// `on_start` runs first on the pump's thread (e.g. lowering its priority below the loop's).
  SimulationPump(FrameSource& source, TripleBuffer<HapticFrame>& frames, const HapticLoop& loop,
                 double rate_hz, std::function<void()> on_start = {});
  ~SimulationPump();
  void start();
  void stop();
  std::int64_t steps() const { return steps_.load(); }
  /// Wall time of the slowest step, µs.
  double max_step_us() const { return max_step_us_; }

 private:
  void run();
  FrameSource& source_;
  TripleBuffer<HapticFrame>& frames_;
  const HapticLoop& loop_;
  double rate_hz_;
  std::function<void()> on_start_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::int64_t> steps_{0};
  double max_step_us_ = 0;
};

}  // namespace tsf::haptics
