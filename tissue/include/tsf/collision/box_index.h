// A dense index over a box of lattice coordinates: for each (i, j, k) in the box, the position of
// that node or cell in some list (−1: not in it). The contact code looks nodes and cubes up by
// coordinates many times a pass; over a box that the list fills reasonably, one array read beats
// a binary search. A box much larger than its list (a huge query box) is not worth allocating:
// worth_it() says so, and the caller keeps its search.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "tsf/common/vec3.h"

namespace tsf::collision {

class BoxIndex {
 public:
  /// Whether a box of `volume` cells is worth indexing for a list of `count` entries.
  static bool worth_it(std::int64_t volume, std::size_t count) {
    return volume <= 64 * static_cast<std::int64_t>(count) + 4096;
  }
  /// The box [lo, lo + dims), every entry −1.
  void assign(const Int3& lo, const Int3& dims) {
    lo_ = lo;
    dims_ = dims;
    slots_.assign(static_cast<std::size_t>(dims.volume()), -1);
  }
  void clear() { slots_.clear(); }
  bool empty() const { return slots_.empty(); }
  bool contains(int i, int j, int k) const {
    return i >= lo_.x && j >= lo_.y && k >= lo_.z && i < lo_.x + dims_.x && j < lo_.y + dims_.y &&
           k < lo_.z + dims_.z;
  }
  /// The entry of (i, j, k), which must lie in the box.
  std::int32_t& at(int i, int j, int k) { return slots_[slot(i, j, k)]; }
  /// The entry of (i, j, k), or −1 outside the box.
  std::int32_t find(int i, int j, int k) const {
    return contains(i, j, k) ? slots_[slot(i, j, k)] : -1;
  }

 private:
  std::size_t slot(int i, int j, int k) const {
    return static_cast<std::size_t>(i - lo_.x) +
           static_cast<std::size_t>(dims_.x) *
               (static_cast<std::size_t>(j - lo_.y) +
                static_cast<std::size_t>(dims_.y) * static_cast<std::size_t>(k - lo_.z));
  }
  std::vector<std::int32_t> slots_;
  Int3 lo_{}, dims_{};
};

}  // namespace tsf::collision
