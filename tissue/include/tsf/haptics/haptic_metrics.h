// Quality measures of a recorded haptic trajectory (thesis §8.6.1), each a number a regression
// can watch:
//   jitter         high-frequency energy: RMS of |F| minus a local quadratic fit over
//                  `jitter_window_s` (Savitzky–Golay), in contact, µN: steps and ripple faster
//                  than the window, not the smooth rise and fall of a contact
//   kick           max |dF/dt| between ticks, µN/s (a sudden change felt as a knock)
//   pop-through    force lost while pressing deeper: the largest drop of |F| below its peak in a
//                  contact while the stylus moves against the force, µN
//   latency        filter group delay + mean frame age; bounce-prone when it exceeds
//                  `bounce_latency_s` (the thesis: below ~300 Hz, i.e. > 3.3 ms, the stylus
//                  bounces)
// Relative values divide by the peak force.
#pragma once

#include <vector>

#include "tsf/haptics/haptic_sample.h"

namespace tsf::haptics {

struct MetricOptions {
  double tick_s = 1e-3;
  int filter_window = 1;
  double jitter_window_s = 0.01;
  double bounce_latency_s = 1.0 / 300.0;
};

struct HapticMetrics {
  std::size_t samples = 0, contact_samples = 0;
  double peak_force_un = 0, mean_contact_force_un = 0;
  double jitter_un = 0, jitter_relative = 0;
  double kick_un_per_s = 0, kick_relative_per_ms = 0;  ///< the latter: max ΔF per ms / peak
  double pop_through_un = 0, pop_through_relative = 0;
  double filter_delay_ms = 0, mean_frame_age_ms = 0, max_frame_age_ms = 0, latency_ms = 0;
  bool bounce_prone = false;
  double compute_p50_us = 0, compute_p99_us = 0, compute_max_us = 0;
};

HapticMetrics compute_metrics(const std::vector<HapticSample>& samples,
                              const MetricOptions& options);

}  // namespace tsf::haptics
