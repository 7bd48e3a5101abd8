// A moving-average filter on the force (thesis §8.6.2): the mean of the last `window` samples.
//
// It removes jitter (a window of w samples attenuates content at the tick rate's 1/w multiples to
// zero) at a latency cost: a step in the input takes exactly `window` samples to be fully felt
// (the output reaches the new value on the window-th sample counting the step's own), and a ramp
// comes out delayed by (window − 1)/2 samples. At 1 kHz a window of 4 costs 1.5 ms of mean delay;
// past a few ms the delay invites bounce (thesis §8.6.1.3). window = 1 passes the input through.
// Allocation-free after construction; one owner thread.
#pragma once

#include <vector>

#include "tsf/common/vec3.h"

namespace tsf::haptics {

class MovingAverageFilter {
 public:
  /// window ≥ 1 (throws tsf::Error otherwise).
  explicit MovingAverageFilter(int window = 1);
  /// Adds a sample and returns the mean of the last min(window, samples seen) samples.
  Vec3d filter(const Vec3d& x);
  void reset();
  int window() const { return window_; }
  /// Samples until a step is fully felt (= window).
  int step_latency_samples() const { return window_; }
  /// Mean delay of a ramp, samples: (window − 1)/2.
  double group_delay_samples() const { return 0.5 * (window_ - 1); }

 private:
  int window_;
  std::vector<Vec3d> ring_;
  Vec3d sum_{0, 0, 0};
  int next_ = 0, filled_ = 0;
};

}  // namespace tsf::haptics
