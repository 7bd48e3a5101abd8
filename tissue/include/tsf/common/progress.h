// Terminal progress for long work (reads, filters, long simulations).
//
// Draws a single updating line on stderr when stderr is a terminal, at most ~10 times a second;
// prints nothing when stderr is redirected (logs and CI stay clean) unless forced. Thread-safe:
// `advance` may be called from OpenMP workers.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace tsf {

class Progress {
 public:
  /// `label` is shown before the bar; `total` is the number of work units (0 = unknown).
  Progress(std::string label, std::uint64_t total, bool enabled = stderr_is_terminal());
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void advance(std::uint64_t units = 1);
  void set(std::uint64_t done);
  /// Fraction in [0,1] (e.g. from an ITK progress event).
  void set_fraction(double fraction);
  /// Ends the line ("done in 1.23 s"); called by the destructor if not called before.
  void finish();

  static bool stderr_is_terminal();

 private:
  void draw(bool final_draw);

  std::string label_;
  std::uint64_t total_;
  bool enabled_;
  bool finished_ = false;
  std::atomic<std::uint64_t> done_{0};
  std::mutex draw_mutex_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

}  // namespace tsf
