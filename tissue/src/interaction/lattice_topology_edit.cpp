#include "tsf/interaction/lattice_topology_edit.h"

#include <algorithm>
#include <array>

#include "tsf/common/error.h"

namespace tsf::interaction {

void DensitySnapshot::capture(const VoxelVolume& volume, const VoxelBox& box) {
  box_ = box.intersected(VoxelBox::of_dims(volume.dims()));
  extent_ = box_.extent();
  density_.resize(static_cast<std::size_t>(box_.voxel_count()));
  std::size_t at = 0;
  for (int k = box_.lo.z; k < box_.hi.z; ++k)
    for (int j = box_.lo.y; j < box_.hi.y; ++j) {
      const float* row = volume.density_data().data() + volume.index(box_.lo.x, j, k);
      std::copy(row, row + extent_.x, density_.begin() + static_cast<std::ptrdiff_t>(at));
      at += static_cast<std::size_t>(extent_.x);
    }
}

double DensitySnapshot::removed_volume_mm3(const VoxelVolume& volume,
                                           const VoxelBox& changed) const {
  const VoxelBox b = changed.intersected(VoxelBox::of_dims(volume.dims()));
  double sum = 0;
  for (int k = b.lo.z; k < b.hi.z; ++k)
    for (int j = b.lo.y; j < b.hi.y; ++j)
      for (int i = b.lo.x; i < b.hi.x; ++i)
        sum += static_cast<double>(before(volume, i, j, k)) -
               static_cast<double>(volume.density(i, j, k));
  const Vec3d& s = volume.geometry().spacing;
  return sum * s.x * s.y * s.z;
}

std::vector<std::pair<std::uint8_t, double>> DensitySnapshot::removed_by_label_mm3(
    const VoxelVolume& volume, const VoxelBox& changed) const {
  const VoxelBox b = changed.intersected(VoxelBox::of_dims(volume.dims()));
  std::array<double, 256> sum{};
  for (int k = b.lo.z; k < b.hi.z; ++k)
    for (int j = b.lo.y; j < b.hi.y; ++j)
      for (int i = b.lo.x; i < b.hi.x; ++i)
        sum[volume.label(i, j, k)] += static_cast<double>(before(volume, i, j, k)) -
                                      static_cast<double>(volume.density(i, j, k));
  const Vec3d& s = volume.geometry().spacing;
  std::vector<std::pair<std::uint8_t, double>> out;
  for (int l = 0; l < 256; ++l)
    if (sum[static_cast<std::size_t>(l)] > 0.0)
      out.emplace_back(static_cast<std::uint8_t>(l),
                       sum[static_cast<std::size_t>(l)] * s.x * s.y * s.z);
  return out;
}

float cell_occupancy(const VoxelVolume& volume, const crms::LatticeGeometry& g, std::int64_t node,
                     int k) {
  const Int3 c = g.coordinates(node);
  const Int3& d = volume.dims();
  double sum = 0;
  for (int z = c.z * k; z < (c.z + 1) * k; ++z) {
    if (z >= d.z) break;
    for (int y = c.y * k; y < (c.y + 1) * k; ++y) {
      if (y >= d.y) break;
      const int x1 = std::min((c.x + 1) * k, d.x);
      const float* row = volume.density_data().data() + volume.index(0, y, z);
      for (int x = c.x * k; x < x1; ++x) sum += static_cast<double>(row[x]);
    }
  }
  return static_cast<float>(sum / (static_cast<double>(k) * k * k));
}

namespace {

/// Voxel range [lo, hi) of node coordinate c's bridge along its spring axis, and of its cell
/// across it.
void bridge_along(int c, int k, int& lo, int& hi) {
  lo = c * k + k / 2;
  hi = c * k + k + (k - 1) / 2 + 1;
}

template <typename Density>
bool bridge_solid(const Int3& node, int axis, int k, const Int3& dims, float iso,
                  const Density& density) {
  int lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    if (a == axis) {
      bridge_along(node[a], k, lo[a], hi[a]);
    } else {
      lo[a] = node[a] * k;
      hi[a] = (node[a] + 1) * k;
    }
  }
  // Any voxel outside the volume reads 0: a column reaching it is not solid.
  const int b = axis == 0 ? 1 : 0, c = axis == 2 ? 1 : 2;
  for (int u = lo[b]; u < hi[b]; ++u)
    for (int v = lo[c]; v < hi[c]; ++v) {
      bool solid = true;
      for (int t = lo[axis]; t < hi[axis] && solid; ++t) {
        int p[3];
        p[axis] = t;
        p[b] = u;
        p[c] = v;
        if (p[0] < 0 || p[1] < 0 || p[2] < 0 || p[0] >= dims.x || p[1] >= dims.y || p[2] >= dims.z)
          solid = false;
        else
          solid = density(p[0], p[1], p[2]) >= iso;
      }
      if (solid) return true;
    }
  return false;
}

}  // namespace

LatticeTopologyEdit find_lattice_topology_edit(const VoxelVolume& volume,
                                               const DensitySnapshot& before,
                                               const VoxelBox& changed,
                                               const crms::Lattice& lattice, int k,
                                               float deletion_threshold, float iso) {
  require(k >= 1, "lattice topology edit: node spacing must be >= 1 voxel");
  LatticeTopologyEdit edit;
  if (changed.empty()) return edit;
  const crms::LatticeGeometry& g = lattice.geometry();
  const Int3& dims = volume.dims();

  // Nodes whose cells overlap the changed voxels.
  Int3 nlo, nhi;
  for (int a = 0; a < 3; ++a) {
    nlo[a] = std::max(0, changed.lo[a] / k);
    nhi[a] = std::min(g.dims[a] - 1, (changed.hi[a] - 1) / k);
  }
  for (int z = nlo.z; z <= nhi.z; ++z)
    for (int y = nlo.y; y <= nhi.y; ++y)
      for (int x = nlo.x; x <= nhi.x; ++x) {
        const std::int64_t n = g.index(x, y, z);
        if (!lattice.alive(n)) continue;
        if (cell_occupancy(volume, g, n, k) < deletion_threshold) edit.deleted_nodes.push_back(n);
      }

  // Springs whose bridge overlaps the changed voxels: nodes one cell further out on each side.
  auto deleted = [&](std::int64_t n) {
    return std::binary_search(edit.deleted_nodes.begin(), edit.deleted_nodes.end(), n);
  };
  const auto now = [&](int i, int j, int kk) { return volume.density(i, j, kk); };
  const auto then = [&](int i, int j, int kk) { return before.before(volume, i, j, kk); };
  for (int z = std::max(0, nlo.z - 1); z <= nhi.z; ++z)
    for (int y = std::max(0, nlo.y - 1); y <= nhi.y; ++y)
      for (int x = std::max(0, nlo.x - 1); x <= nhi.x; ++x) {
        const std::int64_t n = g.index(x, y, z);
        if (!lattice.alive(n) || deleted(n)) continue;
        const Int3 node{x, y, z};
        for (int axis = 0; axis < 3; ++axis) {
          const int d = crms::make_direction(axis, +1);
          if (!lattice.link(n, d)) continue;
          Int3 m = node;
          ++m[axis];
          if (deleted(g.index(m.x, m.y, m.z))) continue;
          // Does the bridge overlap the changed box?
          VoxelBox bridge;
          for (int a = 0; a < 3; ++a) {
            if (a == axis) {
              bridge_along(node[a], k, bridge.lo[a], bridge.hi[a]);
            } else {
              bridge.lo[a] = node[a] * k;
              bridge.hi[a] = (node[a] + 1) * k;
            }
          }
          if (bridge.intersected(changed).empty()) continue;
          if (bridge_solid(node, axis, k, dims, iso, now)) continue;
          if (!bridge_solid(node, axis, k, dims, iso, then)) continue;
          edit.broken_springs.push_back({n, d});
        }
      }
  return edit;
}

}  // namespace tsf::interaction
