#include "tsf/haptics/haptic_metrics.h"

#include <algorithm>
#include <cmath>

#include "tsf/haptics/haptic_loop.h"

namespace tsf::haptics {

HapticMetrics compute_metrics(const std::vector<HapticSample>& s, const MetricOptions& o) {
  HapticMetrics m;
  m.samples = s.size();
  if (s.empty()) return m;
  const std::size_t n = s.size();
  std::vector<double> mag(n);
  for (std::size_t i = 0; i < n; ++i) mag[i] = length(s[i].force_un);
  m.peak_force_un = *std::max_element(mag.begin(), mag.end());
  const auto in_contact = [&](std::size_t i) { return s[i].contacts > 0 || mag[i] > 0; };

  // Jitter: residual of |F| against a local quadratic fit over the window (Savitzky–Golay,
  // 2m+1 samples): the fit follows the force's intended rise, fall and curvature, so what is left
  // is the content faster than the window (steps, ripple), not the shape of a smooth contact.
  const int m_half = std::max(2, static_cast<int>(std::lround(0.5 * o.jitter_window_s / o.tick_s)));
  const double mm = m_half;
  const double norm = (2 * mm - 1) * (2 * mm + 1) * (2 * mm + 3);
  double sum_sq = 0, sum_contact = 0;
  std::size_t fitted = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!in_contact(i)) continue;
    ++m.contact_samples;
    sum_contact += mag[i];
    if (i < static_cast<std::size_t>(m_half) || i + m_half >= n) continue;
    double fit = 0;
    for (int j = -m_half; j <= m_half; ++j)
      fit += (3.0 * (3 * mm * mm + 3 * mm - 1) - 15.0 * j * j) / norm * mag[i + j];
    sum_sq += (mag[i] - fit) * (mag[i] - fit);
    ++fitted;
  }
  if (m.contact_samples > 0)
    m.mean_contact_force_un = sum_contact / static_cast<double>(m.contact_samples);
  if (fitted > 0) m.jitter_un = std::sqrt(sum_sq / static_cast<double>(fitted));

  // Kick: the largest change of the force vector between ticks.
  for (std::size_t i = 1; i < n; ++i) {
    const double dt = s[i].time_s - s[i - 1].time_s;
    if (dt > 0)
      m.kick_un_per_s = std::max(m.kick_un_per_s, length(s[i].force_un - s[i - 1].force_un) / dt);
  }

  // Pop-through: force lost below the contact's peak while the stylus keeps pressing in
  // (moving against the last non-zero force direction).
  double peak = 0;
  Vec3d direction{0, 0, 0};
  for (std::size_t i = 1; i < n; ++i) {
    if (!in_contact(i)) {
      peak = 0;
      continue;
    }
    if (mag[i] > 0) direction = s[i].force_un / mag[i];
    peak = std::max(peak, mag[i]);
    const Vec3d v = s[i].position_mm - s[i - 1].position_mm;
    if (dot(v, direction) < -1e-9) m.pop_through_un = std::max(m.pop_through_un, peak - mag[i]);
  }

  m.filter_delay_ms = 0.5 * (o.filter_window - 1) * o.tick_s * 1e3;
  double age_sum = 0;
  std::vector<float> compute(n);
  for (std::size_t i = 0; i < n; ++i) {
    age_sum += s[i].frame_age_s;
    m.max_frame_age_ms = std::max(m.max_frame_age_ms, s[i].frame_age_s * 1e3);
    compute[i] = s[i].compute_us;
  }
  m.mean_frame_age_ms = age_sum / static_cast<double>(n) * 1e3;
  m.latency_ms = m.filter_delay_ms + m.mean_frame_age_ms;
  m.bounce_prone = m.latency_ms > o.bounce_latency_s * 1e3;
  m.compute_p50_us = percentile(compute, 0.5);
  m.compute_p99_us = percentile(compute, 0.99);
  m.compute_max_us = percentile(compute, 1.0);
  if (m.peak_force_un > 0) {
    m.jitter_relative = m.jitter_un / m.peak_force_un;
    m.kick_relative_per_ms = m.kick_un_per_s * 1e-3 / m.peak_force_un;
    m.pop_through_relative = m.pop_through_un / m.peak_force_un;
  }
  return m;
}

}  // namespace tsf::haptics
