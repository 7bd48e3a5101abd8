#include "tsf/crms/lattice_builders.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>

#include "tsf/common/error.h"
#include "tsf/volume/tissue_labels.h"

namespace tsf::crms {
namespace {

void check_density(double rho, const char* field) {
  require(std::isfinite(rho) && rho >= 1e-6 && rho <= 1e-1,
          std::string(field) + " = " + std::to_string(rho) +
              " g/mm³ is out of range [1e-6, 1e-1] (water is 1e-3)");
}

}  // namespace

Lattice build_lattice_from_volume(const VoxelVolume& volume, const VolumeLatticeOptions& options) {
  const int k = options.node_spacing_voxels;
  require(k >= 1 && k <= 64,
          "node_spacing_voxels = " + std::to_string(k) + " is out of range [1, 64]");
  require(options.occupancy_threshold > 0.0f && options.occupancy_threshold <= 1.0f,
          "occupancy_threshold = " + std::to_string(options.occupancy_threshold) +
              " is out of range (0, 1]");
  require(options.mass_floor >= 0.0f && options.mass_floor <= 1.0f,
          "mass_floor = " + std::to_string(options.mass_floor) + " is out of range [0, 1]");
  check_density(options.density_g_per_mm3, "density");
  const Int3 vd = volume.dims();
  require(vd.x > 0 && vd.y > 0 && vd.z > 0, "the voxel volume is empty");
  require(volume.density_data().size() == volume.voxel_count() &&
              volume.label_data().size() == volume.voxel_count(),
          "the voxel volume's density/label arrays do not match its dimensions");

  const VolumeGeometry& vg = volume.geometry();
  LatticeGeometry g;
  g.dims = {(vd.x + k - 1) / k, (vd.y + k - 1) / k, (vd.z + k - 1) / k};
  g.spacing = {vg.spacing.x * k, vg.spacing.y * k, vg.spacing.z * k};
  const double c = 0.5 * k - 0.5;  // node (0,0,0) at the centre of voxels [0,k)³
  g.origin = vg.index_to_tissue({c, c, c});
  Lattice lattice(g);

  if (options.material_blends) {
    require(volume.has_material_weights(),
            "material_blends: the volume carries no material weights (segment writes them as "
            "PREFIX-weights.nrrd)");
    for (int ch = 0; ch < 4; ++ch) {
      require(options.channel_material[ch] >= 0 && options.channel_material[ch] < kMaxMaterials,
              "channel_material[" + std::to_string(ch) +
                  "] = " + std::to_string(options.channel_material[ch]) + ", expected 0.." +
                  std::to_string(kMaxMaterials - 1));
      check_density(options.channel_density_g_per_mm3[ch], "channel_density");
    }
  }
  const auto& density = volume.density_data();
  const auto& labels = volume.label_data();
  const double cell_volume = g.cell_volume();
  const double inv_block = 1.0 / (static_cast<double>(k) * k * k);
  const std::int64_t count = lattice.node_count();
#pragma omp parallel for schedule(dynamic, 64)
  for (std::int64_t n = 0; n < count; ++n) {
    const Int3 nc = g.coordinates(n);
    double sum = 0.0;
    std::array<double, 256> label_weight{};
    std::array<double, 4> channel_weight{};
    for (int z = nc.z * k; z < std::min((nc.z + 1) * k, vd.z); ++z)
      for (int y = nc.y * k; y < std::min((nc.y + 1) * k, vd.y); ++y)
        for (int x = nc.x * k; x < std::min((nc.x + 1) * k, vd.x); ++x) {
          const std::size_t v = volume.index(x, y, z);
          const double d = density[v];
          sum += d;
          label_weight[labels[v]] += d;
          if (options.material_blends)
            for (int ch = 0; ch < 4; ++ch)
              channel_weight[ch] += d * volume.material_weight_data()[v][ch];
        }
    const double occupancy = std::clamp(sum * inv_block, 0.0, 1.0);
    lattice.set_occupancy(n, static_cast<float>(occupancy));
    if (occupancy < static_cast<double>(options.occupancy_threshold)) continue;
    // Majority label among tissue voxels (label 0 = outside never wins over tissue).
    int best = kLabelSoftTissue;
    double best_weight = 0.0;
    for (int l = 1; l < 256; ++l)
      if (label_weight[l] > best_weight) {
        best_weight = label_weight[l];
        best = l;
      }
    lattice.set_alive(n, true);
    lattice.set_label(n, static_cast<std::uint8_t>(best));
    double rho = options.density_g_per_mm3;
    if (options.material_blends) {
      const MaterialBlend blend = make_material_blend(options.channel_material, channel_weight);
      lattice.set_material(n, blend);
      rho = 0.0;
      for (int ch = 0; ch < 4; ++ch)  // the blend's density, channel by channel
        rho += channel_weight[ch] * options.channel_density_g_per_mm3[ch];
      const double total =
          channel_weight[0] + channel_weight[1] + channel_weight[2] + channel_weight[3];
      rho = total > 0.0 ? rho / total : options.channel_density_g_per_mm3[0];
    }
    lattice.set_mass(
        n, static_cast<float>(rho * cell_volume *
                              std::max(occupancy, static_cast<double>(options.mass_floor))));
  }
  require(lattice.alive_count() > 0,
          "no lattice node reaches occupancy " + std::to_string(options.occupancy_threshold) +
              ": the volume holds no tissue at node spacing " + std::to_string(k));
  if (!options.fixed_labels.empty()) fix_nodes_with_labels(lattice, options.fixed_labels);
  return lattice;
}

MaterialBlend make_material_blend(const std::array<int, 4>& entries,
                                  const std::array<double, 4>& fractions) {
  // Merge components naming the same entry.
  std::array<int, 4> entry{};
  std::array<double, 4> share{};
  int used = 0;
  double total = 0.0;
  for (int c = 0; c < 4; ++c) {
    const double f = std::isfinite(fractions[c]) && fractions[c] > 0.0 ? fractions[c] : 0.0;
    total += f;
    int slot = 0;
    while (slot < used && entry[slot] != entries[c]) ++slot;
    if (slot == used) entry[used++] = entries[c];
    share[slot] += f;
  }
  if (!(total > 0.0)) return MaterialBlend::single(entries[0]);
  // Largest remainders: floor every share of 255, hand the rest out by fractional part.
  std::array<int, 4> weight{};
  std::array<double, 4> remainder{};
  int given = 0;
  for (int s = 0; s < used; ++s) {
    const double exact = 255.0 * share[s] / total;
    weight[s] = static_cast<int>(std::floor(exact));
    remainder[s] = exact - weight[s];
    given += weight[s];
  }
  for (; given < 255; ++given) {
    int best = 0;
    for (int s = 1; s < used; ++s)
      if (remainder[s] > remainder[best]) best = s;
    ++weight[best];
    remainder[best] = -1.0;
  }
  // Heaviest component first: pure() then catches single-material nodes with one test.
  std::array<int, 4> order{0, 1, 2, 3};
  for (int s = 1; s < used; ++s)  // insertion sort of ≤ 4 components, heaviest first
    for (int t = s; t > 0 && weight[order[t]] > weight[order[t - 1]]; --t)
      std::swap(order[t], order[t - 1]);
  MaterialBlend b;
  b.index = 0;
  b.weight = 0;
  for (int s = 0; s < used; ++s) {
    b.index |= (static_cast<std::uint32_t>(entry[order[s]]) & 0xffu) << (8 * s);
    b.weight |= static_cast<std::uint32_t>(weight[order[s]]) << (8 * s);
  }
  return b;
}

Lattice build_box_lattice(const BoxLatticeOptions& options) {
  require(std::isfinite(options.spacing_mm) && options.spacing_mm > 0.0,
          "box spacing = " + std::to_string(options.spacing_mm) + " mm, expected > 0");
  check_density(options.density_g_per_mm3, "density");
  LatticeGeometry g;
  for (int a = 0; a < 3; ++a) {
    const double size = options.size_mm[a];
    require(std::isfinite(size) && size > 0.0, "box size along axis " + std::to_string(a) + " = " +
                                                   std::to_string(size) + " mm, expected > 0");
    const double nodes = std::max(1.0, std::round(size / options.spacing_mm));
    require(nodes <= 4096, "box of " + std::to_string(size) + " mm at spacing " +
                               std::to_string(options.spacing_mm) +
                               " mm needs more than 4096 nodes along an axis");
    g.dims[a] = static_cast<int>(nodes);
    g.spacing[a] = size / nodes;
    g.origin[a] = options.min_corner_mm[a] + 0.5 * g.spacing[a];
  }
  Lattice lattice(g);
  const float mass = static_cast<float>(options.density_g_per_mm3 * g.cell_volume());
  for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
    lattice.set_alive(n, true);
    lattice.set_occupancy(n, 1.0f);
    lattice.set_mass(n, mass);
    lattice.set_label(n, kLabelSoftTissue);
  }
  return lattice;
}

std::int64_t fix_nodes_in_box(Lattice& lattice, const Vec3d& lo, const Vec3d& hi) {
  std::int64_t fixed = 0;
  for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
    if (!lattice.alive(n)) continue;
    const Vec3d p = lattice.geometry().rest_position(n);
    if (p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z) {
      lattice.set_fixed(n, true);
      ++fixed;
    }
  }
  return fixed;
}

std::int64_t fix_nodes_behind_plane(Lattice& lattice, const Vec3d& point, const Vec3d& normal) {
  require(length_squared(normal) > 0.0, "anchor plane normal must not be zero");
  std::int64_t fixed = 0;
  for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
    if (!lattice.alive(n)) continue;
    if (dot(lattice.geometry().rest_position(n) - point, normal) <= 0.0) {
      lattice.set_fixed(n, true);
      ++fixed;
    }
  }
  return fixed;
}

std::int64_t fix_nodes_with_labels(Lattice& lattice, const std::vector<std::uint8_t>& labels) {
  std::int64_t fixed = 0;
  for (std::int64_t n = 0; n < lattice.node_count(); ++n) {
    if (!lattice.alive(n)) continue;
    if (std::find(labels.begin(), labels.end(), lattice.label(n)) != labels.end()) {
      lattice.set_fixed(n, true);
      ++fixed;
    }
  }
  return fixed;
}

}  // namespace tsf::crms
