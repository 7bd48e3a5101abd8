#include "tsf/common/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace tsf {

bool Progress::stderr_is_terminal() {
  return ::isatty(STDERR_FILENO) == 1;
}

Progress::Progress(std::string label, std::uint64_t total, bool enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_ - std::chrono::seconds(1)) {}

Progress::~Progress() {
  finish();
}

void Progress::advance(std::uint64_t units) {
  done_.fetch_add(units, std::memory_order_relaxed);
  draw(false);
}

void Progress::set(std::uint64_t done) {
  done_.store(done, std::memory_order_relaxed);
  draw(false);
}

void Progress::set_fraction(double fraction) {
  if (total_ == 0) total_ = 1000;
  set(static_cast<std::uint64_t>(std::clamp(fraction, 0.0, 1.0) * static_cast<double>(total_)));
}

void Progress::finish() {
  if (finished_) return;
  draw(true);
  finished_ = true;
}

void Progress::draw(bool final_draw) {
  if (!enabled_) return;
  std::unique_lock<std::mutex> lock(draw_mutex_, std::try_to_lock);
  if (!lock.owns_lock() && !final_draw) return;  // another thread is drawing: skip, never block
  if (!lock.owns_lock()) lock.lock();
  const auto now = std::chrono::steady_clock::now();
  if (!final_draw && now - last_draw_ < std::chrono::milliseconds(100)) return;
  last_draw_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const std::uint64_t done = done_.load(std::memory_order_relaxed);
  constexpr int kWidth = 30;
  if (total_ > 0) {
    const double f = std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
    const int filled = static_cast<int>(f * kWidth);
    char bar[kWidth + 1];
    for (int i = 0; i < kWidth; ++i) bar[i] = i < filled ? '#' : '.';
    bar[kWidth] = '\0';
    const double eta = f > 0.01 ? elapsed * (1.0 - f) / f : 0.0;
    if (final_draw)
      std::fprintf(stderr, "\r%s [%s] %5.1f%%  done in %.2f s\x1b[K\n", label_.c_str(), bar,
                   100.0 * f, elapsed);
    else
      std::fprintf(stderr, "\r%s [%s] %5.1f%%  %.1f s, ~%.0f s left\x1b[K", label_.c_str(), bar,
                   100.0 * f, elapsed, eta);
  } else {
    std::fprintf(stderr, "\r%s %llu  %.1f s%s\x1b[K%s", label_.c_str(),
                 static_cast<unsigned long long>(done), elapsed, final_draw ? " done" : "",
                 final_draw ? "\n" : "");
  }
  std::fflush(stderr);
}

}  // namespace tsf
