// A lock-free triple buffer: one writer publishes whole objects, one reader always gets the
// newest complete one, and neither ever waits for the other (the haptic loop reading the
// simulation's frames).
//
// Three slots: the writer's back, a shared middle, the reader's front. publish() swaps back and
// middle and marks the middle fresh; acquire() swaps middle and front when the middle is fresh.
// The exchange is one atomic operation on a small integer (slot index | fresh bit), so an object
// is never read while written, and the writer reuses a slot's capacity (no allocation).
#pragma once

#include <atomic>
#include <cstdint>

namespace tsf::haptics {

template <class T>
class TripleBuffer {
 public:
  TripleBuffer() = default;
  TripleBuffer(const TripleBuffer&) = delete;
  TripleBuffer& operator=(const TripleBuffer&) = delete;

  // ---- writer (one thread) ----
  /// The object to fill next (it holds whatever was published two publishes ago).
  T& back() { return slots_[back_]; }
  /// Hands back() to the reader as the newest object.
  void publish() {
    back_ = middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel) &
            kIndex;
  }

  // ---- reader (one thread) ----
  /// The newest published object (the same one again when nothing new was published).
  const T& acquire() {
    if (middle_.load(std::memory_order_relaxed) & kFresh)
      front_ = middle_.exchange(front_, std::memory_order_acq_rel) & kIndex;
    return slots_[front_];
  }
  /// The reader's current object without looking for a newer one.
  const T& front() const { return slots_[front_]; }

 private:
  static constexpr std::uint8_t kFresh = 4, kIndex = 3;
  T slots_[3];
  std::uint8_t back_ = 0, front_ = 1;
  std::atomic<std::uint8_t> middle_{2};
};

}  // namespace tsf::haptics
