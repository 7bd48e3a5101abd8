// Connected pieces of the lattice: alive nodes joined by intact springs (Lattice::link). A cut
// that separates the tissue shows here as a new component; a component with no anchored node is
// free and falls under gravity.
#pragma once

#include <cstdint>
#include <vector>

#include "tsf/crms/lattice.h"

namespace tsf::interaction {

struct LatticeComponents {
  std::vector<std::int32_t> label;     ///< per node: component index, −1 for dead nodes
  std::vector<std::int64_t> sizes;     ///< nodes per component, largest first
  std::vector<std::uint8_t> anchored;  ///< per component: holds a fixed node
  std::size_t count() const { return sizes.size(); }
};

/// Labels the components (breadth-first over links). Components are numbered by size, largest
/// first (ties: lowest node first).
LatticeComponents find_lattice_components(const crms::Lattice& lattice);

}  // namespace tsf::interaction
