// The 8 deformed corners of one lattice cube, with missing (deleted or cut-away) corners inferred
// from the nodes that remain on the vertex's side (docs/design.md "Coupler"; thesis §7.2,
// Appendix A).
//
// Corners are numbered c = x + 2y + 4z with x, y, z ∈ {0,1} the offset from the cube's lower
// corner node `cell`. A vertex may use 32 source nodes (its binding's `sources` bit mask):
//   bits 0–7     the cube's corners
//   bits 8–31    bit 8 + 3c + a: the outside neighbour of corner c along axis a (the node one step
//                further from the cube: offset −1 when c's a-bit is 0, +2 when it is 1)
// The binder (vertex_binder.h) sets a bit only for alive nodes connected to the vertex's side of
// the tissue through intact springs; the resolver also re-checks alive flags, so a node deleted
// after binding is simply treated as missing.
//
// Inference: the missing corners follow the best-fit local frame of the known nodes, q ≈ q̄ +
// A·(r − r̄) over their rest offsets r and deformed positions q (the cube's known corners; its
// known outside neighbours join when the corners alone do not span the cube). The thesis's three
// rules are the cases of this fit, each made exact for more motions:
//   known nodes span 3-D   least-squares affine A: exact for any affine motion (the corner
//                          triple of Appendix A is a special case);
//   coplanar (a face, a    the plane's two axes fitted, the third completed by their cross
//   corner triple)         product scaled by the square root of the in-plane area change (the
//                          thesis's "corner triple + cross product"): exact for rigid motion and
//                          uniform scale, affine within the plane;
//   collinear (an edge,    rotation + uniform scale along the line: a node between two known
//   an opposite pair)      ones lands on their midpoint (the thesis's "opposite pair");
//   one node               translation (the thesis's "neighbour + unit offset", with the true
//                          rest offset).
// Positions are relative to the rest position of the cell's lower corner (mm).
#pragma once

#include <cstdint>

#include "tsf/common/hd.h"
#include "tsf/common/vec3.h"

namespace tsf::coupler {

constexpr int kCubeCorners = 8;
constexpr std::uint32_t kCornerBits = 0xffu;
constexpr std::uint32_t kAllSourceBits = 0xffffffffu;

TSF_HD_INLINE constexpr int corner_bit(int c, int axis) {
  return (c >> axis) & 1;
}
/// Bit of `sources` for the outside neighbour of corner c along axis a.
TSF_HD_INLINE constexpr int outside_source_bit(int c, int axis) {
  return 8 + 3 * c + axis;
}
/// Node offset (from the cell) of the outside neighbour of corner c along axis a, on that axis.
TSF_HD_INLINE constexpr int outside_offset(int c, int axis) {
  return corner_bit(c, axis) ? 2 : -1;
}

/// Node offset (from the cell) of source bit b (0–31).
TSF_HD_INLINE Int3 source_offset(int b) {
  if (b < 8) return {corner_bit(b, 0), corner_bit(b, 1), corner_bit(b, 2)};
  const int c = (b - 8) / 3, a = (b - 8) % 3;
  Int3 o{corner_bit(c, 0), corner_bit(c, 1), corner_bit(c, 2)};
  o[a] = outside_offset(c, a);
  return o;
}

/// True when a node at offset o from a cell is one of the cell's 32 sources.
TSF_HD_INLINE bool is_source_offset(const Int3& o) {
  int outside = 0;
  for (int a = 0; a < 3; ++a) {
    if (o[a] < -1 || o[a] > 2) return false;
    if (o[a] == -1 || o[a] == 2) ++outside;
  }
  return outside <= 1;
}

/// Rest offset of node offset (ox, oy, oz) from the cell's lower corner, mm.
TSF_HD_INLINE Vec3f rest_offset(int ox, int oy, int oz, const float h[3]) {
  return {static_cast<float>(ox) * h[0], static_cast<float>(oy) * h[1],
          static_cast<float>(oz) * h[2]};
}

/// Fetches the deformed position of a source node relative to the cell's rest corner, or false
/// when it is outside the lattice or dead. `Reader::displacement(i, j, k, u)` returns false for
/// such nodes and otherwise writes the node's displacement.
template <class Reader>
TSF_HD_INLINE bool fetch_node(const Reader& reader, const Int3& cell, int ox, int oy, int oz,
                              const float h[3], Vec3f& q) {
  Vec3f u;
  if (!reader.displacement(cell.x + ox, cell.y + oy, cell.z + oz, u)) return false;
  q = rest_offset(ox, oy, oz, h) + u;
  return true;
}

/// A 3×3 linear map by its columns.
struct LinearMap3 {
  Vec3f col[3];
  TSF_HD_INLINE Vec3f apply(const Vec3f& v) const {
    return col[0] * v.x + col[1] * v.y + col[2] * v.z;
  }
};

/// Least-squares local frame of the known nodes (see header): the map A with q ≈ q̄ + A·(r − r̄)
/// over known rest offsets r and deformed positions q. `count` points, rest r[i], deformed q[i].
TSF_HD_INLINE LinearMap3 fit_local_frame(const Vec3f* r, const Vec3f* q, int count, Vec3f& rbar,
                                         Vec3f& qbar) {
  LinearMap3 A{{Vec3f{1, 0, 0}, Vec3f{0, 1, 0}, Vec3f{0, 0, 1}}};
  rbar = Vec3f{0, 0, 0};
  qbar = Vec3f{0, 0, 0};
  if (count <= 0) return A;
  for (int i = 0; i < count; ++i) {
    rbar += r[i];
    qbar += q[i];
  }
  rbar = rbar / static_cast<float>(count);
  qbar = qbar / static_cast<float>(count);
  if (count == 1) return A;
  // Span of the rest offsets: the longest deviation, then the one most off its line.
  int ia = 0;
  float la = -1;
  for (int i = 0; i < count; ++i) {
    const float l = length_squared(r[i] - rbar);
    if (l > la) {
      la = l;
      ia = i;
    }
  }
  const Vec3f ra = r[ia] - rbar;
  if (!(la > 0)) return A;
  const Vec3f u = ra / sqrtf(la);
  int ib = -1;
  float lb = 0;
  for (int i = 0; i < count; ++i) {
    const float l = length_squared(cross(u, r[i] - rbar));
    if (l > lb) {
      lb = l;
      ib = i;
    }
  }
  const float scale2 = la;  // squared length scale of the point set
  if (ib < 0 || lb < 1e-8f * scale2) {
    // Collinear: rotation taking u to the fitted direction, uniform scale along it.
    float suu = 0;
    Vec3f d{0, 0, 0};
    for (int i = 0; i < count; ++i) {
      const float t = dot(r[i] - rbar, u);
      d += (q[i] - qbar) * t;
      suu += t * t;
    }
    d = d / suu;
    const float s = length(d);
    if (!(s > 1e-12f)) return A;
    const Vec3f e = d / s;
    // Rodrigues: rotation from u to e.
    const Vec3f k = cross(u, e);
    const float c = dot(u, e), sn = length(k);
    Vec3f axis = sn > 1e-12f ? k / sn : Vec3f{0, 0, 0};
    for (int a = 0; a < 3; ++a) {
      Vec3f v{0, 0, 0};
      v[a] = 1;
      // R·v = v·c + (axis × v)·sn + axis·(axis·v)·(1 − c)
      const Vec3f rv = v * c + cross(axis, v) * sn + axis * (dot(axis, v) * (1 - c));
      A.col[a] = rv * s;
    }
    return A;
  }
  const Vec3f v = normalized_or_zero((r[ib] - rbar) - u * dot(r[ib] - rbar, u));
  const Vec3f nrm = cross(u, v);
  // Is the set 3-D? Largest distance off the (u, v) plane.
  float off = 0;
  for (int i = 0; i < count; ++i) {
    const float o = fabsf(dot(r[i] - rbar, nrm));
    off = o > off ? o : off;
  }
  if (off * off > 1e-8f * scale2) {
    // Full least squares: A = (Σ D Rᵀ)(Σ R Rᵀ)⁻¹.
    float C[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    Vec3f B[3] = {Vec3f{0, 0, 0}, Vec3f{0, 0, 0}, Vec3f{0, 0, 0}};  // columns of Σ D Rᵀ
    for (int i = 0; i < count; ++i) {
      const Vec3f R = r[i] - rbar, D = q[i] - qbar;
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) C[3 * a + b] += R[a] * R[b];
        B[a] += D * R[a];
      }
    }
    const Vec3f c0{C[0], C[3], C[6]}, c1{C[1], C[4], C[7]}, c2{C[2], C[5], C[8]};
    const float det = dot(c0, cross(c1, c2));
    if (fabsf(det) > 1e-20f) {
      // C symmetric: C⁻¹ rows = (c1×c2, c2×c0, c0×c1)/det.
      const Vec3f i0 = cross(c1, c2) / det, i1 = cross(c2, c0) / det, i2 = cross(c0, c1) / det;
      // A = B·C⁻¹: column j of A = Σ_a B[a]·(C⁻¹)[a][j].
      for (int j = 0; j < 3; ++j) A.col[j] = B[0] * i0[j] + B[1] * i1[j] + B[2] * i2[j];
      return A;
    }
  }
  // Coplanar: fit the plane's two axes, complete the normal by their cross product scaled by the
  // square root of the in-plane area change (a similarity across the plane).
  float m00 = 0, m01 = 0, m11 = 0;
  Vec3f bu{0, 0, 0}, bv{0, 0, 0};
  for (int i = 0; i < count; ++i) {
    const Vec3f R = r[i] - rbar, D = q[i] - qbar;
    const float a = dot(R, u), b = dot(R, v);
    m00 += a * a;
    m01 += a * b;
    m11 += b * b;
    bu += D * a;
    bv += D * b;
  }
  const float det2 = m00 * m11 - m01 * m01;
  if (!(fabsf(det2) > 1e-20f)) return A;
  const Vec3f Au = (bu * m11 - bv * m01) / det2;
  const Vec3f Av = (bv * m00 - bu * m01) / det2;
  const Vec3f n = cross(Au, Av);
  const float area = length(n);
  const Vec3f An = area > 1e-20f ? n / sqrtf(area) : nrm;
  // A = [Au Av An]·[u v nrm]ᵀ: column j = Au·u[j] + Av·v[j] + An·nrm[j].
  for (int j = 0; j < 3; ++j) A.col[j] = Au * u[j] + Av * v[j] + An * nrm[j];
  return A;
}

/// Resolves the corners of `cell` (see header). q receives positions relative to the cell's
/// rest corner, mm. `needed` names the corners the caller will read (0x17 = 0, 1, 2, 4 for the
/// local frame): when they are all present the others are not fetched. Returns the mask of
/// corners that had to be inferred in `inferred` and false when no source node is known at all
/// (the corners are then the rest offsets).
template <class Reader>
TSF_HD_INLINE bool resolve_cube_corners(const Reader& reader, const Int3& cell, const float h[3],
                                        std::uint32_t sources, Vec3f q[8],
                                        unsigned* inferred = nullptr, unsigned needed = 0xffu) {
  unsigned known = 0;
  for (int c = 0; c < 8; ++c) {
    const int ox = corner_bit(c, 0), oy = corner_bit(c, 1), oz = corner_bit(c, 2);
    q[c] = rest_offset(ox, oy, oz, h);
    if (((needed >> c) & 1u) && ((sources >> c) & 1u) &&
        fetch_node(reader, cell, ox, oy, oz, h, q[c]))
      known |= 1u << c;
  }
  if ((known & needed) == needed) {
    if (inferred) *inferred = 0;
    return true;
  }
  for (int c = 0; c < 8; ++c) {
    if ((needed >> c) & 1u) continue;
    const int ox = corner_bit(c, 0), oy = corner_bit(c, 1), oz = corner_bit(c, 2);
    if (((sources >> c) & 1u) && fetch_node(reader, cell, ox, oy, oz, h, q[c])) known |= 1u << c;
  }
  if (inferred) *inferred = 0xffu & ~known;
  if (known == 0xffu) return true;

  // Known points: the corners, plus the outside neighbours when the corners do not span 3-D.
  Vec3f rp[32], qp[32];
  int count = 0;
  int spread[3] = {0, 0, 0};  // corners known with bit a = 0 / = 1 per axis: 1 | 2
  for (int c = 0; c < 8; ++c) {
    if (!((known >> c) & 1u)) continue;
    rp[count] = rest_offset(corner_bit(c, 0), corner_bit(c, 1), corner_bit(c, 2), h);
    qp[count] = q[c];
    ++count;
    for (int a = 0; a < 3; ++a) spread[a] |= corner_bit(c, a) ? 2 : 1;
  }
  // Four corners not on one face span the cube; otherwise add the outside neighbours.
  const bool corners_span =
      count >= 4 && spread[0] == 3 && spread[1] == 3 && spread[2] == 3 &&
      !(count == 4 && (known == 0x0fu || known == 0xf0u || known == 0x33u || known == 0xccu ||
                       known == 0x55u || known == 0xaau || known == 0x99u || known == 0x66u ||
                       known == 0xc3u || known == 0x3cu || known == 0xa5u || known == 0x5au));
  if (!corners_span && (sources >> 8) != 0) {
    for (int c = 0; c < 8; ++c)
      for (int a = 0; a < 3; ++a) {
        if (!((sources >> outside_source_bit(c, a)) & 1u)) continue;
        int o[3] = {corner_bit(c, 0), corner_bit(c, 1), corner_bit(c, 2)};
        o[a] = outside_offset(c, a);
        Vec3f p;
        if (fetch_node(reader, cell, o[0], o[1], o[2], h, p)) {
          rp[count] = rest_offset(o[0], o[1], o[2], h);
          qp[count] = p;
          ++count;
        }
      }
  }
  if (count == 0) return false;
  Vec3f rbar, qbar;
  const LinearMap3 A = fit_local_frame(rp, qp, count, rbar, qbar);
  for (int c = 0; c < 8; ++c) {
    if ((known >> c) & 1u) continue;
    const Vec3f r = rest_offset(corner_bit(c, 0), corner_bit(c, 1), corner_bit(c, 2), h);
    q[c] = qbar + A.apply(r - rbar);
  }
  return true;
}

}  // namespace tsf::coupler
