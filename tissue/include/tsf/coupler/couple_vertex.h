// One render vertex through the deformed lattice: the per-vertex function of the coupler, called
// by the CPU loop (OpenMP) and the CUDA kernel alike (docs/design.md "Coupler", thesis §7.1).
//
// A vertex is bound to a cube (its lower corner node `cell`) with local coordinates
// w = (p_rest − rest(cell)) / h ∈ [0,1]³ (slightly outside near the tissue border). Two modes:
//   kLocalFrame  the thesis form: origin corner q0 and the three edges to its neighbours,
//                v = q0 + w.x·X + w.y·Y + w.z·Z with X = q1 − q0, Y = q2 − q0, Z = q4 − q0.
//                Reads 4 corners; continuous only where neighbouring cubes deform affinely.
//   kTrilinear   v = Σ_c W_c(w)·q_c over the 8 corners (W the trilinear weights): continuous
//                across cube faces, so the surface stays watertight under any lattice motion.
// Normals follow the deformation gradient F of the chosen map (columns ∂v/∂w_a / h_a):
// n' ∝ cof(F)·n = F⁻ᵀ·n·det F, which stays perpendicular to the deformed surface under shear
// (the thesis multiplied the rest normal by the axes, F·n, which tilts it). With w in rest units
// this is n' ∝ h_x·n_x·(Y × Z) + h_y·n_y·(Z × X) + h_z·n_z·(X × Y) for columns X, Y, Z = ∂v/∂w.
#pragma once

#include <cstdint>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"
#include "tsf/coupler/cube_corners.h"
#include "tsf/coupler/deformed_lattice_view.h"

namespace tsf::coupler {

enum class CouplerMode : int {
  kTrilinear = 0,   ///< 8 corners, continuous across cubes (default)
  kLocalFrame = 1,  ///< the thesis's origin + 3 axes, 4 corners
};

/// Where a vertex slot is bound. 16 bytes: one vector load on the GPU.
struct VertexBinding {
  std::int32_t cell = -1;  ///< lattice node index of the cube's lower corner; −1 = not bound
  float w[3] = {0, 0, 0};  ///< local coordinates in the cube
};
static_assert(sizeof(VertexBinding) == 16, "VertexBinding is one 16-byte load");

/// Reads displacements from a DeformedLatticeView (bounds and alive flags checked).
struct LatticeReader {
  DeformedLatticeView lattice;
  TSF_HD_INLINE bool displacement(int i, int j, int k, Vec3f& u) const {
    if (!lattice.in_range(i, j, k)) return false;
    const std::int64_t n = lattice.index(i, j, k);
    if (!lattice.alive(n)) return false;
    u = lattice.displacement(n);
    return true;
  }
};

/// Trilinear weight of corner c at w.
TSF_HD_INLINE float trilinear_weight(int c, const float w[3]) {
  const float wx = corner_bit(c, 0) ? w[0] : 1.0f - w[0];
  const float wy = corner_bit(c, 1) ? w[1] : 1.0f - w[1];
  const float wz = corner_bit(c, 2) ? w[2] : 1.0f - w[2];
  return wx * wy * wz;
}

/// Position (relative to the cell's rest corner) and the columns of ∂v/∂w of the chosen map.
TSF_HD_INLINE Vec3f map_cube_point(const Vec3f q[8], const float w[3], CouplerMode mode,
                                   Vec3f axes[3]) {
  if (mode == CouplerMode::kLocalFrame) {
    axes[0] = q[1] - q[0];
    axes[1] = q[2] - q[0];
    axes[2] = q[4] - q[0];
    return q[0] + axes[0] * w[0] + axes[1] * w[1] + axes[2] * w[2];
  }
  const float x = w[0], y = w[1], z = w[2];
  const float mx = 1.0f - x, my = 1.0f - y, mz = 1.0f - z;
  // Edges along x, y, z weighted by the other two coordinates.
  axes[0] = (q[1] - q[0]) * (my * mz) + (q[3] - q[2]) * (y * mz) + (q[5] - q[4]) * (my * z) +
            (q[7] - q[6]) * (y * z);
  axes[1] = (q[2] - q[0]) * (mx * mz) + (q[3] - q[1]) * (x * mz) + (q[6] - q[4]) * (mx * z) +
            (q[7] - q[5]) * (x * z);
  axes[2] = (q[4] - q[0]) * (mx * my) + (q[5] - q[1]) * (x * my) + (q[6] - q[2]) * (mx * y) +
            (q[7] - q[3]) * (x * y);
  Vec3f p{0, 0, 0};
  for (int c = 0; c < 8; ++c) p += q[c] * trilinear_weight(c, w);
  return p;
}

/// Deformed normal: cof(F)·n with F's columns axes[a]/h[a] (see header), normalised; the rest
/// normal when the cube is collapsed (no finite direction).
TSF_HD_INLINE Vec3f deform_normal(const Vec3f axes[3], const float h[3], const Vec3f& rest_normal) {
  const Vec3f n = cross(axes[1], axes[2]) * (h[0] * rest_normal.x) +
                  cross(axes[2], axes[0]) * (h[1] * rest_normal.y) +
                  cross(axes[0], axes[1]) * (h[2] * rest_normal.z);
  const float len = length(n);
  if (!(len > 1e-30f) || !(len < 3.0e38f)) return rest_normal;
  return n / len;
}

struct CoupledVertex {
  Vec3f position;  ///< mm, tissue space (deformed)
  Vec3f normal;    ///< unit
  bool bound;      ///< false: no source node was available, position = rest
};

/// The cell (lower corner node coordinates) of a binding.
TSF_HD_INLINE Int3 binding_cell(const DeformedLatticeView& lattice, std::int64_t n) {
  return {static_cast<int>(n % lattice.dims.x),
          static_cast<int>((n / lattice.dims.x) % lattice.dims.y),
          static_cast<int>(n / (static_cast<std::int64_t>(lattice.dims.x) * lattice.dims.y))};
}

/// Corners mode `mode` reads (the local frame needs 0, 1, 2 and 4 only).
TSF_HD_INLINE unsigned corners_needed(CouplerMode mode) {
  return mode == CouplerMode::kLocalFrame ? 0x17u : 0xffu;
}

/// Couples one vertex from its cube's resolved corners (resolve_cube_corners with
/// corners_needed(mode)); vertices of one cube with the same sources share them.
TSF_HD_INLINE CoupledVertex couple_resolved(const DeformedLatticeView& lattice, const Int3& cell,
                                            const Vec3f q[8], bool bound, const VertexBinding& b,
                                            const Vec3f& rest_normal, CouplerMode mode) {
  CoupledVertex out;
  out.bound = bound;
  Vec3f axes[3];
  const Vec3f rel = map_cube_point(q, b.w, mode, axes);
  out.position = lattice.rest(cell.x, cell.y, cell.z) + rel;
  out.normal = deform_normal(axes, lattice.spacing, rest_normal);
  return out;
}

/// Couples one vertex. A vertex without a source node (an orphan) keeps its rest position
/// (`bound` false); an unbound slot (cell < 0) gives a zero position.
template <class Reader>
TSF_HD_INLINE CoupledVertex couple_vertex(const Reader& reader, const DeformedLatticeView& lattice,
                                          const VertexBinding& b, std::uint32_t sources,
                                          const Vec3f& rest_normal, CouplerMode mode) {
  if (b.cell < 0 || b.cell >= lattice.dims.volume()) {
    CoupledVertex out;
    out.position = {0, 0, 0};
    out.normal = rest_normal;
    out.bound = false;
    return out;
  }
  const Int3 cell = binding_cell(lattice, b.cell);
  Vec3f q[8];
  const bool bound = resolve_cube_corners(reader, cell, lattice.spacing, sources, q, nullptr,
                                          corners_needed(mode));
  return couple_resolved(lattice, cell, q, bound, b, rest_normal, mode);
}

/// Two-pass coupling (what Coupler runs): a cube as its vertices see it — the cell and the
/// sources they use — is a frame, shared by the ~5–10 vertices of a surface cube. Pass 1 resolves
/// each frame's corners once (the inference of missing corners is the costly part); pass 2
/// interpolates every vertex from its frame's corners.
struct CubeFrame {
  std::int32_t cell = -1;     ///< lower corner node; −1 = free
  std::uint32_t sources = 0;  ///< cube_corners.h bit layout
};
/// A frame's corners for the current state: q relative to base = rest(cell), mm.
struct FrameCorners {
  Vec3f q[8];
  Vec3f base;
  std::uint32_t bound;  ///< 0: no source node was available (the corners are rest offsets)
};
/// The record pass 2 reads per vertex slot: its frame and local coordinates (one 16-byte load).
struct VertexFrameBinding {
  std::uint32_t frame = 0xffffffffu;  ///< 0xffffffff: unbound
  float w[3] = {0, 0, 0};
};
static_assert(sizeof(VertexFrameBinding) == 16, "VertexFrameBinding is one 16-byte load");
constexpr std::uint32_t kNoFrame = 0xffffffffu;

/// Pass 1 for one frame.
template <class Reader>
TSF_HD_INLINE FrameCorners resolve_frame(const Reader& reader, const DeformedLatticeView& lattice,
                                         const CubeFrame& frame, CouplerMode mode) {
  FrameCorners out;
  const Int3 cell = binding_cell(lattice, frame.cell);
  out.base = lattice.rest(cell.x, cell.y, cell.z);
  out.bound = resolve_cube_corners(reader, cell, lattice.spacing, frame.sources, out.q, nullptr,
                                   corners_needed(mode))
                  ? 1u
                  : 0u;
  return out;
}

/// Pass 2 for one vertex.
TSF_HD_INLINE CoupledVertex couple_from_frame(const FrameCorners& f, const float w[3],
                                              const float h[3], const Vec3f& rest_normal,
                                              CouplerMode mode) {
  CoupledVertex out;
  out.bound = f.bound != 0;
  Vec3f axes[3];
  out.position = f.base + map_cube_point(f.q, w, mode, axes);
  out.normal = deform_normal(axes, h, rest_normal);
  return out;
}

/// The rest position the binding stands for: rest(cell) + w ⊙ h.
TSF_HD_INLINE Vec3f bound_rest_position(const DeformedLatticeView& lattice,
                                        const VertexBinding& b) {
  const std::int64_t n = b.cell;
  const int i = static_cast<int>(n % lattice.dims.x);
  const int j = static_cast<int>((n / lattice.dims.x) % lattice.dims.y);
  const int k = static_cast<int>(n / (static_cast<std::int64_t>(lattice.dims.x) * lattice.dims.y));
  return lattice.rest(i, j, k) + Vec3f{b.w[0] * lattice.spacing[0], b.w[1] * lattice.spacing[1],
                                       b.w[2] * lattice.spacing[2]};
}

}  // namespace tsf::coupler
