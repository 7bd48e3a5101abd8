// The coupler's index of frames by key (cube cell, sources): an open-addressing hash table
// (linear probing, tombstones, power-of-two capacity) holding 64-bit keys and 32-bit frame ids.
// Edits look up and retire a few hundred frames each; a node-based std::unordered_map spends
// more on malloc/free there than on hashing.
#pragma once

#include <cstdint>
#include <vector>

namespace tsf::coupler {

class FrameIndex {
 public:
  static constexpr std::uint32_t kAbsent = 0xffffffffu;

  std::size_t size() const { return size_; }
  void clear() {
    slots_.assign(slots_.size(), Slot{});
    size_ = used_ = 0;
  }
  /// The id stored for `key`, or kAbsent.
  std::uint32_t find(std::uint64_t key) const {
    if (slots_.empty()) return kAbsent;
    const std::size_t mask = slots_.size() - 1;
    for (std::size_t i = hash(key) & mask;; i = (i + 1) & mask) {
      const Slot& s = slots_[i];
      if (s.state == kEmpty) return kAbsent;
      if (s.state == kFull && s.key == key) return s.value;
    }
  }
  /// Stores key → value (the key must not be present).
  void insert(std::uint64_t key, std::uint32_t value) {
    if ((used_ + 1) * 2 > slots_.size()) rehash(slots_.empty() ? 1024 : slots_.size() * 2);
    const std::size_t mask = slots_.size() - 1;
    std::size_t i = hash(key) & mask;
    while (slots_[i].state == kFull) i = (i + 1) & mask;
    if (slots_[i].state == kEmpty) ++used_;
    slots_[i] = {key, value, kFull};
    ++size_;
  }
  /// Removes `key` when present.
  void erase(std::uint64_t key) {
    if (slots_.empty()) return;
    const std::size_t mask = slots_.size() - 1;
    for (std::size_t i = hash(key) & mask;; i = (i + 1) & mask) {
      Slot& s = slots_[i];
      if (s.state == kEmpty) return;
      if (s.state == kFull && s.key == key) {
        s.state = kTombstone;
        --size_;
        return;
      }
    }
  }

 private:
  static constexpr std::uint8_t kEmpty = 0, kFull = 1, kTombstone = 2;
  struct Slot {
    std::uint64_t key = 0;
    std::uint32_t value = 0;
    std::uint8_t state = kEmpty;
  };
  static std::size_t hash(std::uint64_t k) {
    k ^= k >> 33;  // murmur3 finaliser
    k *= 0xff51afd7ed558ccdull;
    k ^= k >> 33;
    k *= 0xc4ceb9fe1a85ec53ull;
    k ^= k >> 33;
    return static_cast<std::size_t>(k);
  }
  void rehash(std::size_t capacity) {
    while (size_ * 2 >= capacity) capacity *= 2;
    std::vector<Slot> old;
    old.swap(slots_);
    slots_.assign(capacity, Slot{});
    size_ = used_ = 0;
    for (const Slot& s : old)
      if (s.state == kFull) insert(s.key, s.value);
  }

  std::vector<Slot> slots_;
  std::size_t size_ = 0;  ///< keys present
  std::size_t used_ = 0;  ///< slots not empty (keys + tombstones)
};

}  // namespace tsf::coupler
