// The haptic loop of a viewer session (docs/haptics.md, "Live haptics"): a device drives the
// first hand's tool, the loop ticks on its own thread at the haptic rate (1 kHz by default)
// reading the newest frame the simulation thread captured around that tool, and the render
// thread shows the force in the HUD and the live plot.
//
//   device (mouse and keyboard, a    ──pose──►  haptic thread: HapticLoop (tsf/haptics)
//   scripted trajectory, a driver)   ◄─force──    read device → newest frame → model → filter
//                                                  ▲ triple buffer              │ seqlock
//   simulation thread: SimulationSession::step      │                           ▼
//     the hand's pose = the device's ──► apply_tool, advance ──► publish(frame) render: HUD, plot
//
// Offscreen (reproducible frames) the loop's thread does not run: each rendered frame takes one
// tick on the render thread (tick_now), with a scripted device set to the frame's time.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>

#include "tsf/haptics/force_models.h"
#include "tsf/haptics/frame_capture.h"
#include "tsf/haptics/haptic_device.h"
#include "tsf/haptics/haptic_loop.h"
#include "tsf/haptics/triple_buffer.h"
#include "tsf/interaction/tissue_model.h"

namespace tsf::viewer {

struct LiveHapticsOptions {
  haptics::ForceModelKind model = haptics::ForceModelKind::kLattice;
  haptics::ForceModelOptions force;  ///< stylus radius, resolution, law (voxel and mesh models)
  haptics::HapticLoopOptions loop;   ///< rate, filter, device frame, thread start hook
  double capture_margin_mm = 3.0;    ///< stylus travel between two captures
};

class LiveHaptics {
 public:
  /// Throws tsf::Error naming the option when one is out of range.
  LiveHaptics(std::unique_ptr<haptics::HapticDevice> device, const LiveHapticsOptions& options);
  ~LiveHaptics();  ///< stops the loop
  LiveHaptics(const LiveHaptics&) = delete;
  LiveHaptics& operator=(const LiveHaptics&) = delete;

  /// Starts the loop's thread (window); offscreen, call tick_now() per frame instead.
  void start();
  void stop();
  bool running() const { return loop_->running(); }
  /// One tick on the calling thread (offscreen); returns the force, µN.
  Vec3d tick_now() { return loop_->tick_now(); }

  haptics::HapticDevice& device() { return *device_; }
  const LiveHapticsOptions& options() const { return options_; }
  /// The device as of the latest tick, in tissue space (any thread). Before the first tick: the
  /// device read on the calling thread is not safe, so callers start the loop first.
  haptics::DeviceState device_state() const { return loop_->latest_device_state(); }

  /// Simulation thread, after a step: captures the tissue around `pose` (the device's tool in
  /// `slot`, pressing or not) and hands it to the loop.
  void publish(interaction::TissueModel& model, const ToolPose& pose, int slot);

  /// Render thread: the latest force (tissue space, µN), the ticks so far, and the rate over the
  /// last second of wall time.
  Vec3d force_un() const { return loop_->latest_force(); }
  std::int64_t ticks() const { return loop_->ticks(); }
  double recent_rate_hz();
  /// After stop(): the loop's statistics (rate, missed ticks, latency percentiles).
  haptics::LoopStatistics statistics() const { return loop_->statistics(); }
  /// The largest force rendered so far (render thread's samples), µN.
  double max_force_seen_un() const { return max_force_seen_; }
  void note_force(double un) { max_force_seen_ = un > max_force_seen_ ? un : max_force_seen_; }

 private:
  LiveHapticsOptions options_;
  std::unique_ptr<haptics::HapticDevice> device_;
  std::unique_ptr<haptics::ForceModel> model_;
  haptics::TripleBuffer<haptics::HapticFrame> frames_;
  haptics::TissueFrameCapture capture_;
  std::unique_ptr<haptics::HapticLoop> loop_;
  std::deque<std::pair<std::chrono::steady_clock::time_point, std::int64_t>> recent_;
  double max_force_seen_ = 0;
  double time_s_ = 0;
};

}  // namespace tsf::viewer
