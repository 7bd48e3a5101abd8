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
  }
  std::size_t size() const { return nodes.size(); }
  /// Index of `node` in the arrays, or −1 when it was not gathered.
  std::ptrdiff_t find(std::int64_t node) const {
    const auto it = std::lower_bound(nodes.begin(), nodes.end(), node);
    return it != nodes.end() && *it == node ? it - nodes.begin() : -1;
  }
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
    const std::ptrdiff_t at = neighbourhood->find(lattice.index(i, j, k));
    if (at < 0) return false;
    u = overrides ? (*overrides)[static_cast<std::size_t>(at)]
                  : neighbourhood->displacement[static_cast<std::size_t>(at)];
    return true;
  }
};

}  // namespace tsf::collision
