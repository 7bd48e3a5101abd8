// A seqlock for small trivially copyable values (a stylus pose, a force): one writer never waits;
// readers retry while a write is in progress. The payload lives in relaxed atomic words, so a torn
// read is detected by the sequence number rather than being a data race.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace tsf::haptics {

template <class T>
class Seqlock {
  static_assert(std::is_trivially_copyable<T>::value, "Seqlock holds trivially copyable values");

 public:
  explicit Seqlock(const T& initial = T{}) { store(initial); }

  /// One writer thread.
  void store(const T& value) {
    std::uint64_t words[kWords] = {};
    std::memcpy(words, &value, sizeof(T));
    const std::uint64_t s = sequence_.load(std::memory_order_relaxed);
    sequence_.store(s + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    for (int i = 0; i < kWords; ++i) words_[i].store(words[i], std::memory_order_relaxed);
    sequence_.store(s + 2, std::memory_order_release);
  }

  /// Any thread; lock-free for the writer, retries while a store is in progress.
  T load() const {
    std::uint64_t words[kWords];
    for (;;) {
      const std::uint64_t s0 = sequence_.load(std::memory_order_acquire);
      if (s0 & 1) continue;
      for (int i = 0; i < kWords; ++i) words[i] = words_[i].load(std::memory_order_relaxed);
      std::atomic_thread_fence(std::memory_order_acquire);
      if (sequence_.load(std::memory_order_relaxed) == s0) break;
    }
    T value;
    std::memcpy(&value, words, sizeof(T));
    return value;
  }

 private:
  static constexpr int kWords = static_cast<int>((sizeof(T) + 7) / 8);
  std::atomic<std::uint64_t> sequence_{0};
  std::atomic<std::uint64_t> words_[kWords] = {};
};

}  // namespace tsf::haptics
