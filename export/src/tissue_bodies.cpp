#include "tsf/export/tissue_bodies.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "tsf/common/error.h"
#include "tsf/export/mesh_cleanup.h"

namespace tsf::exporter {

namespace {

using Tri = std::array<std::uint32_t, 3>;

/// uint64 key -> vertex index, open addressing (keys are never ~0).
class KeyMap {
 public:
  KeyMap() { rehash(1u << 16); }
  /// The index stored for `key`, or `fresh` (stored) when it is new; `inserted` says which.
  std::uint32_t get_or_insert(std::uint64_t key, std::uint32_t fresh, bool& inserted) {
    if (2 * (size_ + 1) > keys_.size()) rehash(2 * keys_.size());
    std::size_t i = slot(key);
    while (keys_[i] != kEmpty) {
      if (keys_[i] == key) {
        inserted = false;
        return values_[i];
      }
      i = (i + 1) & (keys_.size() - 1);
    }
    keys_[i] = key;
    values_[i] = fresh;
    ++size_;
    inserted = true;
    return fresh;
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::size_t slot(std::uint64_t key) const {
    key ^= key >> 33;
    key *= 0xff51afd7ed558ccdULL;
    key ^= key >> 33;
    return static_cast<std::size_t>(key) & (keys_.size() - 1);
  }
  void rehash(std::size_t capacity) {
    std::vector<std::uint64_t> old_keys = std::move(keys_);
    std::vector<std::uint32_t> old_values = std::move(values_);
    keys_.assign(capacity, kEmpty);
    values_.assign(capacity, 0);
    for (std::size_t i = 0; i < old_keys.size(); ++i) {
      if (old_keys[i] == kEmpty) continue;
      std::size_t j = slot(old_keys[i]);
      while (keys_[j] != kEmpty) j = (j + 1) & (keys_.size() - 1);
      keys_[j] = old_keys[i];
      values_[j] = old_values[i];
    }
  }
  std::vector<std::uint64_t> keys_;
  std::vector<std::uint32_t> values_;
  std::size_t size_ = 0;
};

/// The 7 lattice directions of the Kuhn triangulation's edges (all components 0 or 1).
int direction_code(const Int3& d) {
  return d.x + 2 * d.y + 4 * d.z;
}  // 1..7

class Builder {
 public:
  Builder(const VoxelVolume& volume, float iso)
      : v_(volume), iso_(iso), dims_(volume.dims()), px_(dims_.x + 2), py_(dims_.y + 2) {
    origin_ = volume.geometry().origin;
    step_ = volume.geometry().spacing;
  }

  InterfaceComplex run() {
    // Kuhn tetrahedra of the unit cube: for each axis order (a, b, c) the chain 0, e_a,
    // e_a + e_b, 1.
    static const int kOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                      {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int z = -1; z < dims_.z; ++z)
      for (int y = -1; y < dims_.y; ++y)
        for (int x = -1; x < dims_.x; ++x) {
          std::uint16_t r[8];
          bool mixed = false;
          for (int b = 0; b < 8; ++b) {
            r[b] = region({x + (b & 1), y + ((b >> 1) & 1), z + ((b >> 2) & 1)});
            mixed |= r[b] != r[0];
          }
          if (!mixed) continue;
          for (int o = 0; o < 6; ++o) {
            Int3 p[4];
            p[0] = {x, y, z};
            for (int k = 1; k < 4; ++k) {
              p[k] = p[k - 1];
              p[k][kOrders[o][k - 1]] += 1;
            }
            tetrahedron(p, static_cast<std::uint64_t>(linear({x, y, z})) * 6 +
                               static_cast<std::uint64_t>(o));
          }
        }
    return std::move(out_);
  }

 private:
  static constexpr std::uint64_t kEdgeTag = 1ULL << 62, kFaceTag = 2ULL << 62, kTetTag = 3ULL << 62;

  bool in_volume(const Int3& p) const {
    return p.x >= 0 && p.y >= 0 && p.z >= 0 && p.x < dims_.x && p.y < dims_.y && p.z < dims_.z;
  }
  float density(const Int3& p) const { return in_volume(p) ? v_.density(p.x, p.y, p.z) : 0.0f; }
  std::uint16_t region(const Int3& p) const {
    if (!in_volume(p)) return kAirRegion;
    return v_.density(p.x, p.y, p.z) >= iso_ ? v_.label(p.x, p.y, p.z) : kAirRegion;
  }
  std::int64_t linear(const Int3& p) const {
    return (p.x + 1) + static_cast<std::int64_t>(px_) *
                           ((p.y + 1) + static_cast<std::int64_t>(py_) * (p.z + 1));
  }
  Vec3f position(const Int3& p) const {
    return to_float(origin_ + Vec3d{p.x * step_.x, p.y * step_.y, p.z * step_.z});
  }

  std::uint32_t add_vertex(std::uint64_t key, const Vec3f& where) {
    bool inserted = false;
    const std::uint32_t v =
        map_.get_or_insert(key, static_cast<std::uint32_t>(out_.positions.size()), inserted);
    if (inserted) out_.positions.push_back(where);
    return v;
  }

  /// The vertex on edge ab (regions differ); a, b lattice points with b − a in {0,1}³.
  std::uint32_t edge_vertex(const Int3& a, const Int3& b) {
    const Int3 lo = linear(a) < linear(b) ? a : b, hi = linear(a) < linear(b) ? b : a;
    const Int3 d{hi.x - lo.x, hi.y - lo.y, hi.z - lo.z};
    const std::uint64_t key = kEdgeTag | (static_cast<std::uint64_t>(linear(lo)) * 8 +
                                          static_cast<std::uint64_t>(direction_code(d)));
    const std::uint16_t rl = region(lo), rh = region(hi);
    float t = 0.5f;
    if (rl == kAirRegion || rh == kAirRegion) {
      const float dl = density(lo), dh = density(hi);
      t = dh != dl ? (iso_ - dl) / (dh - dl) : 0.5f;
      t = std::clamp(t, 0.02f, 0.98f);
    }
    const Vec3f pl = position(lo), ph = position(hi);
    return add_vertex(key, pl + (ph - pl) * t);
  }

  void emit(const Vec3f* corner_of_behind_side, const Vec3f* corner_of_front_side, std::uint32_t a,
            std::uint32_t b, std::uint32_t c, std::uint16_t behind, std::uint16_t front) {
    const Vec3f& pa = out_.positions[a];
    const Vec3f n = cross(out_.positions[b] - pa, out_.positions[c] - pa);
    const Vec3f dir = *corner_of_front_side - *corner_of_behind_side;
    if (dot(n, dir) < 0.0f) std::swap(b, c);
    if (behind > front) {  // canonical: the lower region behind
      std::swap(b, c);
      std::swap(behind, front);
    }
    out_.triangles.push_back({a, b, c});
    out_.behind.push_back(behind);
    out_.front.push_back(front);
  }

  void tetrahedron(const Int3 p[4], std::uint64_t tet_id) {
    std::uint16_t r[4];
    for (int i = 0; i < 4; ++i) r[i] = region(p[i]);
    int distinct = 1;
    for (int i = 1; i < 4; ++i) {
      bool seen = false;
      for (int j = 0; j < i; ++j) seen |= r[j] == r[i];
      distinct += !seen;
    }
    if (distinct == 1) return;
    Vec3f x[4];
    for (int i = 0; i < 4; ++i) x[i] = position(p[i]);
    if (distinct == 2) {
      // Marching tetrahedra: one corner against three, or two against two.
      int lone = -1;
      for (int i = 0; i < 4 && lone < 0; ++i) {
        int same = 0;
        for (int j = 0; j < 4; ++j) same += r[j] == r[i];
        if (same == 1) lone = i;
      }
      if (lone >= 0) {
        int o[3], k = 0;
        for (int j = 0; j < 4; ++j)
          if (j != lone) o[k++] = j;
        const Vec3f rest = (x[o[0]] + x[o[1]] + x[o[2]]) * (1.0f / 3.0f);
        emit(&x[lone], &rest, edge_vertex(p[lone], p[o[0]]), edge_vertex(p[lone], p[o[1]]),
             edge_vertex(p[lone], p[o[2]]), r[lone], r[o[0]]);
        return;
      }
      int a[2] = {0, 0}, b[2] = {0, 0}, na = 0, nb = 0;
      for (int j = 0; j < 4; ++j) (r[j] == r[0] ? a[na++] : b[nb++]) = j;
      const Vec3f ca = (x[a[0]] + x[a[1]]) * 0.5f, cb = (x[b[0]] + x[b[1]]) * 0.5f;
      const std::uint32_t e00 = edge_vertex(p[a[0]], p[b[0]]), e01 = edge_vertex(p[a[0]], p[b[1]]),
                          e11 = edge_vertex(p[a[1]], p[b[1]]), e10 = edge_vertex(p[a[1]], p[b[0]]);
      // The quad e00, e01, e11, e10 (around the tetrahedron's middle).
      emit(&ca, &cb, e00, e01, e11, r[a[0]], r[b[0]]);
      emit(&ca, &cb, e00, e11, e10, r[a[0]], r[b[0]]);
      return;
    }
    // Three or four regions: barycentric walls around a centre vertex.
    static const int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    std::uint32_t e[4][4];
    Vec3f centre{0, 0, 0};
    int cut = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        if (r[i] != r[j]) {
          e[i][j] = e[j][i] = edge_vertex(p[i], p[j]);
          centre += out_.positions[e[i][j]];
          ++cut;
        }
    const std::uint32_t g = add_vertex(kTetTag | tet_id, centre * (1.0f / static_cast<float>(cut)));
    for (const auto& f : kFaces) {
      const int i = f[0], j = f[1], k = f[2];
      const bool ij = r[i] != r[j], jk = r[j] != r[k], ik = r[i] != r[k];
      if (ij && jk && ik) {
        // Face vertex: keyed by the face's lowest lattice point and the steps to the other two.
        Int3 q[3] = {p[i], p[j], p[k]};
        std::sort(q, q + 3, [&](const Int3& s, const Int3& t) { return linear(s) < linear(t); });
        const Int3 d1{q[1].x - q[0].x, q[1].y - q[0].y, q[1].z - q[0].z};
        const Int3 d2{q[2].x - q[0].x, q[2].y - q[0].y, q[2].z - q[0].z};
        const std::uint64_t key =
            kFaceTag | (static_cast<std::uint64_t>(linear(q[0])) * 64 +
                        static_cast<std::uint64_t>(direction_code(d1) * 8 + direction_code(d2)));
        const Vec3f fp =
            (out_.positions[e[i][j]] + out_.positions[e[j][k]] + out_.positions[e[i][k]]) *
            (1.0f / 3.0f);
        const std::uint32_t fv = add_vertex(key, fp);
        const int pairs[3][2] = {{i, j}, {j, k}, {i, k}};
        for (const auto& pr : pairs)
          emit(&x[pr[0]], &x[pr[1]], e[pr[0]][pr[1]], fv, g, r[pr[0]], r[pr[1]]);
      } else if (ij || jk || ik) {
        // Two regions on this face: the corner alone against the other two.
        const int lone = !ij ? k : (!jk ? i : j);
        const int o1 = lone == i ? j : i, o2 = lone == k ? j : k;
        const Vec3f rest = (x[o1] + x[o2]) * 0.5f;
        emit(&x[lone], &rest, e[lone][o1], e[lone][o2], g, r[lone], r[o1]);
      }
    }
  }

  const VoxelVolume& v_;
  float iso_;
  Int3 dims_;
  int px_, py_;
  Vec3d origin_, step_;
  KeyMap map_;
  InterfaceComplex out_;
};

}  // namespace

std::vector<std::uint8_t> InterfaceComplex::tissues() const {
  bool seen[257] = {};
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    seen[behind[t]] = true;
    seen[front[t]] = true;
  }
  std::vector<std::uint8_t> out;
  for (int l = 0; l < 256; ++l)
    if (seen[l]) out.push_back(static_cast<std::uint8_t>(l));
  return out;
}

InterfaceComplex tissue_interfaces(const VoxelVolume& volume, float iso) {
  require(iso > 0.0f && iso <= 1.0f,
          "tissue bodies: iso-level " + std::to_string(iso) + " is outside (0, 1]");
  const Int3 d = volume.dims();
  require(static_cast<std::int64_t>(d.x + 2) * (d.y + 2) * (d.z + 2) < (std::int64_t{1} << 52),
          "tissue bodies: volume too large for 64-bit vertex keys");
  require(volume.label_data().size() == volume.voxel_count(),
          "tissue bodies need a label per voxel");
  return Builder(volume, iso).run();
}

std::vector<std::uint32_t> interface_parts(const InterfaceComplex& c) {
  std::vector<std::uint32_t> part(c.triangles.size());
  for (std::size_t t = 0; t < part.size(); ++t)
    part[t] = static_cast<std::uint32_t>(c.behind[t]) * 257u + c.front[t];
  return part;
}

InterfaceComplex decimated_complex(const InterfaceComplex& complex, const DecimatedMesh& d,
                                   std::size_t* squeezed) {
  InterfaceComplex out;
  out.positions = complex.positions;
  const std::size_t n = d.triangles.size();
  // Each triangle in the orientation of its sorted corners: from region x to region y.
  struct Oriented {
    Tri sorted;
    std::uint16_t x, y;
  };
  std::vector<Oriented> tri(n);
  for (std::size_t t = 0; t < n; ++t) {
    const Tri v{d.origin[d.triangles[t][0]], d.origin[d.triangles[t][1]],
                d.origin[d.triangles[t][2]]};
    Tri s = v;
    std::sort(s.begin(), s.end());
    const bool even = (v[0] == s[0] && v[1] == s[1]) || (v[1] == s[0] && v[2] == s[1]) ||
                      (v[2] == s[0] && v[0] == s[1]);
    const std::uint32_t part = d.part[d.triangles[t][0]];
    const auto behind = static_cast<std::uint16_t>(part / 257u),
               front = static_cast<std::uint16_t>(part % 257u);
    tri[t] = {s, even ? behind : front, even ? front : behind};
  }
  std::vector<std::uint32_t> order(n);
  for (std::uint32_t t = 0; t < n; ++t) order[t] = t;
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return tri[a].sorted < tri[b].sorted; });
  std::size_t pairs = 0;
  const auto add = [&](const Tri& sorted, std::uint16_t x, std::uint16_t y) {
    // Sorted order runs from x to y; store with the lower region behind.
    if (x < y) {
      out.triangles.push_back(sorted);
      out.behind.push_back(x);
      out.front.push_back(y);
    } else {
      out.triangles.push_back({sorted[0], sorted[2], sorted[1]});
      out.behind.push_back(y);
      out.front.push_back(x);
    }
  };
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i;
    while (j < n && tri[order[j]].sorted == tri[order[i]].sorted) ++j;
    if (j - i == 2) {
      const Oriented &a = tri[order[i]], &b = tri[order[i + 1]];
      if (a.y == b.x || b.y == a.x) {
        const std::uint16_t x = a.y == b.x ? a.x : b.x, y = a.y == b.x ? b.y : a.y;
        if (x != y) add(a.sorted, x, y);
        ++pairs;
        i = j;
        continue;
      }
    }
    for (std::size_t k = i; k < j; ++k) add(tri[order[k]].sorted, tri[order[k]].x, tri[order[k]].y);
    i = j;
  }
  if (squeezed) *squeezed = pairs;
  return out;
}

std::vector<std::uint32_t> body_nonmanifold_vertices(const InterfaceComplex& c) {
  // Per body, its undirected edges (a triangle counts for both regions it separates).
  std::vector<std::pair<std::uint16_t, std::uint64_t>> keyed;
  keyed.reserve(6 * c.triangles.size());
  for (std::size_t t = 0; t < c.triangles.size(); ++t)
    for (std::uint16_t region : {c.behind[t], c.front[t]}) {
      if (region == kAirRegion) continue;
      for (int k = 0; k < 3; ++k) {
        std::uint32_t u = c.triangles[t][k], v = c.triangles[t][(k + 1) % 3];
        if (u > v) std::swap(u, v);
        keyed.push_back({region, (static_cast<std::uint64_t>(u) << 32) | v});
      }
    }
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < keyed.size();) {
    std::size_t j = i;
    while (j < keyed.size() && keyed[j] == keyed[i]) ++j;
    if (j - i > 2) {
      out.push_back(static_cast<std::uint32_t>(keyed[i].second >> 32));
      out.push_back(static_cast<std::uint32_t>(keyed[i].second & 0xffffffffu));
    }
    i = j;
  }
  // Per body, vertices whose triangles form more than one fan (pinched: two sheets touching at a
  // point). Two triangles around a vertex are in one fan when they share another vertex.
  std::vector<std::tuple<std::uint16_t, std::uint32_t, std::uint32_t>> around;
  around.reserve(6 * c.triangles.size());
  for (std::size_t t = 0; t < c.triangles.size(); ++t)
    for (std::uint16_t region : {c.behind[t], c.front[t]}) {
      if (region == kAirRegion) continue;
      for (std::uint32_t v : c.triangles[t])
        around.emplace_back(region, v, static_cast<std::uint32_t>(t));
    }
  std::sort(around.begin(), around.end());
  for (std::size_t i = 0; i < around.size();) {
    std::size_t j = i;
    while (j < around.size() && std::get<0>(around[j]) == std::get<0>(around[i]) &&
           std::get<1>(around[j]) == std::get<1>(around[i]))
      ++j;
    const std::size_t k = j - i;
    std::vector<std::size_t> fan(k);
    for (std::size_t a = 0; a < k; ++a) fan[a] = a;
    const auto find = [&](std::size_t x) {
      while (fan[x] != x) x = fan[x] = fan[fan[x]];
      return x;
    };
    const std::uint32_t v = std::get<1>(around[i]);
    for (std::size_t a = 0; a < k; ++a)
      for (std::size_t b = a + 1; b < k; ++b) {
        const Tri& ta = c.triangles[std::get<2>(around[i + a])];
        const Tri& tb = c.triangles[std::get<2>(around[i + b])];
        bool share = false;
        for (std::uint32_t x : ta)
          for (std::uint32_t y : tb) share |= x == y && x != v;
        if (share) fan[find(a)] = find(b);
      }
    std::size_t fans = 0;
    for (std::size_t a = 0; a < k; ++a) fans += find(a) == a;
    if (fans > 1) out.push_back(v);
    i = j;
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

InterfaceComplex decimate_interfaces(const InterfaceComplex& complex,
                                     const DecimationOptions& options, DecimatedMesh* report) {
  DecimationOptions o = options;
  o.manifold_runs = 1;  // the bodies are checked here, each as a whole
  const std::vector<std::uint32_t> parts = interface_parts(complex);
  InterfaceComplex out;
  DecimatedMesh d;
  for (int round = 0; round < 8; ++round) {
    d = decimate_parts(complex.positions, complex.triangles, parts, o, false);
    out = decimated_complex(complex, d);
    std::vector<std::uint32_t> bad = body_nonmanifold_vertices(out);
    d.nonmanifold_vertices = bad.size();
    // Collinear triangles the cap flip could not pair away (two caps across one long edge):
    // their corners are such spots too.
    for (const Tri& t : out.triangles)
      if (zero_area_triangle(out.positions[t[0]], out.positions[t[1]], out.positions[t[2]]))
        bad.insert(bad.end(), t.begin(), t.end());
    if (bad.empty()) break;
    // Lock the spots with two rings around them (decimate_parts adds the second): one ring
    // mostly moves the problem next door.
    std::vector<char> hit(complex.positions.size(), 0), ring(complex.positions.size(), 0);
    for (std::uint32_t v : bad) hit[v] = 1;
    for (const Tri& t : complex.triangles)
      if (hit[t[0]] || hit[t[1]] || hit[t[2]])
        for (std::uint32_t v : t) ring[v] = 1;
    for (std::uint32_t v = 0; v < ring.size(); ++v)
      if (ring[v]) o.locked_sources.push_back(v);
  }
  if (report) *report = std::move(d);
  return out;
}

imt::SurfaceMesh body_mesh(const InterfaceComplex& c, std::uint8_t tissue) {
  imt::SurfaceMesh m;
  std::vector<std::uint32_t> index_of(c.positions.size(), UINT32_MAX);
  const auto use = [&](std::uint32_t v) {
    if (index_of[v] == UINT32_MAX) {
      index_of[v] = static_cast<std::uint32_t>(m.positions.size());
      m.positions.push_back(c.positions[v]);
    }
    return index_of[v];
  };
  for (std::size_t t = 0; t < c.triangles.size(); ++t) {
    const Tri& tri = c.triangles[t];
    if (c.behind[t] == tissue)
      m.triangles.push_back({use(tri[0]), use(tri[1]), use(tri[2])});
    else if (c.front[t] == tissue)
      m.triangles.push_back({use(tri[0]), use(tri[2]), use(tri[1])});
  }
  m.labels.assign(m.positions.size(), tissue);
  return m;
}

}  // namespace tsf::exporter
