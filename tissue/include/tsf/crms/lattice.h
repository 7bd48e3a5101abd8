// R3: the CRMS lattice on the host — which nodes exist, their masses, labels and anchors, and which
// springs are intact. The solver copies it to its backend; topology edits (node deletion, spring
// breaking) go through the solver so both sides stay in step.
//
// Per node (index n of LatticeGeometry):
//   alive       uint8 0/1: the node takes part in the simulation
//   fixed       uint8 0/1: anchored (held at its constraint target, rest by default)
//   broken      uint8, 6 bits: spring to face neighbour d broken (kept on both ends)
//   mass        float, g
//   occupancy   float in [0,1]: tissue fraction of the node's cell (1 for analytic shapes)
//   label       uint8 TissueLabel: density-weighted majority label of the cell
//   material    MaterialBlend: up to 4 palette entries and their weights (kHeterogeneous)
// A spring between n and its neighbour in direction d exists when both are alive and in range
// and it is not broken; link_bits() packs that for the kernels (node_state_view.h).
#pragma once

#include <cstdint>
#include <vector>

#include "tsf/crms/lattice_geometry.h"
#include "tsf/crms/spring_constants.h"

namespace tsf::crms {

class Lattice {
 public:
  Lattice() = default;
  /// All nodes dead, massless, unanchored; builders fill them in (lattice_builders.h).
  explicit Lattice(const LatticeGeometry& geometry);

  const LatticeGeometry& geometry() const { return geometry_; }
  std::int64_t node_count() const { return geometry_.node_count(); }
  std::int64_t alive_count() const;

  bool alive(std::int64_t n) const { return alive_[n] != 0; }
  bool fixed(std::int64_t n) const { return fixed_[n] != 0; }
  float mass(std::int64_t n) const { return mass_[n]; }
  float occupancy(std::int64_t n) const { return occupancy_[n]; }
  std::uint8_t label(std::int64_t n) const { return label_[n]; }
  MaterialBlend material(std::int64_t n) const { return material_[n]; }
  /// The palette entry with the largest weight in n's blend.
  int dominant_material(std::int64_t n) const;
  /// 6-bit mask of broken springs at n.
  std::uint8_t broken_mask(std::int64_t n) const { return broken_[n]; }

  void set_alive(std::int64_t n, bool alive) { alive_[n] = alive ? 1 : 0; }
  void set_fixed(std::int64_t n, bool fixed) { fixed_[n] = fixed ? 1 : 0; }
  void set_mass(std::int64_t n, float mass_g) { mass_[n] = mass_g; }
  void set_occupancy(std::int64_t n, float occupancy) { occupancy_[n] = occupancy; }
  void set_label(std::int64_t n, std::uint8_t label) { label_[n] = label; }
  /// One palette entry for the whole node.
  void set_material(std::int64_t n, int entry) { material_[n] = MaterialBlend::single(entry); }
  void set_material(std::int64_t n, MaterialBlend blend) { material_[n] = blend; }

  /// Index of the face neighbour of n in direction d, or −1 outside the lattice.
  std::int64_t neighbour(std::int64_t n, int d) const;
  /// Breaks the spring between n and its neighbour in direction d on both ends (no-op when there
  /// is no neighbour).
  void break_spring(std::int64_t n, int d);
  /// True when the spring from n in direction d exists (see header).
  bool link(std::int64_t n, int d) const;
  /// Packed per-node flags for the kernels: link bits, alive, fixed.
  std::uint8_t packed_flags(std::int64_t n) const;
  std::vector<std::uint8_t> packed_flags() const;

  /// Sum of node masses, g.
  double total_mass() const;
  /// Checks sizes, finite positive masses of alive nodes, occupancies in [0,1]; throws tsf::Error
  /// naming the first offending node and value.
  void validate() const;

 private:
  LatticeGeometry geometry_;
  std::vector<std::uint8_t> alive_, fixed_, broken_, label_;
  std::vector<MaterialBlend> material_;
  std::vector<float> mass_, occupancy_;
};

}  // namespace tsf::crms
