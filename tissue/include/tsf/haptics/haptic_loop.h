// The haptic loop: its own thread ticking at a fixed rate (default 1 kHz, 5–10 kHz possible),
// each tick reading the device, the newest simulation frame (triple buffer: never waits for the
// solver or a renderer), evaluating the force model, filtering, clamping to the device and
// writing the force back.
//
// Ticks are scheduled on absolute deadlines (start + k·period): a late tick does not shift the
// ones after it, so the long-run rate holds even when the OS delays single wake-ups; ticks more
// than a period late are counted. The stylus state is published through a seqlock so the
// simulation thread can press the tissue where the stylus is (SimulationPump below).
#pragma once

#include <atomic>
#include <cstdint>
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

  void validate() const;
};

struct LoopStatistics {
  std::int64_t ticks = 0;
  double elapsed_s = 0;         ///< first tick to last
  double rate_hz = 0;           ///< (ticks − 1) / elapsed
  std::int64_t late_ticks = 0;  ///< started more than one period after their deadline
  double max_lateness_us = 0;
  double compute_p50_us = 0, compute_p99_us = 0, compute_p999_us = 0, compute_max_us = 0;
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
  bool running() const { return running_.load(); }

  /// The device state of the latest tick (any thread).
  DeviceState latest_device_state() const { return device_state_.load(); }
  Vec3d latest_force() const { return force_.load(); }

  // After stop():
  LoopStatistics statistics() const;
  const std::vector<HapticSample>& samples() const { return samples_; }
  const std::vector<float>& compute_us() const { return compute_us_; }

 private:
  void run();

  HapticDevice& device_;
  const ForceModel& model_;
  TripleBuffer<HapticFrame>& frames_;
  HapticLoopOptions options_;
  MovingAverageFilter filter_;
  std::thread thread_;
  std::atomic<bool> running_{false}, stop_{false};
  Seqlock<DeviceState> device_state_;
  Seqlock<Vec3d> force_;
  std::vector<HapticSample> samples_;
  std::vector<float> compute_us_;
  std::int64_t ticks_ = 0, late_ = 0;
  double elapsed_s_ = 0, max_late_us_ = 0;
};

/// The simulation thread of a live session: steps a FrameSource at `rate_hz` with the stylus
/// where the loop last read it, publishing a frame after each step. (A viewer runs its own
/// simulation loop and calls source.step() + frames.publish() the same way.)
class SimulationPump {
 public:
  SimulationPump(FrameSource& source, TripleBuffer<HapticFrame>& frames, const HapticLoop& loop,
                 double rate_hz);
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
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::int64_t> steps_{0};
  double max_step_us_ = 0;
};

}  // namespace tsf::haptics
