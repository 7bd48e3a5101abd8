#include "tsf/haptics/moving_average.h"

#include <string>

#include "tsf/common/error.h"

namespace tsf::haptics {

MovingAverageFilter::MovingAverageFilter(int window) : window_(window) {
  require(window >= 1, "filter window: expected ≥ 1 sample, got " + std::to_string(window));
  ring_.assign(static_cast<std::size_t>(window), Vec3d{0, 0, 0});
}

Vec3d MovingAverageFilter::filter(const Vec3d& x) {
  if (window_ == 1) return x;
  if (filled_ == window_)
    sum_ -= ring_[static_cast<std::size_t>(next_)];
  else
    ++filled_;
  ring_[static_cast<std::size_t>(next_)] = x;
  sum_ += x;
  next_ = (next_ + 1) % window_;
  // Re-sum once per lap so rounding of the running sum never accumulates.
  if (next_ == 0 && filled_ == window_) {
    sum_ = {0, 0, 0};
    for (const Vec3d& v : ring_) sum_ += v;
  }
  return sum_ / static_cast<double>(filled_);
}

void MovingAverageFilter::reset() {
  sum_ = {0, 0, 0};
  next_ = filled_ = 0;
}

}  // namespace tsf::haptics
