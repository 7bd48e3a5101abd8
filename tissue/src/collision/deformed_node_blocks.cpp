#include "tsf/collision/deformed_node_blocks.h"

#include <algorithm>
#include <cmath>

namespace tsf::collision {

DeformedNodeBlocks::DeformedNodeBlocks(const Int3& dims) : dims_(dims) {
  for (int a = 0; a < 3; ++a) blocks_[a] = (dims[a] + kBlockNodes - 1) / kBlockNodes;
  boxes_.resize(static_cast<std::size_t>(blocks_.volume()));
}

void DeformedNodeBlocks::refit(const coupler::DeformedLatticeView& lat) {
  const auto count = static_cast<std::int64_t>(boxes_.size());
  float max_disp2 = 0.0f;
  // Threads only for big lattices: on a busy machine a parallel region can wait a whole time
  // slice for its second thread, longer than a serial refit of 100k nodes (~0.3 ms).
#pragma omp parallel for schedule(static) reduction(max : max_disp2) if (count > 16384)
  for (std::int64_t b = 0; b < count; ++b) {
    const int bx = static_cast<int>(b % blocks_.x);
    const int by = static_cast<int>((b / blocks_.x) % blocks_.y);
    const int bz = static_cast<int>(b / (static_cast<std::int64_t>(blocks_.x) * blocks_.y));
    Box box;
    const int i1 = std::min(dims_.x, (bx + 1) * kBlockNodes);
    const int j1 = std::min(dims_.y, (by + 1) * kBlockNodes);
    const int k1 = std::min(dims_.z, (bz + 1) * kBlockNodes);
    for (int k = bz * kBlockNodes; k < k1; ++k)
      for (int j = by * kBlockNodes; j < j1; ++j)
        for (int i = bx * kBlockNodes; i < i1; ++i) {
          const std::int64_t n = lat.index(i, j, k);
          if (!lat.alive(n)) continue;
          const Vec3f u = lat.displacement(n);
          max_disp2 = std::max(max_disp2, length_squared(u));
          const Vec3f p = lat.rest(i, j, k) + u;
          if (box.empty) {
            box.lo = box.hi = p;
            box.empty = false;
          } else {
            box.lo = {std::min(box.lo.x, p.x), std::min(box.lo.y, p.y), std::min(box.lo.z, p.z)};
            box.hi = {std::max(box.hi.x, p.x), std::max(box.hi.y, p.y), std::max(box.hi.z, p.z)};
          }
        }
    boxes_[static_cast<std::size_t>(b)] = box;
  }
  max_displacement_ = std::sqrt(max_disp2);
}

void DeformedNodeBlocks::nodes_moved(const std::vector<std::int64_t>& nodes,
                                     const std::vector<Vec3d>& positions,
                                     const coupler::DeformedLatticeView& lat) {
  for (std::size_t i = 0; i < nodes.size() && i < positions.size(); ++i) {
    const std::int64_t n = nodes[i];
    const int x = static_cast<int>(n % dims_.x), y = static_cast<int>((n / dims_.x) % dims_.y);
    const int z = static_cast<int>(n / (static_cast<std::int64_t>(dims_.x) * dims_.y));
    Box& box = boxes_[static_cast<std::size_t>(x / kBlockNodes) +
                      static_cast<std::size_t>(blocks_.x) *
                          (static_cast<std::size_t>(y / kBlockNodes) +
                           static_cast<std::size_t>(blocks_.y) *
                               static_cast<std::size_t>(z / kBlockNodes))];
    const Vec3f p = to_float(positions[i]);
    if (box.empty) {
      box.lo = box.hi = p;
      box.empty = false;
    } else {
      box.lo = {std::min(box.lo.x, p.x), std::min(box.lo.y, p.y), std::min(box.lo.z, p.z)};
      box.hi = {std::max(box.hi.x, p.x), std::max(box.hi.y, p.y), std::max(box.hi.z, p.z)};
    }
    const Vec3f u = p - lat.rest(x, y, z);
    max_displacement_ = std::max(max_displacement_, length(u));
  }
}

void DeformedNodeBlocks::query(const coupler::DeformedLatticeView& lat, const Vec3f& lo,
                               const Vec3f& hi, std::vector<std::int64_t>& nodes,
                               std::vector<Vec3f>& displacements) const {
  nodes.clear();
  displacements.clear();
  last_visited_ = 0;
  // A node in the query box rests within max_displacement_ of it: only blocks whose rest range
  // meets the box grown by that can hold one.
  Int3 b0, b1;
  for (int a = 0; a < 3; ++a) {
    const float d = max_displacement_ * 1.0001f + 1e-4f;
    const double h = static_cast<double>(lat.spacing[a]), o = static_cast<double>(lat.origin[a]);
    const double t0 = std::floor((static_cast<double>(lo[a] - d) - o) / h);
    const double t1 = std::ceil((static_cast<double>(hi[a] + d) - o) / h);
    const int n0 = static_cast<int>(std::max(0.0, std::min(t0, double(dims_[a] - 1))));
    const int n1 = static_cast<int>(std::max(0.0, std::min(t1, double(dims_[a] - 1))));
    if (t1 < 0.0 || t0 > double(dims_[a] - 1)) return;
    b0[a] = n0 / kBlockNodes;
    b1[a] = n1 / kBlockNodes;
  }
  for (int bz = b0.z; bz <= b1.z; ++bz)
    for (int by = b0.y; by <= b1.y; ++by)
      for (int bx = b0.x; bx <= b1.x; ++bx) {
        const std::size_t b =
            static_cast<std::size_t>(bx) +
            static_cast<std::size_t>(blocks_.x) *
                (static_cast<std::size_t>(by) +
                 static_cast<std::size_t>(blocks_.y) * static_cast<std::size_t>(bz));
        const Box& box = boxes_[b];
        if (box.empty || box.hi.x < lo.x || box.hi.y < lo.y || box.hi.z < lo.z || box.lo.x > hi.x ||
            box.lo.y > hi.y || box.lo.z > hi.z)
          continue;
        ++last_visited_;
        const int i1 = std::min(dims_.x, (bx + 1) * kBlockNodes);
        const int j1 = std::min(dims_.y, (by + 1) * kBlockNodes);
        const int k1 = std::min(dims_.z, (bz + 1) * kBlockNodes);
        for (int k = bz * kBlockNodes; k < k1; ++k)
          for (int j = by * kBlockNodes; j < j1; ++j)
            for (int i = bx * kBlockNodes; i < i1; ++i) {
              const std::int64_t n = lat.index(i, j, k);
              if (!lat.alive(n)) continue;
              const Vec3f u = lat.displacement(n);
              const Vec3f p = lat.rest(i, j, k) + u;
              if (p.x < lo.x || p.y < lo.y || p.z < lo.z || p.x > hi.x || p.y > hi.y || p.z > hi.z)
                continue;
              nodes.push_back(n);
              displacements.push_back(u);
            }
      }
  // Blocks are visited in index order but nodes interleave across block rows: sort by node.
  std::vector<std::size_t> order(nodes.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return nodes[a] < nodes[b]; });
  std::vector<std::int64_t> sorted_nodes(nodes.size());
  std::vector<Vec3f> sorted_u(nodes.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    sorted_nodes[i] = nodes[order[i]];
    sorted_u[i] = displacements[order[i]];
  }
  nodes.swap(sorted_nodes);
  displacements.swap(sorted_u);
}

}  // namespace tsf::collision
