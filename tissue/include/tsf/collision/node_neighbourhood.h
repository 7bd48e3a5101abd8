// The deformed lattice near a tool, copied out of the solver (host memory on both backends):
// every alive node whose deformed position lies in a query box, its displacement, and the exact
// tool-vs-node test. Contact resolution, the inverse map and the narrow phase all read from it,
// so the CPU and CUDA backends run the same host logic on the same data.
//
//   nodes         ascending lattice node indices
//   displacement  per node, mm
//   inside        per node, 1 when the node is inside the tool (node_in_tool)
//   target        per node, nearest tool surface point (mm) when inside
//   normal        per node, outward tool normal there
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "tsf/collision/box_index.h"
#include "tsf/common/vec3.h"
#include "tsf/coupler/deformed_lattice_view.h"

namespace tsf::collision {

struct NodeNeighbourhood {
  Vec3f lo{0, 0, 0}, hi{0, 0, 0};  ///< the query box, mm
  std::vector<std::int64_t> nodes;
  std::vector<Vec3f> displacement;
  std::vector<std::uint8_t> inside;
  std::vector<Vec3f> target, normal;

  void clear() {
    nodes.clear();
    displacement.clear();
    inside.clear();
    target.clear();
    normal.clear();
    local_.clear();
  }
  std::size_t size() const { return nodes.size(); }
  /// Index of `node` in the arrays, or −1 when it was not gathered.
  std::ptrdiff_t find(std::int64_t node) const {
    const auto it = std::lower_bound(nodes.begin(), nodes.end(), node);
    return it != nodes.end() && *it == node ? it - nodes.begin() : -1;
  }

  /// Builds a dense index over the gathered nodes' lattice box so find(i, j, k) is O(1) (the
  /// narrow phase and the inverse map look nodes up by coordinates many times). Call it after
  /// filling `nodes` (ascending); clear() drops it, and without one find(i, j, k) searches.
  void build_index(const Int3& lattice_dims) {
    local_.clear();
    if (nodes.empty()) return;
    const std::int64_t nx = lattice_dims.x, ny = lattice_dims.y;
    Int3 first{lattice_dims.x, lattice_dims.y, lattice_dims.z}, last{-1, -1, -1};
    for (std::int64_t n : nodes) {
      const Int3 c{static_cast<int>(n % nx), static_cast<int>((n / nx) % ny),
                   static_cast<int>(n / (nx * ny))};
      for (int a = 0; a < 3; ++a) {
        first[a] = c[a] < first[a] ? c[a] : first[a];
        last[a] = c[a] > last[a] ? c[a] : last[a];
      }
    }
    const Int3 dims{last.x - first.x + 1, last.y - first.y + 1, last.z - first.z + 1};
    // Too sparse (a huge query box): keep the binary search rather than allocate the box.
    if (!BoxIndex::worth_it(dims.volume(), nodes.size())) return;
    local_.assign(first, dims);
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      const std::int64_t n = nodes[i];
      const Int3 c{static_cast<int>(n % nx), static_cast<int>((n / nx) % ny),
                   static_cast<int>(n / (nx * ny))};
      local_.at(c.x, c.y, c.z) = static_cast<std::int32_t>(i);
    }
  }
  /// Index of node (i, j, k) in the arrays, or −1.
  std::ptrdiff_t find(int i, int j, int k, const Int3& lattice_dims) const {
    if (!local_.empty()) return local_.find(i, j, k);
    return find(static_cast<std::int64_t>(i) +
                static_cast<std::int64_t>(lattice_dims.x) *
                    (static_cast<std::int64_t>(j) + static_cast<std::int64_t>(lattice_dims.y) * k));
  }

 private:
  BoxIndex local_;
};

/// A cube_corners.h reader over a neighbourhood (host only): nodes not gathered read as missing.
/// `overrides` (optional, same indexing as the neighbourhood) replaces displacements, e.g. with
/// contact corrections not yet written to the solver.
struct NeighbourhoodReader {
  const NodeNeighbourhood* neighbourhood = nullptr;
  coupler::DeformedLatticeView lattice;  ///< geometry only (pointers unused)
  const std::vector<Vec3f>* overrides = nullptr;

  bool displacement(int i, int j, int k, Vec3f& u) const {
    if (!lattice.in_range(i, j, k)) return false;
    const std::ptrdiff_t at = neighbourhood->find(i, j, k, lattice.dims);
    if (at < 0) return false;
    u = overrides ? (*overrides)[static_cast<std::size_t>(at)]
                  : neighbourhood->displacement[static_cast<std::size_t>(at)];
    return true;
  }
};

}  // namespace tsf::collision
