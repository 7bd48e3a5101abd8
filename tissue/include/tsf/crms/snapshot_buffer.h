// Double-buffered node positions for readers (viewer, haptics) that must never stall the solver.
//
// The solver's thread fills the back buffer (on CUDA: a device→pinned-host copy on a side stream)
// and publishes it when complete; publishing swaps front and back under a short lock and bumps the
// version. Readers on any thread copy the front buffer (or visit it) under the same lock. A
// snapshot requested while the previous copy is still in flight is dropped, not queued: the
// solver never waits for a reader or for PCIe.
//
// positions  #nodes×3 floats, interleaved x,y,z, mm, tissue space (dead nodes: last position)
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <vector>

namespace tsf::crms {

class SnapshotBuffer {
 public:
  /// Two buffers of `node_count`×3 floats owned by the caller (pinned host memory on CUDA).
  SnapshotBuffer(float* buffer_a, float* buffer_b, std::int64_t node_count);
  SnapshotBuffer(const SnapshotBuffer&) = delete;
  SnapshotBuffer& operator=(const SnapshotBuffer&) = delete;

  // ---- producer (the solver's thread) ----
  /// Supplies the two buffers later (allocation on first use); only before the first publish.
  void attach(float* buffer_a, float* buffer_b);
  bool attached() const { return buffers_[0] != nullptr; }
  float* back() { return buffers_[1 - front_]; }
  /// Makes the back buffer (holding the state after `step` steps) the readers' front.
  void publish(std::int64_t step);
  /// Counts requests dropped because a copy was still in flight.
  void count_dropped() { ++dropped_; }

  // ---- readers (any thread) ----
  /// 0 until the first publish; increases by one per publish.
  std::uint64_t version() const;
  /// Copies the latest positions; returns its version (0 = nothing published yet).
  std::uint64_t copy_latest(std::vector<float>& positions, std::int64_t* step = nullptr) const;
  /// Calls `visit(positions, node_count, version, step)` on the front buffer under the lock;
  /// `visit` must be quick (it holds off the next publish, never the solver's stepping).
  void visit_latest(const std::function<void(const float*, std::int64_t, std::uint64_t,
                                             std::int64_t)>& visit) const;
  std::int64_t node_count() const { return node_count_; }
  std::uint64_t dropped() const { return dropped_.load(); }

 private:
  float* buffers_[2];
  std::int64_t node_count_;
  int front_ = 0;
  std::uint64_t version_ = 0;
  std::int64_t step_ = 0;
  std::atomic<std::uint64_t> dropped_{0};
  mutable std::mutex mutex_;
};

}  // namespace tsf::crms
