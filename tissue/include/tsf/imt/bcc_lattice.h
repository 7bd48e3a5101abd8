// The body-centred-cubic (BCC) lattice of Interactive Marching Tetrahedra (docs/design.md,
// "The pipeline" (R2); Chan & Purisima's tessellation, thesis §6.2).
//
// Points. Voxel samples ("corners") sit at integer indices s; cube c has corners c + d, d ∈ {0,1}³,
// and a body centre at c + ½ whose value is the mean of its 8 corners (clamped to their range so
// a cube whose corners all lie on one side of the iso-level has its centre on that side too, even
// after rounding; a centre whose cube reaches outside the volume reads 0, like every sample
// outside it). We address points in doubled integer coordinates: corner s -> 2s, the centre of
// cube c -> 2c + 1 (all three odd).
//
// Tetrahedra. Every cube face is shared by two cubes; each of its 4 edges with the two body
// centres forms a tetrahedron. Cube c owns the tetrahedra of its three lower faces (x = c.x,
// y = c.y, z = c.z), shared with c − e_a: 3 faces × 4 edges = 12 tetrahedra per cube, no
// ambiguous cases. Every tetrahedron is stored positively oriented, so one case table gives
// triangles whose normals point from density >= iso ("inside") to density < iso.
//
// Edges and vertex keys. Surface vertices sit on lattice edges; each edge has one owner cube and a
// slot, which makes welding exact (no hashing of positions):
//   slots 0-2   corner edge from corner c along +x, +y, +z
//   slots 3-5   centre edge from centre(c − e_a) to centre(c), a = x, y, z
//   slots 6-13  diagonal from centre(c) to corner c + d, slot 6 + dx + 2dy + 4dz
//   slot  14    the corner point c itself, slot 15 the centre point (vertices snapped onto a point)
// A vertex key is (owner cube, slot); owner cubes span c ∈ [−1, n] per axis for n voxels (samples
// outside the volume read as density 0, which closes surfaces that touch the volume's border).
#pragma once

#include <cstdint>

#include "tsf/common/hd.h"

namespace tsf::imt {

constexpr int kSlotsPerCube = 16;
constexpr int kSlotCornerEdge = 0;  ///< + axis (0..2)
constexpr int kSlotCentreEdge = 3;  ///< + axis (3..5)
constexpr int kSlotDiagonal = 6;    ///< + dx + 2dy + 4dz (6..13)
constexpr int kSlotCornerPoint = 14;
constexpr int kSlotCentrePoint = 15;
constexpr int kTetsPerCube = 12;

/// A point or edge slot of a cube at an offset from a reference cube.
struct LatticeRef {
  std::int8_t offset[3];  ///< owner cube − reference cube, each in {−1, 0, 1}
  std::uint8_t slot;      ///< 0..15
};

/// One of a cube's 12 tetrahedra, positively oriented.
struct TetTemplate {
  std::int8_t point[4][3];  ///< doubled coordinates relative to 2c
  LatticeRef point_ref[4];  ///< each vertex as a point slot (14/15) of its owner cube
  LatticeRef edge_ref[6];   ///< lattice edge under each tet edge (kTetEdge order)
};

/// Tet edge k joins tet vertices kTetEdgeA[k] and kTetEdgeB[k].
constexpr std::uint8_t kTetEdgeA[6] = {0, 0, 0, 1, 1, 2};
constexpr std::uint8_t kTetEdgeB[6] = {1, 2, 3, 2, 3, 3};

/// Triangles of a positively oriented tetrahedron for inside mask m (bit i: vertex i has
/// density >= iso), as tet edge indices, wound counter-clockwise seen from the outside.
struct TetCase {
  std::uint8_t triangle_count;
  std::uint8_t triangle[2][3];
};

/// End points of an edge slot in doubled coordinates relative to 2·owner, in the canonical
/// direction used for interpolation (p0 -> p1). Point slots give p0 == p1.
struct SlotEndpoints {
  std::int8_t p0[3];
  std::int8_t p1[3];
};

namespace detail {

constexpr int det3(const int a[3], const int b[3], const int c[3]) {
  return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
         a[2] * (b[0] * c[1] - b[1] * c[0]);
}

constexpr LatticeRef point_ref(const int p[3]) {
  LatticeRef r{{0, 0, 0}, 0};
  const bool corner = (p[0] % 2 == 0);
  for (int k = 0; k < 3; ++k)
    r.offset[k] = static_cast<std::int8_t>(corner ? p[k] / 2 : (p[k] - 1) / 2);
  r.slot = static_cast<std::uint8_t>(corner ? kSlotCornerPoint : kSlotCentrePoint);
  return r;
}

constexpr LatticeRef edge_ref(const int p[3], const int q[3]) {
  const bool pc = (p[0] % 2 == 0), qc = (q[0] % 2 == 0);
  LatticeRef r{{0, 0, 0}, 0};
  if (pc == qc) {  // corner-corner or centre-centre: differ by 2 along one axis
    int axis = 0;
    for (int k = 0; k < 3; ++k)
      if (p[k] != q[k]) axis = k;
    const bool p_lower = p[axis] < q[axis];
    const int* lo = p_lower ? p : q;
    const int* hi = p_lower ? q : p;
    for (int k = 0; k < 3; ++k)
      r.offset[k] = static_cast<std::int8_t>(pc ? lo[k] / 2 : (hi[k] - 1) / 2);
    r.slot = static_cast<std::uint8_t>((pc ? kSlotCornerEdge : kSlotCentreEdge) + axis);
  } else {  // diagonal, owned by the centre's cube
    const int* m = pc ? q : p;
    const int* s = pc ? p : q;
    int d = 0;
    for (int k = 0; k < 3; ++k) {
      r.offset[k] = static_cast<std::int8_t>((m[k] - 1) / 2);
      d += ((s[k] - (m[k] - 1)) / 2) << k;
    }
    r.slot = static_cast<std::uint8_t>(kSlotDiagonal + d);
  }
  return r;
}

struct CubeTetTable {
  TetTemplate tet[kTetsPerCube];
};

constexpr CubeTetTable make_cube_tets() {
  CubeTetTable t{};
  const int qb[4] = {0, 1, 1, 0};
  const int qe[4] = {0, 0, 1, 1};
  int n = 0;
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, e = (a + 2) % 3;
    for (int k = 0; k < 4; ++k) {
      int P[3] = {0, 0, 0}, Q[3] = {0, 0, 0}, A[3] = {1, 1, 1}, B[3] = {1, 1, 1};
      P[b] = 2 * qb[k];
      P[e] = 2 * qe[k];
      Q[b] = 2 * qb[(k + 1) % 4];
      Q[e] = 2 * qe[(k + 1) % 4];
      B[a] = -1;
      int u[3] = {0, 0, 0}, v[3] = {0, 0, 0}, w[3] = {0, 0, 0};
      for (int i = 0; i < 3; ++i) {
        u[i] = Q[i] - P[i];
        v[i] = A[i] - P[i];
        w[i] = B[i] - P[i];
      }
      int pts[4][3] = {
          {P[0], P[1], P[2]}, {Q[0], Q[1], Q[2]}, {A[0], A[1], A[2]}, {B[0], B[1], B[2]}};
      if (det3(u, v, w) < 0)  // swap P and Q for a positive orientation
        for (int i = 0; i < 3; ++i) {
          pts[0][i] = Q[i];
          pts[1][i] = P[i];
        }
      TetTemplate& tt = t.tet[n++];
      for (int v4 = 0; v4 < 4; ++v4) {
        for (int i = 0; i < 3; ++i) tt.point[v4][i] = static_cast<std::int8_t>(pts[v4][i]);
        tt.point_ref[v4] = point_ref(pts[v4]);
      }
      for (int ed = 0; ed < 6; ++ed)
        tt.edge_ref[ed] = edge_ref(pts[kTetEdgeA[ed]], pts[kTetEdgeB[ed]]);
    }
  }
  return t;
}

constexpr int tet_edge_index(int i, int j) {
  for (int k = 0; k < 6; ++k)
    if ((kTetEdgeA[k] == i && kTetEdgeB[k] == j) || (kTetEdgeA[k] == j && kTetEdgeB[k] == i))
      return k;
  return -1;
}

struct TetCaseTable {
  TetCase c[16];
};

// Orients each triangle on the reference tet (0,0,0),(2,0,0),(0,2,0),(0,0,2) (positive): its
// normal must point from the inside vertices' centroid toward the outside vertices' centroid.
constexpr TetCase oriented(TetCase tc, int mask) {
  const int ref[4][3] = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, 2}};
  int in_c[3] = {0, 0, 0}, out_c[3] = {0, 0, 0}, n_in = 0, n_out = 0;
  for (int v = 0; v < 4; ++v) {
    const bool in = (mask >> v) & 1;
    for (int i = 0; i < 3; ++i) (in ? in_c : out_c)[i] += ref[v][i];
    (in ? n_in : n_out) += 1;
  }
  int dir[3] = {0, 0, 0};  // n_in·n_out·(mean(out) − mean(in)), integer
  for (int i = 0; i < 3; ++i) dir[i] = out_c[i] * n_in - in_c[i] * n_out;
  for (int t = 0; t < tc.triangle_count; ++t) {
    int p[3][3] = {};  // edge midpoints ×2 (doubled reference coordinates sum)
    for (int k = 0; k < 3; ++k) {
      const int e = tc.triangle[t][k];
      for (int i = 0; i < 3; ++i) p[k][i] = ref[kTetEdgeA[e]][i] + ref[kTetEdgeB[e]][i];
    }
    int u[3] = {}, v[3] = {};
    for (int i = 0; i < 3; ++i) {
      u[i] = p[1][i] - p[0][i];
      v[i] = p[2][i] - p[0][i];
    }
    const int nrm[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                        u[0] * v[1] - u[1] * v[0]};
    if (nrm[0] * dir[0] + nrm[1] * dir[1] + nrm[2] * dir[2] < 0) {
      const std::uint8_t s = tc.triangle[t][1];
      tc.triangle[t][1] = tc.triangle[t][2];
      tc.triangle[t][2] = s;
    }
  }
  return tc;
}

constexpr TetCaseTable make_tet_cases() {
  TetCaseTable t{};
  for (int m = 0; m < 16; ++m) {
    int in[4] = {}, out[4] = {}, ni = 0, no = 0;
    for (int v = 0; v < 4; ++v) {
      if ((m >> v) & 1)
        in[ni++] = v;
      else
        out[no++] = v;
    }
    TetCase tc{0, {{0, 0, 0}, {0, 0, 0}}};
    if (ni == 1 || ni == 3) {  // one vertex cut off: one triangle
      const int lone = ni == 1 ? in[0] : out[0];
      const int* others = ni == 1 ? out : in;
      tc.triangle_count = 1;
      for (int k = 0; k < 3; ++k)
        tc.triangle[0][k] = static_cast<std::uint8_t>(tet_edge_index(lone, others[k]));
    } else if (ni == 2) {  // a quad (i0o0, i0o1, i1o1, i1o0) split along its first diagonal
      const int q[4] = {tet_edge_index(in[0], out[0]), tet_edge_index(in[0], out[1]),
                        tet_edge_index(in[1], out[1]), tet_edge_index(in[1], out[0])};
      tc.triangle_count = 2;
      const int tri[2][3] = {{q[0], q[1], q[2]}, {q[0], q[2], q[3]}};
      for (int a = 0; a < 2; ++a)
        for (int k = 0; k < 3; ++k) tc.triangle[a][k] = static_cast<std::uint8_t>(tri[a][k]);
    }
    t.c[m] = oriented(tc, m);
  }
  return t;
}

constexpr SlotEndpoints slot_endpoints(int slot) {
  SlotEndpoints e{{0, 0, 0}, {0, 0, 0}};
  if (slot < kSlotCentreEdge) {
    e.p1[slot] = 2;
  } else if (slot < kSlotDiagonal) {
    for (int i = 0; i < 3; ++i) e.p0[i] = e.p1[i] = 1;
    e.p0[slot - kSlotCentreEdge] = -1;
  } else if (slot < kSlotCornerPoint) {
    const int d = slot - kSlotDiagonal;
    for (int i = 0; i < 3; ++i) {
      e.p0[i] = 1;
      e.p1[i] = static_cast<std::int8_t>(2 * ((d >> i) & 1));
    }
  } else if (slot == kSlotCentrePoint) {
    for (int i = 0; i < 3; ++i) e.p0[i] = e.p1[i] = 1;
  }
  return e;
}

struct SlotEndpointTable {
  SlotEndpoints s[kSlotsPerCube];
};
constexpr SlotEndpointTable make_slot_endpoints() {
  SlotEndpointTable t{};
  for (int s = 0; s < kSlotsPerCube; ++s) t.s[s] = slot_endpoints(s);
  return t;
}

/// The 14 BCC neighbours of any lattice point, in doubled coordinates: ±2 along an axis (same
/// kind of point), then (±1, ±1, ±1) (the other kind).
struct NeighbourTable {
  std::int8_t offset[14][3];
  std::uint16_t adjacent[14];  ///< bit j set when neighbours i and j are joined by a lattice edge
};
constexpr bool is_lattice_edge(int dx, int dy, int dz) {
  const int ax = dx < 0 ? -dx : dx, ay = dy < 0 ? -dy : dy, az = dz < 0 ? -dz : dz;
  return (ax == 1 && ay == 1 && az == 1) || (ax + ay + az == 2 && (ax == 2 || ay == 2 || az == 2));
}
constexpr NeighbourTable make_neighbours() {
  NeighbourTable t{};
  int n = 0;
  for (int a = 0; a < 3; ++a)
    for (int s = -1; s <= 1; s += 2) {
      for (int i = 0; i < 3; ++i) t.offset[n][i] = 0;
      t.offset[n][a] = static_cast<std::int8_t>(2 * s);
      ++n;
    }
  for (int z = -1; z <= 1; z += 2)
    for (int y = -1; y <= 1; y += 2)
      for (int x = -1; x <= 1; x += 2) {
        t.offset[n][0] = static_cast<std::int8_t>(x);
        t.offset[n][1] = static_cast<std::int8_t>(y);
        t.offset[n][2] = static_cast<std::int8_t>(z);
        ++n;
      }
  for (int i = 0; i < 14; ++i) {
    t.adjacent[i] = 0;
    for (int j = 0; j < 14; ++j)
      if (i != j &&
          is_lattice_edge(t.offset[i][0] - t.offset[j][0], t.offset[i][1] - t.offset[j][1],
                          t.offset[i][2] - t.offset[j][2]))
        t.adjacent[i] = static_cast<std::uint16_t>(t.adjacent[i] | (1u << j));
  }
  return t;
}

}  // namespace detail

inline constexpr detail::CubeTetTable kCubeTets = detail::make_cube_tets();
inline constexpr detail::TetCaseTable kTetCases = detail::make_tet_cases();
inline constexpr detail::SlotEndpointTable kSlotEndpoints = detail::make_slot_endpoints();
inline constexpr detail::NeighbourTable kNeighbours = detail::make_neighbours();

/// True when the set `members` (bits over the 14 neighbours) is connected through link edges
/// (the empty set counts as connected).
TSF_HD_INLINE bool link_connected(std::uint16_t members) {
  if (members == 0) return true;
  std::uint16_t reached = static_cast<std::uint16_t>(members & (~members + 1u));  // lowest bit
  for (;;) {
    std::uint16_t grown = reached;
    for (int i = 0; i < 14; ++i)
      if ((reached >> i) & 1u) grown = static_cast<std::uint16_t>(grown | kNeighbours.adjacent[i]);
    grown = static_cast<std::uint16_t>(grown & members);
    if (grown == reached) return reached == members;
    reached = grown;
  }
}

/// Where the iso-level crosses the edge from value v0 to v1 (opposite sides): fraction from v0.
TSF_HD_INLINE float crossing_fraction(float v0, float v1, float iso) {
  return (iso - v0) / (v1 - v0);
}

/// Body-centre value: mean of the 8 corners, clamped to their range (see the header comment).
TSF_HD_INLINE float body_centre_value(const float c[8]) {
  float lo = c[0], hi = c[0];
  for (int i = 1; i < 8; ++i) {
    lo = c[i] < lo ? c[i] : lo;
    hi = c[i] > hi ? c[i] : hi;
  }
  const float mean = ((c[0] + c[1]) + (c[2] + c[3]) + ((c[4] + c[5]) + (c[6] + c[7]))) * 0.125f;
  return mean < lo ? lo : (mean > hi ? hi : mean);
}

}  // namespace tsf::imt
