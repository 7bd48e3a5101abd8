#include "tsf/interaction/tear_separation.h"

#include <algorithm>

#include "tsf/common/error.h"

namespace tsf::interaction {
namespace {

/// Voxels [c·k, (c+1)·k) of cell coordinate c along one axis.
void cell_range(int c, int k, int& lo, int& hi) {
  lo = c * k;
  hi = (c + 1) * k;
}

bool any_link(const crms::Lattice& lattice, std::int64_t n) {
  for (int d = 0; d < crms::kFaceDirections; ++d)
    if (lattice.link(n, d)) return true;
  return false;
}

}  // namespace

TornVoxels torn_voxels(const crms::Lattice& lattice, const std::vector<crms::SpringRef>& torn,
                       int k, const Int3& volume_dims) {
  require(k >= 1, "torn_voxels: node spacing must be >= 1 voxel");
  TornVoxels out;
  const crms::LatticeGeometry& g = lattice.geometry();
  const VoxelBox volume = VoxelBox::of_dims(volume_dims);
  auto add = [&](const VoxelBox& b) {
    const VoxelBox c = b.intersected(volume);
    if (c.empty()) return;
    out.boxes.push_back(c);
    out.bounds = out.bounds.united(c);
  };
  std::vector<std::int64_t> ends;
  for (const crms::SpringRef& s : torn) {
    require(s.node >= 0 && s.node < lattice.node_count() && s.direction >= 0 &&
                s.direction < crms::kFaceDirections,
            "torn_voxels: spring out of range");
    // From the lower node: a spring given from its upper end is the same spring.
    std::int64_t n = s.node;
    int d = s.direction;
    if (crms::direction_sign(d) < 0) {
      n = lattice.neighbour(n, d);
      d = crms::opposite_direction(d);
      if (n < 0) continue;
    }
    const std::int64_t m = lattice.neighbour(n, d);
    if (m < 0) continue;
    ends.push_back(n);
    ends.push_back(m);
    const int a = crms::direction_axis(d);
    const int b = a == 0 ? 1 : 0, c = a == 2 ? 1 : 2;
    const Int3 cn = g.coordinates(n);
    // The face slab across n's cell, and across each neighbouring column of cells without a
    // parallel spring (nothing there holds the two sides together).
    for (int db = -1; db <= 1; ++db)
      for (int dc = -1; dc <= 1; ++dc) {
        Int3 q = cn;
        q[b] += db;
        q[c] += dc;
        if (db != 0 || dc != 0) {
          if (q[b] < 0 || q[c] < 0 || q[b] >= g.dims[b] || q[c] >= g.dims[c]) {
            // Beyond the lattice: voxels may still exist there (a partial last cell).
          } else if (lattice.link(g.index(q.x, q.y, q.z), d)) {
            continue;
          }
        }
        VoxelBox box;
        box.lo[a] = (cn[a] + 1) * k - 1;
        box.hi[a] = (cn[a] + 1) * k + 1;
        cell_range(q[b], k, box.lo[b], box.hi[b]);
        cell_range(q[c], k, box.lo[c], box.hi[c]);
        add(box);
      }
  }
  // Nodes the tear left without any spring: their cells go.
  std::sort(ends.begin(), ends.end());
  ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
  for (std::int64_t n : ends) {
    if (!lattice.alive(n) || any_link(lattice, n)) continue;
    out.masked_nodes.push_back(n);
    const Int3 cn = g.coordinates(n);
    VoxelBox box;
    for (int ax = 0; ax < 3; ++ax) cell_range(cn[ax], k, box.lo[ax], box.hi[ax]);
    add(box);
  }
  return out;
}

}  // namespace tsf::interaction
