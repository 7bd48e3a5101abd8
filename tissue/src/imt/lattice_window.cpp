#include "lattice_window.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace tsf::imt::detail {

namespace {
constexpr float kNotCandidate = std::numeric_limits<float>::infinity();
}

void LatticeWindow::set_layout(const Int3& c0, const Int3& c1, bool merging) {
  const int m = margin(merging);
  lo_ = {c0.x - m, c0.y - m, c0.z - m};
  const Int3 dims{c1.x - c0.x + 2 * m, c1.y - c0.y + 2 * m, c1.z - c0.z + 2 * m};
  if (dims == layout_dims_) return;
  // candidate_t_ stays "no candidate" everywhere between windows: reset what the last window set,
  // with its own layout, before the indices change meaning.
  for (int k = 0; k < 2; ++k) {
    for (std::int64_t i : candidates_[k])
      candidate_t_[k][static_cast<std::size_t>(i)] = kNotCandidate;
    candidates_[k].clear();
  }
  layout_dims_ = dims_ = dims;
  sy_ = dims_.x;
  sz_ = static_cast<std::int64_t>(dims_.x) * dims_.y;
  const std::int64_t s[3] = {1, sy_, sz_};
  auto offset_of = [&](const int P[3]) {  // doubled coordinates relative to 2c
    const bool corner = (P[0] & 1) == 0;
    std::int64_t d = 0;
    for (int k = 0; k < 3; ++k) d += (corner ? P[k] / 2 : (P[k] - 1) / 2) * s[k];
    return PointOffset{corner ? kCornerKind : kCentreKind, d};
  };
  for (int t = 0; t < kTetsPerCube; ++t)
    for (int v = 0; v < 4; ++v) {
      const std::int8_t* P = kCubeTets.tet[t].point[v];
      const int p[3] = {P[0], P[1], P[2]};
      tet_[t][v] = offset_of(p);
    }
  for (int slot = 0; slot < kSlotsPerCube; ++slot) {
    const SlotEndpoints& e = kSlotEndpoints.s[slot];
    const int p0[3] = {e.p0[0], e.p0[1], e.p0[2]}, p1[3] = {e.p1[0], e.p1[1], e.p1[2]};
    slot_[slot][0] = offset_of(p0);
    slot_[slot][1] = offset_of(p1);
    slot_p0_[slot] = {double(p0[0]), double(p0[1]), double(p0[2])};
    slot_p1_[slot] = {double(p1[0]), double(p1[1]), double(p1[2])};
  }
  for (int d = 0; d < 8; ++d) {
    const int P[3] = {2 * (d & 1), 2 * ((d >> 1) & 1), 2 * (d >> 2)};
    cube_point_[d] = offset_of(P);
  }
  {
    const int A[3] = {1, 1, 1}, Bx[3] = {-1, 1, 1}, By[3] = {1, -1, 1}, Bz[3] = {1, 1, -1};
    cube_point_[8] = offset_of(A);
    cube_point_[9] = offset_of(Bx);
    cube_point_[10] = offset_of(By);
    cube_point_[11] = offset_of(Bz);
  }
  for (int n = 0; n < 14; ++n) {
    const std::int8_t* o = kNeighbours.offset[n];
    std::int64_t same = 0, from_corner = 0, from_centre = 0;
    for (int k = 0; k < 3; ++k) {
      same += (o[k] / 2) * s[k];
      from_corner += ((o[k] - 1) / 2) * s[k];  // corner s -> centre s + {−1, 0}
      from_centre += ((o[k] + 1) / 2) * s[k];  // centre m -> corner m + {0, 1}
    }
    if (n < 6) {
      nbr_[kCornerKind][n] = {kCornerKind, same};
      nbr_[kCentreKind][n] = {kCentreKind, same};
    } else {
      nbr_[kCornerKind][n] = {kCentreKind, from_corner};
      nbr_[kCentreKind][n] = {kCornerKind, from_centre};
    }
  }
  // Every other array is fully rewritten by each compute(): only resize.
  const std::size_t n = static_cast<std::size_t>(dims_.volume());
  for (int k = 0; k < 2; ++k) {
    raw_[k].resize(n);
    flags_[k].resize(n);
    pass_[k].resize(n);
    candidate_t_[k].resize(n, kNotCandidate);
  }
  cube_mixed_.resize(n);
  near_mixed_.resize(n);
}

void LatticeWindow::compute(const VoxelVolume& volume, const SurfaceOptions& options,
                            const Int3& c0, const Int3& c1) {
  const bool merging = options.snap_epsilon > 0.0f;
  volume_ = &volume;
  iso_ = options.iso;
  set_layout(c0, c1, merging);
  relevant_.clear();
  if (!load_and_classify(c0, c1)) return;
  if (merging) decide_merges(options.snap_epsilon);
  find_relevant(c0, c1);
}

void LatticeWindow::merged_points(std::vector<MergedPoint>& out) const {
  out.clear();
  for (int kind = 0; kind < 2; ++kind)
    for (std::int64_t i : candidates_[kind]) {
      const std::uint8_t f = flags_[kind][static_cast<std::size_t>(i)];
      if (f & kSnapped) out.push_back({i, static_cast<std::uint8_t>(kind), f});
    }
}

void LatticeWindow::compute_replaying(const VoxelVolume& volume, const SurfaceOptions& options,
                                      const Int3& c0, const Int3& c1,
                                      const std::vector<MergedPoint>& merged) {
  volume_ = &volume;
  iso_ = options.iso;
  set_layout(c0, c1, options.snap_epsilon > 0.0f);
  relevant_.clear();
  if (!load_and_classify(c0, c1)) return;
  for (const MergedPoint& p : merged) flags_[p.kind][static_cast<std::size_t>(p.index)] = p.flags;
  find_relevant(c0, c1);
}

bool LatticeWindow::load_and_classify(const Int3& c0, const Int3& c1) {
  (void)c0;
  (void)c1;
  const VoxelVolume& volume = *volume_;
  const Int3& vd = volume.dims();
  const float* density = volume.density_data().data();
  float* __restrict corner = raw_[kCornerKind].data();
  const float iso = iso_;

  // 1. Corners: volume samples, zero outside.
  const int x0 = std::max(lo_.x, 0), x1 = std::min(lo_.x + dims_.x, vd.x);
  for (int z = 0; z < dims_.z; ++z) {
    const int gz = lo_.z + z;
    for (int y = 0; y < dims_.y; ++y) {
      const int gy = lo_.y + y;
      float* row = corner + sy_ * y + sz_ * z;
      if (gz < 0 || gz >= vd.z || gy < 0 || gy >= vd.y || x1 <= x0) {
        std::fill(row, row + dims_.x, 0.0f);
        continue;
      }
      std::fill(row, row + (x0 - lo_.x), 0.0f);
      std::memcpy(row + (x0 - lo_.x), density + volume.index(x0, gy, gz),
                  sizeof(float) * static_cast<std::size_t>(x1 - x0));
      std::fill(row + (x1 - lo_.x), row + dims_.x, 0.0f);
    }
  }
  // The loops below run over the flattened window: a cube's 8 corners are at i + {0, 1, sy, …},
  // so one long loop vectorises where rows of 10–40 would not. Entries for the last corner of
  // each row, column and slice are not cubes; they are computed as harmless garbage and cleared.
  const std::int64_t n = static_cast<std::int64_t>(raw_[kCornerKind].size());
  const std::int64_t n_cubes = n - (1 + sy_ + sz_);
  const std::int64_t dy = sy_, dz = sz_, dyz = sy_ + sz_;

  // 2. Corner sides.
  std::uint8_t* __restrict cf = flags_[kCornerKind].data();
  for (std::int64_t i = 0; i < n; ++i)
    cf[i] = corner[i] >= iso ? std::uint8_t{kInside | kRawInside} : std::uint8_t{0};

  // 3. Cubes whose corners straddle the iso-level.
  std::uint8_t* __restrict mixed = cube_mixed_.data();
  unsigned any_mixed = 0;
  for (std::int64_t i = 0; i < n_cubes; ++i) {
    const unsigned any = cf[i] | cf[i + 1] | cf[i + dy] | cf[i + dy + 1] | cf[i + dz] |
                         cf[i + dz + 1] | cf[i + dyz] | cf[i + dyz + 1];
    const unsigned all = cf[i] & cf[i + 1] & cf[i + dy] & cf[i + dy + 1] & cf[i + dz] &
                         cf[i + dz + 1] & cf[i + dyz] & cf[i + dyz + 1];
    mixed[i] = static_cast<std::uint8_t>((any ^ all) & kRawInside);
    any_mixed |= mixed[i];
  }
  if (!any_mixed) return false;
  for (std::int64_t i = n_cubes; i < n; ++i) mixed[i] = 0;
  for (int z = 0; z < dims_.z; ++z)
    for (int y = 0; y < dims_.y; ++y) {
      std::uint8_t* row = mixed + sy_ * y + sz_ * z;
      if (y == dims_.y - 1 || z == dims_.z - 1)
        std::fill(row, row + dims_.x, std::uint8_t{0});
      else
        row[dims_.x - 1] = 0;
    }

  // 4. Centres: clamped mean of each cube's 8 corners.
  float* __restrict centre = raw_[kCentreKind].data();
  for (std::int64_t i = 0; i < n_cubes; ++i) {
    const float v[8] = {corner[i],      corner[i + 1],      corner[i + dy],  corner[i + dy + 1],
                        corner[i + dz], corner[i + dz + 1], corner[i + dyz], corner[i + dyz + 1]};
    centre[i] = body_centre_value(v);
  }
  for (std::int64_t i = n_cubes; i < n; ++i) centre[i] = 0.0f;
  // A centre whose cube reaches outside the volume is itself a sample outside the volume: it
  // reads 0 like every other one. (The mean of 4 inside corners at 1 and 4 outside zeros is
  // exactly 0.5: a whole plane of centres on the iso-level, each emitting coincident vertices
  // and zero-area triangles wherever tissue touches the volume's border.)
  // Only windows at the volume's border have such centres: interior windows skip this.
  const bool at_border = lo_.x < 0 || lo_.y < 0 || lo_.z < 0 || lo_.x + dims_.x >= vd.x ||
                         lo_.y + dims_.y >= vd.y || lo_.z + dims_.z >= vd.z;
  if (at_border) {
    // Columns x whose cube reaches outside: gx < 0 or gx + 1 >= vd.x.
    const int x_in0 = std::clamp(-lo_.x, 0, dims_.x);
    const int x_in1 = std::clamp(vd.x - 1 - lo_.x, x_in0, dims_.x);
    for (int z = 0; z < dims_.z; ++z) {
      const int gz = lo_.z + z;
      for (int y = 0; y < dims_.y; ++y) {
        const int gy = lo_.y + y;
        float* row = centre + sy_ * y + sz_ * z;
        if (gz < 0 || gz + 1 >= vd.z || gy < 0 || gy + 1 >= vd.y) {
          std::fill(row, row + dims_.x, 0.0f);
          continue;
        }
        std::fill(row, row + x_in0, 0.0f);
        std::fill(row + x_in1, row + dims_.x, 0.0f);
      }
    }
  }
  std::uint8_t* __restrict mf = flags_[kCentreKind].data();
  for (std::int64_t i = 0; i < n; ++i)
    mf[i] = centre[i] >= iso ? std::uint8_t{kInside | kRawInside} : std::uint8_t{0};
  return true;
}

float LatticeWindow::candidate_fraction(int kind, std::int64_t index, float eps,
                                        std::uint8_t& nbr_flags) const {
  const float v = raw_[kind][static_cast<std::size_t>(index)];
  const std::uint8_t side = flags_[kind][static_cast<std::size_t>(index)] & kRawInside;
  // t_q = (iso − v)/(q − v) over opposite neighbours q; its minimum is |iso − v| / max |q − v|.
  unsigned in_mask = 0;
  float widest = 0.0f;
  for (int n = 0; n < 14; ++n) {
    const PointOffset& q = nbr_[kind][n];
    const std::size_t qi = static_cast<std::size_t>(index + q.delta);
    const std::uint8_t q_side = flags_[q.kind][qi] & kRawInside;
    in_mask |= static_cast<unsigned>(q_side != 0) << n;
    const float gap = std::fabs(raw_[q.kind][qi] - v);
    widest = (q_side != side && gap > widest) ? gap : widest;
  }
  const std::uint16_t out_mask = static_cast<std::uint16_t>(~in_mask & 0x3FFFu);
  nbr_flags =
      static_cast<std::uint8_t>((in_mask ? kHasInsideNbr : 0) | (out_mask ? kHasOutsideNbr : 0));
  if (widest == 0.0f) return kNotCandidate;
  const float t = std::fabs(iso_ - v) / widest;
  if (!(t < eps)) return kNotCandidate;
  // The surface near the point must stay a disc: inside and outside neighbours each connected.
  if (!link_connected(static_cast<std::uint16_t>(in_mask)) || !link_connected(out_mask))
    return kNotCandidate;
  return t;
}

std::int64_t LatticeWindow::global_point_id(int kind, std::int64_t index) const {
  const std::int64_t z = index / sz_, y = (index % sz_) / sy_, x = index % sy_;
  const std::int64_t X = 2 * (lo_.x + x) + kind + 8, Y = 2 * (lo_.y + y) + kind + 8,
                     Z = 2 * (lo_.z + z) + kind + 8;
  return (Z << 42) | (Y << 21) | X;
}

void LatticeWindow::decide_merges(float eps) {
  for (int k = 0; k < 2; ++k) {  // forget the previous window's candidates
    for (std::int64_t i : candidates_[k])
      candidate_t_[k][static_cast<std::size_t>(i)] = kNotCandidate;
    candidates_[k].clear();
  }
  // Candidates: points whose 14 neighbours lie in the window (corners [1, dims−2], centres
  // [1, dims−3] per axis), next to a straddling cube (corners of one; centres of cubes that
  // straddle or touch one by a face), with the nearest crossing within eps of the edge.
  // Densities lie in [0,1], so a crossing fraction below eps needs |v − iso| < eps: a cheap
  // first filter.
  const std::uint8_t* mixed = cube_mixed_.data();
  {
    const std::int64_t n = static_cast<std::int64_t>(near_mixed_.size());
    std::uint8_t* __restrict near = near_mixed_.data();
    const std::uint8_t* __restrict mx = mixed;
    const std::int64_t dy = sy_, dz = sz_;
    for (std::int64_t i = 0; i < dz; ++i) near[i] = 0;
    for (std::int64_t i = n - dz; i < n; ++i) near[i] = 0;
    for (std::int64_t i = dz; i < n - dz; ++i)
      near[i] = static_cast<std::uint8_t>(mx[i] | mx[i - 1] | mx[i + 1] | mx[i - dy] | mx[i + dy] |
                                          mx[i - dz] | mx[i + dz]);
  }
  // Which points pass both cheap tests: a byte per point, flat loops that vectorise.
  {
    const std::int64_t n = static_cast<std::int64_t>(near_mixed_.size());
    const std::int64_t dy = sy_, dz = sz_, dyz = sy_ + sz_;
    const float* __restrict rc = raw_[kCornerKind].data();
    const float* __restrict rm = raw_[kCentreKind].data();
    const std::uint8_t* __restrict mx = mixed;
    const std::uint8_t* __restrict near = near_mixed_.data();
    std::uint8_t* __restrict pc = pass_[kCornerKind].data();
    std::uint8_t* __restrict pm = pass_[kCentreKind].data();
    const float iso = iso_;
    // Densities lie in [0,1]: across an edge to a neighbour q, an inside point v (>= iso) has
    // t = (v − iso)/(v − q) >= (v − iso)/v, an outside one t = (iso − v)/(q − v) >=
    // (iso − v)/(1 − v); both are >= |v − iso| / max(v, 1 − v). A point can only merge when
    // that bound is below eps (branch-free, so the loops vectorise).
    auto close_to_iso = [iso, eps](float v) {
      return std::fabs(v - iso) < eps * std::max(v, 1.0f - v);
    };
    for (std::int64_t i = 0; i < dyz + 1; ++i) pc[i] = 0;
    for (std::int64_t i = dyz + 1; i < n; ++i) {
      const unsigned touches = mx[i] | mx[i - 1] | mx[i - dy] | mx[i - dy - 1] | mx[i - dz] |
                               mx[i - dz - 1] | mx[i - dyz] | mx[i - dyz - 1];
      pc[i] = static_cast<std::uint8_t>((touches != 0) & close_to_iso(rc[i]));
    }
    for (std::int64_t i = 0; i < n; ++i)
      pm[i] = static_cast<std::uint8_t>((near[i] != 0) & close_to_iso(rm[i]));
  }
  for (int kind = 0; kind < 2; ++kind) {
    const int hi = kind == kCornerKind ? 2 : 3;
    std::uint8_t* f = flags_[kind].data();
    const std::uint8_t* pass = pass_[kind].data();
    for (int z = 1; z <= dims_.z - hi; ++z)
      for (int y = 1; y <= dims_.y - hi; ++y) {
        const std::int64_t row = sy_ * y + sz_ * z;
        for (int x = 1; x <= dims_.x - hi; ++x) {
          const std::int64_t i = row + x;
          if (!pass[i]) continue;
          std::uint8_t nbr_flags = 0;
          const float t = candidate_fraction(kind, i, eps, nbr_flags);
          f[i] = static_cast<std::uint8_t>(f[i] | nbr_flags);
          if (t < eps) {
            candidate_t_[kind][static_cast<std::size_t>(i)] = t;
            candidates_[kind].push_back(i);
          }
        }
      }
  }
  // A candidate merges when it beats every candidate neighbour: smaller fraction, then smaller
  // global point id. So no two neighbours merge together, except points exactly on the
  // iso-level (fraction 0): they move nothing, two of them are both inside (no crossing between
  // them to disagree on), and every edge ending at one already emits its vertex at the point,
  // so merging them all is what keeps coincident vertices and zero-area triangles out (a binary
  // volume's body centres: docs/imt.md). Decided where all neighbours were considered:
  // corners [2, dims−3], centres [2, dims−4].
  for (int kind = 0; kind < 2; ++kind) {
    const int hi_pad = kind == kCornerKind ? 3 : 4;
    for (std::int64_t i : candidates_[kind]) {
      const int x = static_cast<int>(i % sy_), y = static_cast<int>((i % sz_) / sy_),
                z = static_cast<int>(i / sz_);
      if (x < 2 || y < 2 || z < 2 || x > dims_.x - hi_pad || y > dims_.y - hi_pad ||
          z > dims_.z - hi_pad)
        continue;
      const float t = candidate_t_[kind][static_cast<std::size_t>(i)];
      bool wins = true;
      for (int nb = 0; nb < 14 && wins; ++nb) {
        const PointOffset& q = nbr_[kind][nb];
        const float tq = candidate_t_[q.kind][static_cast<std::size_t>(i + q.delta)];
        if (tq == kNotCandidate) continue;
        if (tq < t)
          wins = false;
        else if (tq == t)
          wins = t == 0.0f || global_point_id(kind, i) < global_point_id(q.kind, i + q.delta);
      }
      if (!wins) continue;
      std::uint8_t& f = flags_[kind][static_cast<std::size_t>(i)];
      f = static_cast<std::uint8_t>(f | kInside | kSnapped);
    }
  }
}

void LatticeWindow::find_relevant(const Int3& c0, const Int3& c1) {
  // Effective straddling (8 corners and the centre) for cubes [c0 − 1, c1), plus merged points.
  const std::uint8_t* cf = flags_[kCornerKind].data();
  const std::uint8_t* mf = flags_[kCentreKind].data();
  std::uint8_t* mixed = cube_mixed_.data();
  const Int3 a0{c0.x - 1 - lo_.x, c0.y - 1 - lo_.y, c0.z - 1 - lo_.z};
  const Int3 a1{c1.x - lo_.x, c1.y - lo_.y, c1.z - lo_.z};
  {
    const std::int64_t begin = a0.x + sy_ * a0.y + sz_ * a0.z;
    const std::int64_t end = (a1.x - 1) + sy_ * (a1.y - 1) + sz_ * (a1.z - 1) + 1;
    const std::int64_t dy = sy_, dz = sz_, dyz = sy_ + sz_;
    const std::uint8_t* __restrict c = cf;
    const std::uint8_t* __restrict m = mf;
    std::uint8_t* __restrict out = mixed;
    for (std::int64_t i = begin; i < end; ++i) {
      const unsigned any = c[i] | c[i + 1] | c[i + dy] | c[i + dy + 1] | c[i + dz] | c[i + dz + 1] |
                           c[i + dyz] | c[i + dyz + 1] | m[i];
      const unsigned all = c[i] & c[i + 1] & c[i + dy] & c[i + dy + 1] & c[i + dz] & c[i + dz + 1] &
                           c[i + dyz] & c[i + dyz + 1] & m[i];
      out[i] = static_cast<std::uint8_t>(((any ^ all) & kInside) | ((c[i] | m[i]) & kSnapped));
    }
  }
  for (int z = a0.z + 1; z < a1.z; ++z)
    for (int y = a0.y + 1; y < a1.y; ++y) {
      const std::int64_t r = sy_ * y + sz_ * z;
      for (int x = a0.x + 1; x < a1.x; ++x) {
        const std::int64_t i = r + x;
        if (mixed[i] | (mixed[i - 1] & kInside) | (mixed[i - sy_] & kInside) |
            (mixed[i - sz_] & kInside))
          relevant_.push_back({i, {lo_.x + x, lo_.y + y, lo_.z + z}});
      }
    }
}

const LatticeWindow::CubeTables& LatticeWindow::tables() {
  static const CubeTables instance = [] {
    CubeTables tb{};
    // Cube point index of a point in doubled coordinates relative to 2c.
    auto point_index = [](const int P[3]) {
      if ((P[0] & 1) == 0) return (P[0] / 2) + 2 * (P[1] / 2) + 4 * (P[2] / 2);
      for (int a = 0; a < 3; ++a)
        if (P[a] == -1) return 9 + a;
      return 8;
    };
    for (int t = 0; t < kTetsPerCube; ++t)
      for (int v = 0; v < 4; ++v) {
        const std::int8_t* P = kCubeTets.tet[t].point[v];
        const int p[3] = {P[0], P[1], P[2]};
        tb.tet_point[t][v] = static_cast<std::uint8_t>(point_index(p));
      }
    for (int s = 0; s < kSlotCornerPoint; ++s) {
      const SlotEndpoints& e = kSlotEndpoints.s[s];
      const int p0[3] = {e.p0[0], e.p0[1], e.p0[2]}, p1[3] = {e.p1[0], e.p1[1], e.p1[2]};
      tb.slot_point[s][0] = static_cast<std::uint8_t>(point_index(p0));
      tb.slot_point[s][1] = static_cast<std::uint8_t>(point_index(p1));
    }
    for (int face = 0; face < 3; ++face) {
      int k = 0;
      tb.face_points[face] = 0;
      for (int d = 0; d < 8; ++d)
        if (((d >> face) & 1) == 0) tb.face_point[face][k++] = static_cast<std::uint8_t>(d);
      tb.face_point[face][4] = 8;
      tb.face_point[face][5] = static_cast<std::uint8_t>(9 + face);
      for (int q = 0; q < 6; ++q)
        tb.face_points[face] =
            static_cast<std::uint16_t>(tb.face_points[face] | (1u << tb.face_point[face][q]));
      for (unsigned fm = 0; fm < 64; ++fm) {
        unsigned inside = 0;  // the face mask spread back onto cube points
        for (int q = 0; q < 6; ++q) inside |= ((fm >> q) & 1u) << tb.face_point[face][q];
        FaceCase& fc = tb.face_case[face][fm];
        fc.count = 0;
        for (int t = 4 * face; t < 4 * face + 4; ++t) {
          int mask = 0;
          for (int v = 0; v < 4; ++v)
            mask |= static_cast<int>((inside >> tb.tet_point[t][v]) & 1u) << v;
          const TetCase& tc = kTetCases.c[mask];
          for (int tri = 0; tri < tc.triangle_count; ++tri) {
            for (int e = 0; e < 3; ++e)
              fc.keys[fc.count][e] = kCubeTets.tet[t].edge_ref[tc.triangle[tri][e]];
            ++fc.count;
          }
        }
      }
    }
    for (unsigned in = 0; in < (1u << kCubePoints); ++in) {
      std::uint16_t m = 0;
      for (int s = 0; s < kSlotCornerPoint; ++s)
        if (((in >> tb.slot_point[s][0]) ^ (in >> tb.slot_point[s][1])) & 1u)
          m = static_cast<std::uint16_t>(m | (1u << s));
      tb.crossing[in] = m;
    }
    return tb;
  }();
  return instance;
}

int LatticeWindow::count_triangles(std::int64_t local) const {
  const CubeTables& tb = *tables_;
  const CubeSides cs = sides(local);
  int n = 0;
  for (int face = 0; face < 3; ++face) {
    const unsigned fm = face_mask(tb, cs.inside, face);
    if (fm == 0 || fm == 63) continue;
    if ((cs.merged & tb.face_points[face]) == 0) {
      n += tb.face_case[face][fm].count;
      continue;
    }
    // Merged points: count what the general path keeps.
    const LatticeWindow& self = *this;
    int kept = 0;
    self.mesh_cube(local, [&](const LatticeRef*) { ++kept; });
    return kept;
  }
  return n;
}

std::uint16_t LatticeWindow::referenced_slots(std::int64_t local) const {
  const CubeTables& tb = *tables_;
  const CubeSides cs = sides(local);
  std::uint16_t m = tb.crossing[cs.inside];
  if (cs.merged) {
    // An edge whose inside end merged makes no vertex of its own.
    for (unsigned bits = m; bits; bits &= bits - 1) {
      const int s = __builtin_ctz(bits);
      const int a = tb.slot_point[s][0], b = tb.slot_point[s][1];
      const int in = ((cs.inside >> a) & 1u) ? a : b;
      if ((cs.merged >> in) & 1u) m = static_cast<std::uint16_t>(m & ~(1u << s));
    }
    constexpr std::uint8_t kMergedPoint = kSnapped | kHasInsideNbr | kHasOutsideNbr;
    if ((flags_[kCornerKind][static_cast<std::size_t>(local)] & kMergedPoint) == kMergedPoint)
      m = static_cast<std::uint16_t>(m | (1u << kSlotCornerPoint));
    if ((flags_[kCentreKind][static_cast<std::size_t>(local)] & kMergedPoint) == kMergedPoint)
      m = static_cast<std::uint16_t>(m | (1u << kSlotCentrePoint));
  }
  return m;
}

std::uint8_t LatticeWindow::corner_label(std::int64_t index) const {
  const int x = lo_.x + static_cast<int>(index % sy_);
  const int y = lo_.y + static_cast<int>((index % sz_) / sy_);
  const int z = lo_.z + static_cast<int>(index / sz_);
  return volume_->contains(x, y, z) ? volume_->label(x, y, z) : std::uint8_t{0};
}

std::uint8_t LatticeWindow::label_at(const Int3& s) const {
  return volume_->contains(s.x, s.y, s.z) ? volume_->label(s.x, s.y, s.z) : std::uint8_t{0};
}

std::uint8_t LatticeWindow::point_label_at(int px, int py, int pz) const {
  if ((px & 1) == 0) return label_at({px / 2, py / 2, pz / 2});
  const Int3 m{(px - 1) / 2, (py - 1) / 2, (pz - 1) / 2};
  const std::int64_t index = local_index(m);
  const float* c = raw_[kCornerKind].data();
  const std::int64_t d[8] = {0, 1, sy_, 1 + sy_, sz_, 1 + sz_, sy_ + sz_, 1 + sy_ + sz_};
  int best = 0;
  float best_v = c[index];
  for (int k = 1; k < 8; ++k)
    if (c[index + d[k]] > best_v) {
      best_v = c[index + d[k]];
      best = k;
    }
  return label_at({m.x + (best & 1), m.y + ((best >> 1) & 1), m.z + (best >> 2)});
}

std::uint8_t LatticeWindow::point_label(int kind, std::int64_t index) const {
  if (kind == kCornerKind) return corner_label(index);
  const float* c = raw_[kCornerKind].data();
  const std::int64_t d[8] = {0, 1, sy_, 1 + sy_, sz_, 1 + sz_, sy_ + sz_, 1 + sy_ + sz_};
  std::int64_t best = index;
  float best_v = c[index];
  for (int k = 1; k < 8; ++k)
    if (c[index + d[k]] > best_v) {
      best_v = c[index + d[k]];
      best = index + d[k];
    }
  return corner_label(best);
}

std::uint8_t LatticeWindow::vertex_label_at_point(int kind, std::int64_t index) const {
  if (flags_[kind][static_cast<std::size_t>(index)] & kRawInside) return point_label(kind, index);
  // A merged point that was outside: its densest inside neighbour decides. Centre values are
  // recomputed from the corners here: the window may hold only a placeholder for them.
  const float* c = raw_[kCornerKind].data();
  int best_kind = kind;
  std::int64_t best = index;
  float best_v = -1.0f;
  for (int n = 0; n < 14; ++n) {
    const PointOffset& q = nbr_[kind][n];
    const std::int64_t qi = index + q.delta;
    if (!(flags_[q.kind][static_cast<std::size_t>(qi)] & kRawInside)) continue;
    float v;
    if (q.kind == kCornerKind) {
      v = c[qi];
    } else {
      const float corners[8] = {
          c[qi],       c[qi + 1],       c[qi + sy_],       c[qi + 1 + sy_],
          c[qi + sz_], c[qi + 1 + sz_], c[qi + sy_ + sz_], c[qi + 1 + sy_ + sz_]};
      v = body_centre_value(corners);
    }
    if (v > best_v) {
      best_v = v;
      best_kind = q.kind;
      best = qi;
    }
  }
  return point_label(best_kind, best);
}

void LatticeWindow::vertex(const Int3& c, std::int64_t local, int slot, Vec3d& index_position,
                           std::uint8_t& label) const {
  const Vec3d base{2.0 * c.x, 2.0 * c.y, 2.0 * c.z};
  const Vec3d P0 = base + slot_p0_[slot];
  const PointOffset& a = slot_[slot][0];
  const std::int64_t ia = local + a.delta;
  if (slot >= kSlotCornerPoint) {
    index_position = P0 * 0.5;
    label = vertex_label_at_point(a.kind, ia);
    return;
  }
  // Neither end of a referenced edge is merged (a merged point is inside, and an edge whose
  // inside end merged makes no vertex of its own): raw values are the effective ones.
  const Vec3d P1 = base + slot_p1_[slot];
  const PointOffset& b = slot_[slot][1];
  const std::int64_t ib = local + b.delta;
  const double t = crossing_fraction(raw_[a.kind][static_cast<std::size_t>(ia)],
                                     raw_[b.kind][static_cast<std::size_t>(ib)], iso_);
  index_position = {0.5 * (P0.x + t * (P1.x - P0.x)), 0.5 * (P0.y + t * (P1.y - P0.y)),
                    0.5 * (P0.z + t * (P1.z - P0.z))};
  const bool a_inside = flags_[a.kind][static_cast<std::size_t>(ia)] & kInside;
  const Vec3d& P = a_inside ? P0 : P1;
  label = point_label_at(static_cast<int>(P.x), static_cast<int>(P.y), static_cast<int>(P.z));
}

}  // namespace tsf::imt::detail
