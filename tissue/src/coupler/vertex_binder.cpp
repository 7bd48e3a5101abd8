#include "tsf/coupler/vertex_binder.h"

#include <array>
#include <cmath>
#include <limits>

#include "tsf/crms/lattice_geometry.h"

namespace tsf::coupler {
namespace {

struct SourceTable {
  std::array<Int3, 32> offset{};
  struct Edge {
    std::int8_t from, to, direction;  // direction d from `from` to `to` (crms face direction)
  };
  std::array<Edge, 64> edges{};
  int edge_count = 0;

  SourceTable() {
    for (int b = 0; b < 32; ++b) {
      if (b < 8) {
        offset[b] = {corner_bit(b, 0), corner_bit(b, 1), corner_bit(b, 2)};
      } else {
        const int c = (b - 8) / 3, a = (b - 8) % 3;
        Int3 o{corner_bit(c, 0), corner_bit(c, 1), corner_bit(c, 2)};
        o[a] = outside_offset(c, a);
        offset[b] = o;
      }
    }
    for (int p = 0; p < 32; ++p)
      for (int q = p + 1; q < 32; ++q)
        for (int a = 0; a < 3; ++a) {
          const int d0 = offset[q][a] - offset[p][a];
          bool same_elsewhere = true;
          for (int e = 0; e < 3; ++e)
            if (e != a && offset[q][e] != offset[p][e]) same_elsewhere = false;
          if (same_elsewhere && (d0 == 1 || d0 == -1)) {
            edges[static_cast<std::size_t>(edge_count++)] = {
                static_cast<std::int8_t>(p), static_cast<std::int8_t>(q),
                static_cast<std::int8_t>(crms::make_direction(a, d0))};
          }
        }
  }
};

const SourceTable& table() {
  static const SourceTable t;
  return t;
}

int find_root(std::int8_t* parent, int x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

}  // namespace

Vec3d binding_rest_position(const crms::LatticeGeometry& g, const VertexBinding& b) {
  const Int3 c = g.coordinates(b.cell);
  const Vec3d r = g.rest_position(c.x, c.y, c.z);
  return {r.x + static_cast<double>(b.w[0]) * g.spacing.x,
          r.y + static_cast<double>(b.w[1]) * g.spacing.y,
          r.z + static_cast<double>(b.w[2]) * g.spacing.z};
}

VertexBinder::VertexBinder(const crms::Lattice& lattice) : lattice_(lattice) {
  (void)table();
}

void VertexBinder::group_cube(const Int3& cell) {
  const crms::LatticeGeometry& g = lattice_.geometry();
  const SourceTable& t = table();
  std::int64_t node[32];
  alive_ = 0;
  for (int b = 0; b < 32; ++b) {
    const Int3 p{cell.x + t.offset[b].x, cell.y + t.offset[b].y, cell.z + t.offset[b].z};
    node[b] = -1;
    if (!g.contains(p.x, p.y, p.z)) continue;
    node[b] = g.index(p.x, p.y, p.z);
    if (lattice_.alive(node[b])) alive_ |= 1u << b;
  }
  std::int8_t parent[32];
  for (int b = 0; b < 32; ++b) parent[b] = static_cast<std::int8_t>(b);
  for (int e = 0; e < t.edge_count; ++e) {
    const auto& edge = t.edges[static_cast<std::size_t>(e)];
    if (!((alive_ >> edge.from) & 1u) || !((alive_ >> edge.to) & 1u)) continue;
    if ((lattice_.broken_mask(node[edge.from]) >> edge.direction) & 1u) continue;
    const int ra = find_root(parent, edge.from), rb = find_root(parent, edge.to);
    if (ra != rb) parent[ra > rb ? ra : rb] = static_cast<std::int8_t>(ra < rb ? ra : rb);
  }
  int first_piece = -1;
  single_piece_ = true;
  for (int b = 0; b < 32; ++b) {
    piece_[b] = ((alive_ >> b) & 1u) ? static_cast<std::int8_t>(find_root(parent, b)) : -1;
    if (piece_[b] < 0) continue;
    if (first_piece < 0) first_piece = piece_[b];
    if (piece_[b] != first_piece) single_piece_ = false;
  }
  cached_cell_ = g.index(cell.x, cell.y, cell.z);
}

std::uint32_t VertexBinder::alive_sources(const Int3& cell) {
  if (lattice_.geometry().index(cell.x, cell.y, cell.z) != cached_cell_) group_cube(cell);
  return alive_;
}

std::uint32_t VertexBinder::connected_sources(const Int3& cell, int anchor_bit) {
  if (lattice_.geometry().index(cell.x, cell.y, cell.z) != cached_cell_) group_cube(cell);
  if (anchor_bit < 0 || anchor_bit >= 32 || piece_[anchor_bit] < 0) return 0;
  std::uint32_t mask = 0;
  for (int b = 0; b < 32; ++b)
    if (piece_[b] == piece_[anchor_bit]) mask |= 1u << b;
  return mask;
}

int VertexBinder::pick_anchor(const Int3& cell, const Vec3d& p, const Vec3d& n) const {
  const crms::LatticeGeometry& g = lattice_.geometry();
  const SourceTable& t = table();
  const double h = g.min_spacing();
  int best = -1;
  double best_score = std::numeric_limits<double>::infinity();
  // The cube's corners first: when one of them lies behind the surface it is the anchor (the
  // usual case); the outside neighbours are scored only when every alive corner is in front.
  double best_behind = 1.0;
  for (int b = 0; b < 8; ++b) {
    if (!((alive_ >> b) & 1u)) continue;
    const Vec3d d =
        g.rest_position(cell.x + t.offset[b].x, cell.y + t.offset[b].y, cell.z + t.offset[b].z) - p;
    const double behind = dot(d, n) / h;
    const double score = behind + 0.25 * length(d) / h;
    if (score < best_score) {
      best_score = score;
      best = b;
      best_behind = behind;
    }
  }
  if (best >= 0 && best_behind < 0.0) return best;
  for (int b = 8; b < 32; ++b) {
    if (!((alive_ >> b) & 1u)) continue;
    const Vec3d r =
        g.rest_position(cell.x + t.offset[b].x, cell.y + t.offset[b].y, cell.z + t.offset[b].z);
    const Vec3d d = r - p;
    const double score = dot(d, n) / h + 0.25 * length(d) / h;
    if (score < best_score) {
      best_score = score;
      best = b;
    }
  }
  return best;
}

bool VertexBinder::find_fallback_cube(const Vec3d& p, Int3& cell) const {
  const crms::LatticeGeometry& g = lattice_.geometry();
  const int r = kFallbackSearchNodes;
  Int3 base;
  for (int a = 0; a < 3; ++a) {
    const double t = std::floor((p[a] - g.origin[a]) / g.spacing[a]);
    base[a] = static_cast<int>(std::max(-1e9, std::min(1e9, t)));
  }
  double best = std::numeric_limits<double>::infinity();
  std::int64_t best_node = -1;
  for (int k = base.z - r + 1; k <= base.z + r; ++k)
    for (int j = base.y - r + 1; j <= base.y + r; ++j)
      for (int i = base.x - r + 1; i <= base.x + r; ++i) {
        if (!g.contains(i, j, k)) continue;
        const std::int64_t n = g.index(i, j, k);
        if (!lattice_.alive(n)) continue;
        const double d = length_squared(g.rest_position(i, j, k) - p);
        if (d < best) {
          best = d;
          best_node = n;
        }
      }
  if (best_node < 0) return false;
  // The cube having that node as a corner whose rest box lies nearest to p.
  const Int3 m = g.coordinates(best_node);
  double best_box = std::numeric_limits<double>::infinity();
  for (int o = 0; o < 8; ++o) {
    Int3 c{m.x - corner_bit(o, 0), m.y - corner_bit(o, 1), m.z - corner_bit(o, 2)};
    bool ok = true;
    for (int a = 0; a < 3; ++a) {
      const int top = g.dims[a] >= 2 ? g.dims[a] - 2 : 0;
      if (c[a] < 0 || c[a] > top) ok = false;
    }
    if (!ok) continue;
    double d2 = 0;
    const Vec3d lo = g.rest_position(c.x, c.y, c.z);
    for (int a = 0; a < 3; ++a) {
      const double hi = lo[a] + (g.dims[a] >= 2 ? g.spacing[a] : 0.0);
      const double e = p[a] < lo[a] ? lo[a] - p[a] : (p[a] > hi ? p[a] - hi : 0.0);
      d2 += e * e;
    }
    if (d2 < best_box) {
      best_box = d2;
      cell = c;
    }
  }
  return best_box < std::numeric_limits<double>::infinity();
}

BindingResult VertexBinder::bind(const Vec3f& rest_position, const Vec3f& rest_normal) {
  const crms::LatticeGeometry& g = lattice_.geometry();
  const Vec3d p = to_double(rest_position);
  const Vec3d n = to_double(rest_normal);
  BindingResult out;
  const crms::LatticeCellLocation loc = crms::locate_rest_point(g, p);
  Int3 cell = loc.cell;
  if (g.index(cell.x, cell.y, cell.z) != cached_cell_) group_cube(cell);
  if (alive_ == 0) {
    Int3 other;
    if (find_fallback_cube(p, other)) {
      cell = other;
      group_cube(cell);
      out.borrowed = true;
      ++borrowed_;
    }
  }
  const Vec3d r = g.rest_position(cell.x, cell.y, cell.z);
  out.binding.cell = static_cast<std::int32_t>(g.index(cell.x, cell.y, cell.z));
  for (int a = 0; a < 3; ++a) out.binding.w[a] = static_cast<float>((p[a] - r[a]) / g.spacing[a]);
  if (alive_ == 0) {
    out.orphan = true;
    ++orphans_;
    return out;
  }
  if (single_piece_) {  // every alive source connects to every other: no side to choose
    out.sources = alive_;
    out.single_piece = !out.borrowed;
    return out;
  }
  const int anchor = pick_anchor(cell, p, n);
  for (int b = 0; b < 32; ++b)
    if (piece_[b] >= 0 && piece_[b] == piece_[anchor]) out.sources |= 1u << b;
  return out;
}

}  // namespace tsf::coupler
