// A hash map from 64-bit keys to small values for the edit path: open addressing with linear
// probing, a power-of-two table kept at most half full (slots in use, tombstones included),
// tombstones for erase. Edits look up, add and retire thousands of keys each (the coupler's
// frames by cube cell and sources, a tool stroke's applied weight per voxel); a node-based
// std::unordered_map spends more there on one allocation per key than on hashing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace tsf {

template <typename Value>
class OpenHashMap {
 public:
  /// Keys present.
  std::size_t size() const { return size_; }
  /// Forgets every key and keeps the table's capacity (a no-op when already empty).
  void clear() {
    if (used_ == 0) return;
    for (Slot& s : slots_) s.state = kEmpty;
    size_ = used_ = 0;
  }
  /// The value stored for `key`, or nullptr.
  const Value* find(std::uint64_t key) const {
    const std::size_t i = locate(key);
    return i == kNowhere ? nullptr : &slots_[i].value;
  }
  /// The value stored for `key`, stored as Value{} first when absent.
  Value& operator[](std::uint64_t key) {
    if (2 * (used_ + 1) > slots_.size()) rehash();
    const std::size_t mask = slots_.size() - 1;
    std::size_t reuse = slots_.size();  // the first tombstone on the probe path
    std::size_t i = hash(key);
    for (;; i = (i + 1) & mask) {
      Slot& s = slots_[i];
      if (s.state == kFull && s.key == key) return s.value;
      if (s.state == kTombstone && reuse == slots_.size()) reuse = i;
      if (s.state == kEmpty) break;
    }
    if (reuse != slots_.size()) {
      i = reuse;
    } else {
      ++used_;
    }
    slots_[i] = {key, Value{}, kFull};
    ++size_;
    return slots_[i].value;
  }
  /// Removes `key` when present.
  void erase(std::uint64_t key) {
    const std::size_t i = locate(key);
    if (i == kNowhere) return;
    slots_[i].state = kTombstone;
    --size_;
  }

 private:
  static constexpr std::uint8_t kEmpty = 0, kFull = 1, kTombstone = 2;
  static constexpr std::size_t kNowhere = ~std::size_t{0};
  struct Slot {
    std::uint64_t key = 0;
    Value value{};
    std::uint8_t state = kEmpty;
  };
  // Fibonacci hashing: the key times 2^64/φ, the product's top log2(capacity) bits, a slot index.
  // One multiply; every bit of the key reaches the top ones, so keys that differ only in their high
  // bits (the coupler's cube cells) or only in their low ones (a row of voxels) spread as well.
  std::size_t hash(std::uint64_t k) const {
    return static_cast<std::size_t>((k * 0x9E3779B97F4A7C15ull) >> shift_);
  }
  // The slot holding `key`, or kNowhere.
  std::size_t locate(std::uint64_t key) const {
    if (slots_.empty()) return kNowhere;
    const std::size_t mask = slots_.size() - 1;
    for (std::size_t i = hash(key);; i = (i + 1) & mask) {
      const Slot& s = slots_[i];
      if (s.state == kEmpty) return kNowhere;
      if (s.state == kFull && s.key == key) return i;
    }
  }
  // Re-inserts the keys present (tombstones dropped) into a table at least four times their
  // number, so that it is at most a quarter full afterwards.
  void rehash() {
    std::size_t capacity = slots_.empty() ? 1024 : slots_.size();
    while (4 * (size_ + 1) > capacity) capacity *= 2;
    std::vector<Slot> old(capacity);
    old.swap(slots_);
    shift_ = 64;
    for (std::size_t c = capacity; c > 1; c >>= 1) --shift_;
    const std::size_t mask = capacity - 1;
    for (const Slot& s : old) {
      if (s.state != kFull) continue;
      std::size_t i = hash(s.key);
      while (slots_[i].state != kEmpty) i = (i + 1) & mask;
      slots_[i] = s;
    }
    used_ = size_;
  }

  std::vector<Slot> slots_;
  std::size_t size_ = 0;  ///< keys present
  std::size_t used_ = 0;  ///< slots not empty (keys and tombstones)
  int shift_ = 63;        ///< 64 − log2(capacity), set by rehash() before any hash()
};

}  // namespace tsf
