#include "tsf/interaction/lattice_components.h"

#include <algorithm>
#include <numeric>

namespace tsf::interaction {

LatticeComponents find_lattice_components(const crms::Lattice& lattice) {
  const crms::LatticeGeometry& g = lattice.geometry();
  const std::int64_t count = lattice.node_count();
  std::vector<std::int32_t> raw(static_cast<std::size_t>(count), -1);
  std::vector<std::int64_t> sizes, first;
  std::vector<std::uint8_t> anchored;
  std::vector<std::int64_t> queue;
  for (std::int64_t s = 0; s < count; ++s) {
    if (!lattice.alive(s) || raw[static_cast<std::size_t>(s)] >= 0) continue;
    const auto id = static_cast<std::int32_t>(sizes.size());
    sizes.push_back(0);
    first.push_back(s);
    anchored.push_back(0);
    queue.assign(1, s);
    raw[static_cast<std::size_t>(s)] = id;
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const std::int64_t n = queue[q];
      ++sizes.back();
      if (lattice.fixed(n)) anchored.back() = 1;
      const Int3 c = g.coordinates(n);
      for (int d = 0; d < crms::kFaceDirections; ++d) {
        const Int3 o = crms::direction_offset(d);
        if (!g.contains(c.x + o.x, c.y + o.y, c.z + o.z)) continue;
        if (!lattice.link(n, d)) continue;
        const std::int64_t m = g.index(c.x + o.x, c.y + o.y, c.z + o.z);
        if (raw[static_cast<std::size_t>(m)] >= 0) continue;
        raw[static_cast<std::size_t>(m)] = id;
        queue.push_back(m);
      }
    }
  }
  // Renumber largest first.
  std::vector<std::int32_t> order(sizes.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::int32_t a, std::int32_t b) { return sizes[a] > sizes[b]; });
  std::vector<std::int32_t> rank(sizes.size());
  for (std::size_t r = 0; r < order.size(); ++r)
    rank[static_cast<std::size_t>(order[r])] = static_cast<std::int32_t>(r);
  LatticeComponents out;
  out.label.resize(raw.size());
  for (std::size_t n = 0; n < raw.size(); ++n) out.label[n] = raw[n] < 0 ? -1 : rank[raw[n]];
  out.sizes.resize(sizes.size());
  out.anchored.resize(sizes.size());
  for (std::size_t r = 0; r < order.size(); ++r) {
    out.sizes[r] = sizes[static_cast<std::size_t>(order[r])];
    out.anchored[r] = anchored[static_cast<std::size_t>(order[r])];
  }
  return out;
}

}  // namespace tsf::interaction
