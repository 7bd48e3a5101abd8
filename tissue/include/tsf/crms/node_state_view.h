// Trivially copyable views of the CRMS lattice and state: what the kernels see.
//
// Owning containers (crms::Lattice, the backends' buffers) never enter a kernel; they hand out
// these views of raw arrays, on the host for the CPU loop and in device memory for CUDA.
//
// Per node (structure of arrays, index n = i + nx*(j + ny*k)):
//   flags             uint8: bits 0–5 link to face neighbour d present, bit 6 alive, bit 7 fixed
//   inv_mass          float, 1/g (0 for fixed nodes is not required: the fixed bit decides)
//   u[3]              float ×3 arrays, displacement from the rest position, mm
//   v[3]              float ×3 arrays, velocity, mm/s
//   material_index    uint32: 4 palette indices      (features::kHeterogeneous only)
//   material_weight   uint32: their 4 uint8 weights  (features::kHeterogeneous only)
//   external_force[3] float ×3 arrays, µN            (features::kExternalForces only)
// State is the displacement, not the position: springs see rest vector + (u_A − u_B) with the
// rest vector exact, so a lattice at rest has exactly zero force and float precision is spent on
// the deformation rather than on the tissue-space offset.
#pragma once

#include <cstdint>

#include "tsf/common/vec3.h"
#include "tsf/crms/spring_constants.h"

namespace tsf::crms {

constexpr std::uint8_t kLinkBits = 0x3f;
constexpr std::uint8_t kAliveBit = 0x40;
constexpr std::uint8_t kFixedBit = 0x80;

struct LatticeView {
  Int3 dims;                         ///< nodes per axis
  std::int64_t count = 0;            ///< nx·ny·nz
  std::int64_t stride_y = 0;         ///< nx
  std::int64_t stride_z = 0;         ///< nx·ny
  float rest_length[3] = {1, 1, 1};  ///< spring rest lengths hx, hy, hz, mm
  const std::uint8_t* flags = nullptr;
  const float* inv_mass = nullptr;
  const std::uint32_t* material_index = nullptr;   ///< MaterialBlend::index per node
  const std::uint32_t* material_weight = nullptr;  ///< MaterialBlend::weight per node
  const float* external_force[3] = {nullptr, nullptr, nullptr};
};

/// The grid coordinates (i, j, k) of node n = i + j·nx + k·nx·ny.
TSF_HD_INLINE Int3 node_coords(const LatticeView& lattice, std::int64_t n) {
  const std::int64_t row = n / lattice.dims.x;
  return {static_cast<int>(n % lattice.dims.x), static_cast<int>(row % lattice.dims.y),
          static_cast<int>(row / lattice.dims.y)};
}

/// Node n's material blend (heterogeneous lattices: material_index/weight are set).
TSF_HD_INLINE MaterialBlend node_material(const LatticeView& lattice, std::int64_t n) {
  MaterialBlend b;
  b.index = lattice.material_index[n];
  b.weight = lattice.material_weight[n];
  return b;
}

struct StateView {
  float* u[3] = {nullptr, nullptr, nullptr};  ///< displacement, mm
  float* v[3] = {nullptr, nullptr, nullptr};  ///< velocity, mm/s
};
struct ConstStateView {
  const float* u[3] = {nullptr, nullptr, nullptr};
  const float* v[3] = {nullptr, nullptr, nullptr};
  ConstStateView() = default;
  TSF_HD_INLINE ConstStateView(const StateView& s)  // NOLINT: views convert implicitly
      : u{s.u[0], s.u[1], s.u[2]}, v{s.v[0], s.v[1], s.v[2]} {}
};

/// The explicit schemes of the kernels (implicit Euler is a host solver, implicit_euler.h).
enum class ExplicitScheme : int {
  kExplicitEuler = 0,    ///< thesis Eq. 11: p += v·dt with the old v, then v += a·dt
  kSymplecticEuler = 1,  ///< v += a·dt, then p += v·dt with the new v
};

/// Everything one explicit step needs besides the arrays; passed by value to kernels.
struct StepParameters {
  float dt = 0;               ///< s
  Vec3f gravity{0, 0, 0};     ///< mm/s²
  float kinetic_damping = 0;  ///< k_sys, 1/mm: a = −k_sys·|v|·v (speed-dependent drag)
  float velocity_limit = 0;   ///< mm/s; 0 = no limit
  int scheme = static_cast<int>(ExplicitScheme::kSymplecticEuler);
  MaterialPalette palette;
};

}  // namespace tsf::crms
