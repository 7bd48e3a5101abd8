// The CPU loops of one explicit CRMS step: thin SIMD loops over lattice rows around the per-node
// physics of node_force.h / node_update.h. Private to tissue/src/crms.
//
// Two evaluations (ForceEvaluation, solver_config.h):
//
// * per node (step_rows_per_node): every node evaluates its whole stencil (7 nodes gather,
//   19 symmetric) and integrates; rows are independent.
//
// * shared (march_tile, symmetric form): each angle is evaluated once. Pass 1 evaluates
//   node_spring_terms() of every node (7-node stencil) into a small ring of 3 planes × (rows of
//   the tile + 2 halo rows) of "terms": self (3 floats) and the 6 reactions on the neighbours
//   (18 floats). Pass 2 finishes a node from its own self and the 6 reactions its neighbours put
//   on it, then integrates. A tile of rows [j0, j1) marches through planes [k0, k1): pass 1 of
//   plane t, then pass 2 of plane t − 1, so the ring holds planes t − 2 .. t. The rows and planes
//   just outside the tile need only the one reaction towards it (reaction_towards: 4 angles
//   instead of 12). The ring stays in the core's cache; main memory sees the state once per step.
//
// Each row loop is one `omp simd` loop over the interior x of the row (x ± 1 inside; neighbour
// rows through row pointers, rows outside the lattice alias the centre row and the link bits zero
// their contribution); the two row ends go through the bounds-checked IndexedStencil. Pass 2 needs
// no stencil of the state and runs the whole row in SIMD: the ring rows are padded by one element
// at both ends, and a missing neighbour's reaction is selected away by the link bit (never
// multiplied, so stale ring data cannot leak even if it were not finite).
//
// The functions are templates over the feature set and are instantiated once per instruction set
// (cpu_kernels_isa.h): each ISA translation unit wraps them in flattened entry points so that the
// whole physics inlines into the SIMD loops compiled for that ISA.
#pragma once

#include <algorithm>
#include <climits>
#include <cstddef>
#include <cstdint>

#include "tsf/common/vec3.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/node_force.h"
#include "tsf/crms/node_state_view.h"
#include "tsf/crms/node_update.h"
#include "tsf/crms/stencil.h"

namespace tsf::crms::cpu {

/// Everything a row loop reads besides the scratch: lattice, input and output state, parameters.
struct StepContext {
  LatticeView lattice;
  ConstStateView in;
  StateView out;
  StepParameters parameters;
};

/// Floats per node in the term ring: self (3) + reaction[d] (6 × 3).
constexpr int kTermQuantities = 21;
TSF_HD_INLINE constexpr int self_quantity(int component) {
  return component;
}
TSF_HD_INLINE constexpr int reaction_quantity(int direction, int component) {
  return 3 + 3 * direction + component;
}

/// A thread's term ring: [3 planes][kTermQuantities][rows][stride] floats, rows = tile rows + 2,
/// stride = nx + 2 (one padding float at each row end). Memory is owned by the backend (zeroed
/// once, so nothing ever reads an unwritten value).
struct TermRing {
  float* data = nullptr;
  int rows = 0;
  int stride = 0;
  float* row(int slot, int quantity, int r) const {
    return data +
           ((static_cast<std::ptrdiff_t>(slot) * kTermQuantities + quantity) * rows + r) * stride +
           1;
  }
  static std::size_t floats(int rows, int nx) {
    return std::size_t{3} * kTermQuantities * static_cast<std::size_t>(rows) *
           static_cast<std::size_t>(nx + 2);
  }
};

/// A tile of the shared evaluation: rows [j0, j1) of planes [k0, k1).
struct Tile {
  int j0 = 0, j1 = 0, k0 = 0, k1 = 0;
};

/// Per-thread scratch of the row loops: the byte arrays a row reads, widened to 32 bits, and
/// pass 2's per-node failure flags. (A byte-sized load or store in a SIMD loop makes GCC choose
/// 64 lanes per vector iteration, four registers per float value, and run up to 63 nodes of every
/// row in the scalar epilogue; with 32-bit types only, a vector is 16 nodes.)
struct RowScratch {
  static constexpr int kRows = 9;
  std::int32_t* flags = nullptr;            ///< kRows × nx
  std::int32_t* material_index = nullptr;   ///< kRows × nx (MaterialBlend::index)
  std::int32_t* material_weight = nullptr;  ///< kRows × nx (MaterialBlend::weight)
  std::int32_t* bad = nullptr;              ///< nx
  static std::size_t ints(int nx) {
    return (3 * std::size_t{kRows} + 1) * static_cast<std::size_t>(nx);
  }
  static RowScratch over(std::int32_t* storage, int nx) {
    const std::size_t plane = std::size_t{kRows} * static_cast<std::size_t>(nx);
    RowScratch s;
    s.flags = storage;
    s.material_index = storage + plane;
    s.material_weight = storage + 2 * plane;
    s.bad = storage + 3 * plane;
    return s;
  }
};

/// Row pointers of the 3×3 block of rows around (j, k): index (dy+1) + 3·(dz+1).
struct RowBlock {
  const float* u[3][9];
  const float* v[3][9];
  const std::int32_t* flags[9];
  const std::int32_t* material_index[9];
  const std::int32_t* material_weight[9];
};

/// The row block of (j, k); flags (and material, when `material` is set) of the rows the stencil
/// reads are widened into the scratch: the 5 rows of the 7-node stencil, or all 9 with
/// `edge_rows` (the 19-node stencil). Rows outside the lattice alias the centre row.
inline RowBlock row_block(const LatticeView& lat, const ConstStateView& in, int j, int k,
                          const RowScratch& scratch, bool edge_rows, bool material) {
  const int nx = lat.dims.x, ny = lat.dims.y, nz = lat.dims.z;
  const std::int64_t base = (static_cast<std::int64_t>(k) * ny + j) * nx;
  RowBlock b;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy) {
      const bool inside = j + dy >= 0 && j + dy < ny && k + dz >= 0 && k + dz < nz;
      const std::int64_t rb = inside ? base + dy * lat.stride_y + dz * lat.stride_z : base;
      const int r = (dy + 1) + 3 * (dz + 1);
      for (int a = 0; a < 3; ++a) {
        b.u[a][r] = in.u[a] + rb;
        b.v[a][r] = in.v[a] + rb;
      }
      std::int32_t* flags = scratch.flags + static_cast<std::ptrdiff_t>(r) * nx;
      std::int32_t* mat_index = scratch.material_index + static_cast<std::ptrdiff_t>(r) * nx;
      std::int32_t* mat_weight = scratch.material_weight + static_cast<std::ptrdiff_t>(r) * nx;
      b.flags[r] = flags;
      b.material_index[r] = mat_index;
      b.material_weight[r] = mat_weight;
      if (!edge_rows && dy != 0 && dz != 0) continue;
      const std::uint8_t* src = lat.flags + rb;
      for (int i = 0; i < nx; ++i) flags[i] = src[i];
      if (material) {
        const std::uint32_t* index = lat.material_index + rb;
        const std::uint32_t* weight = lat.material_weight + rb;
        for (int i = 0; i < nx; ++i) mat_index[i] = static_cast<std::int32_t>(index[i]);
        for (int i = 0; i < nx; ++i) mat_weight[i] = static_cast<std::int32_t>(weight[i]);
      }
    }
  return b;
}

/// Stencil accessor for interior x positions of a row (x ± 1 always inside).
struct RowStencil {
  using Scalar = float;
  const RowBlock& b;
  const float* inv_mass_row;
  const float* const* external_force_row;
  int i;

  static constexpr int row(int slot) {
    return (slot_offset(slot, 1) + 1) + 3 * (slot_offset(slot, 2) + 1);
  }
  Vec3f u(int slot) const {
    const int r = row(slot), x = i + slot_offset(slot, 0);
    return {b.u[0][r][x], b.u[1][r][x], b.u[2][r][x]};
  }
  Vec3f v(int slot) const {
    const int r = row(slot), x = i + slot_offset(slot, 0);
    return {b.v[0][r][x], b.v[1][r][x], b.v[2][r][x]};
  }
  unsigned flags(int slot) const { return b.flags[row(slot)][i + slot_offset(slot, 0)]; }
  MaterialBlend material(int slot) const {
    const int r = row(slot), x = i + slot_offset(slot, 0);
    MaterialBlend m;
    m.index = static_cast<std::uint32_t>(b.material_index[r][x]);
    m.weight = static_cast<std::uint32_t>(b.material_weight[r][x]);
    return m;
  }
  float inv_mass() const { return inv_mass_row[i]; }
  Vec3f external_force() const {
    return {external_force_row[0][i], external_force_row[1][i], external_force_row[2][i]};
  }
};

inline std::int64_t row_base(const LatticeView& lat, int j, int k) {
  return (static_cast<std::int64_t>(k) * lat.dims.y + j) * lat.dims.x;
}

// ---- entry points per instruction set ----------------------------------------------------------

/// The kernels of one instruction set for one feature set.
struct RowKernels {
  std::int64_t (*step_row_per_node)(const StepContext&, int j, int k,
                                    const RowScratch& scratch) = nullptr;
  /// Null for feature sets without the symmetric form.
  std::int64_t (*march_tile)(const StepContext&, const TermRing&, const Tile&,
                             const RowScratch& scratch) = nullptr;
};

/// The kernels of a compiled feature set for each instruction set (cpu_kernels_<isa>.cpp);
/// all-null for an instruction set this build does not have.
RowKernels row_kernels_baseline(unsigned set);
RowKernels row_kernels_avx2(unsigned set);
RowKernels row_kernels_avx512(unsigned set);

}  // namespace tsf::crms::cpu
