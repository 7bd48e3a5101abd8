#include "tsf/crms/lattice.h"

#include <cmath>
#include <string>

#include "tsf/common/error.h"
#include "tsf/crms/node_state_view.h"

namespace tsf::crms {

Lattice::Lattice(const LatticeGeometry& geometry) : geometry_(geometry) {
  require(geometry.dims.x > 0 && geometry.dims.y > 0 && geometry.dims.z > 0,
          "lattice dimensions must be positive, got " + std::to_string(geometry.dims.x) + "x" +
              std::to_string(geometry.dims.y) + "x" + std::to_string(geometry.dims.z));
  for (int a = 0; a < 3; ++a)
    require(std::isfinite(geometry.spacing[a]) && geometry.spacing[a] > 0.0,
            "lattice spacing must be positive and finite (mm), got " +
                std::to_string(geometry.spacing[a]) + " along axis " + std::to_string(a));
  const auto n = static_cast<std::size_t>(geometry.node_count());
  alive_.assign(n, 0);
  fixed_.assign(n, 0);
  broken_.assign(n, 0);
  label_.assign(n, 0);
  material_.assign(n, MaterialBlend{});
  mass_.assign(n, 0.0f);
  occupancy_.assign(n, 0.0f);
}

int Lattice::dominant_material(std::int64_t n) const {
  const MaterialBlend b = material_[n];
  int best = 0;
  for (int c = 1; c < 4; ++c)
    if (b.weight_of(c) > b.weight_of(best)) best = c;
  return b.entry(best);
}

std::int64_t Lattice::alive_count() const {
  std::int64_t c = 0;
  for (auto a : alive_) c += a != 0;
  return c;
}

std::int64_t Lattice::neighbour(std::int64_t n, int d) const {
  Int3 c = geometry_.coordinates(n);
  const Int3 o = direction_offset(d);
  c.x += o.x;
  c.y += o.y;
  c.z += o.z;
  return geometry_.contains(c.x, c.y, c.z) ? geometry_.index(c.x, c.y, c.z) : -1;
}

void Lattice::break_spring(std::int64_t n, int d) {
  const std::int64_t m = neighbour(n, d);
  if (m < 0) return;
  broken_[n] |= static_cast<std::uint8_t>(1u << d);
  broken_[m] |= static_cast<std::uint8_t>(1u << opposite_direction(d));
}

bool Lattice::link(std::int64_t n, int d) const {
  if (!alive_[n] || ((broken_[n] >> d) & 1u)) return false;
  const std::int64_t m = neighbour(n, d);
  return m >= 0 && alive_[m];
}

std::uint8_t Lattice::packed_flags(std::int64_t n) const {
  std::uint8_t f = 0;
  for (int d = 0; d < kFaceDirections; ++d)
    if (link(n, d)) f |= static_cast<std::uint8_t>(1u << d);
  if (alive_[n]) f |= kAliveBit;
  if (fixed_[n]) f |= kFixedBit;
  return f;
}

std::vector<std::uint8_t> Lattice::packed_flags() const {
  std::vector<std::uint8_t> flags(static_cast<std::size_t>(node_count()));
  const std::int64_t count = node_count();
#pragma omp parallel for schedule(static)
  for (std::int64_t n = 0; n < count; ++n) flags[n] = packed_flags(n);
  return flags;
}

double Lattice::total_mass() const {
  double m = 0.0;
  for (std::size_t n = 0; n < mass_.size(); ++n)
    if (alive_[n]) m += static_cast<double>(mass_[n]);
  return m;
}

void Lattice::validate() const {
  const auto n = static_cast<std::size_t>(node_count());
  require(alive_.size() == n && fixed_.size() == n && broken_.size() == n && mass_.size() == n &&
              occupancy_.size() == n && label_.size() == n && material_.size() == n,
          "lattice arrays do not match its " + std::to_string(n) + " nodes");
  for (std::size_t i = 0; i < n; ++i) {
    const MaterialBlend b = material_[i];
    unsigned weight_sum = 0;
    for (int c = 0; c < 4; ++c) weight_sum += b.weight_of(c);
    if (weight_sum != 255u)
      throw Error("lattice node " + std::to_string(i) + " has material weights summing to " +
                  std::to_string(weight_sum) + ", expected 255");
    if (!(occupancy_[i] >= 0.0f && occupancy_[i] <= 1.0f))
      throw Error("lattice node " + std::to_string(i) + " has occupancy " +
                  std::to_string(occupancy_[i]) + ", expected a value in [0,1]");
    if (alive_[i] && !(std::isfinite(mass_[i]) && mass_[i] > 0.0f))
      throw Error("lattice node " + std::to_string(i) + " is alive with mass " +
                  std::to_string(mass_[i]) + " g, expected a positive finite mass");
  }
}

}  // namespace tsf::crms
