#include "tsf/export/mesh_cleanup.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <unordered_map>

#include "parallel_sort.h"
#include "tsf/common/error.h"

namespace tsf::exporter {

bool zero_area_triangle(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const Vec3d p = to_double(a), q = to_double(b), r = to_double(c);
  const double area2 = length(cross(q - p, r - p));
  const double longest = std::max({length(q - p), length(r - q), length(p - r)});
  return longest == 0.0 || area2 <= 1e-12 * longest * longest;
}

namespace {

using Tri = std::array<std::uint32_t, 3>;

std::size_t count_zero_area(const std::vector<Vec3f>& p, const std::vector<Tri>& tris) {
  std::size_t n = 0;
  const auto count = static_cast<std::int64_t>(tris.size());
#pragma omp parallel for reduction(+ : n) schedule(static) if (count > 100000)
  for (std::int64_t i = 0; i < count; ++i) {
    const Tri& t = tris[static_cast<std::size_t>(i)];
    n += zero_area_triangle(p[t[0]], p[t[1]], p[t[2]]);
  }
  return n;
}

std::array<std::uint32_t, 3> bits(const Vec3f& p) {
  std::array<std::uint32_t, 3> b{};
  // +0 and −0 are one position.
  const float x = p.x == 0.0f ? 0.0f : p.x, y = p.y == 0.0f ? 0.0f : p.y,
              z = p.z == 0.0f ? 0.0f : p.z;
  std::memcpy(&b[0], &x, 4);
  std::memcpy(&b[1], &y, 4);
  std::memcpy(&b[2], &z, 4);
  return b;
}

/// Vertices grouped by exactly equal position: the lowest index of each vertex's group.
std::vector<std::uint32_t> position_groups(const std::vector<Vec3f>& positions) {
  const std::size_t n = positions.size();
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::vector<std::array<std::uint32_t, 3>> key(n);
  for (std::size_t v = 0; v < n; ++v) key[v] = bits(positions[v]);
  parallel_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return key[a] != key[b] ? key[a] < key[b] : a < b;
  });
  std::vector<std::uint32_t> group(n);
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i;
    while (j < n && key[order[j]] == key[order[i]]) group[order[j++]] = order[i];
    i = j;
  }
  return group;
}

/// Sorted corner triple and whether the triangle runs in the sorted triple's (even) order.
std::pair<Tri, bool> sorted_key(const Tri& t) {
  Tri s = t;
  std::sort(s.begin(), s.end());
  // A rotation of s keeps the orientation; the other three orders reverse it.
  const bool even = (t[0] == s[0] && t[1] == s[1]) || (t[1] == s[0] && t[2] == s[1]) ||
                    (t[2] == s[0] && t[0] == s[1]);
  return {s, even};
}

std::size_t count_duplicates(const std::vector<Tri>& tris, const std::vector<std::uint32_t>& map) {
  std::vector<Tri> keys(tris.size());
  for (std::size_t t = 0; t < tris.size(); ++t) {
    Tri k{map[tris[t][0]], map[tris[t][1]], map[tris[t][2]]};
    std::sort(k.begin(), k.end());
    keys[t] = k;
  }
  parallel_sort(keys.begin(), keys.end());
  std::size_t dup = 0;
  for (std::size_t t = 1; t < keys.size(); ++t) dup += keys[t] == keys[t - 1];
  return dup;
}

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

}  // namespace

DuplicateRemoval drop_duplicate_triangles(std::vector<Tri>& tris,
                                          const std::vector<std::uint32_t>& key_of_vertex) {
  DuplicateRemoval r;
  const auto key = [&](std::uint32_t v) { return key_of_vertex.empty() ? v : key_of_vertex[v]; };
  std::vector<std::uint32_t> order(tris.size());
  std::iota(order.begin(), order.end(), 0u);
  std::vector<std::pair<Tri, bool>> keys(tris.size());
  for (std::size_t t = 0; t < tris.size(); ++t)
    keys[t] = sorted_key({key(tris[t][0]), key(tris[t][1]), key(tris[t][2])});
  parallel_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return keys[a].first != keys[b].first ? keys[a].first < keys[b].first : a < b;
  });
  std::vector<char> keep(tris.size(), 1);
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    long net = 0;
    while (j < order.size() && keys[order[j]].first == keys[order[i]].first)
      net += keys[order[j++]].second ? 1 : -1;
    if (j - i > 1) {
      // Keep one triangle of the orientation in excess (none when they cancel).
      bool kept = false;
      for (std::size_t k = i; k < j; ++k) {
        const bool even = keys[order[k]].second;
        if (!kept && net != 0 && even == (net > 0)) {
          kept = true;
          continue;
        }
        keep[order[k]] = 0;
      }
      if (net == 0)
        r.fins += j - i;
      else
        r.duplicates += j - i - 1;
    }
    i = j;
  }
  std::size_t w = 0;
  for (std::size_t t = 0; t < tris.size(); ++t)
    if (keep[t]) tris[w++] = tris[t];
  tris.resize(w);
  return r;
}

CapRemoval flip_caps(std::vector<Tri>& tris, const std::vector<Vec3f>& p) {
  // A few rounds: a flip can make a new cap only when the neighbour's far corner is collinear
  // too.
  CapRemoval r;
  for (int round = 0; round < 8; ++round) {
    std::vector<std::uint32_t> caps;
    for (std::uint32_t t = 0; t < tris.size(); ++t)
      if (zero_area_triangle(p[tris[t][0]], p[tris[t][1]], p[tris[t][2]])) caps.push_back(t);
    if (caps.empty()) break;
    // The directed edge b->a opposite each cap's long edge a->b, and the middle corner c.
    struct Cap {
      std::uint32_t tri, a, b, c;
    };
    std::vector<Cap> cap_info;
    std::unordered_map<std::uint64_t, std::uint32_t> wanted;  // edge b->a -> cap number
    for (std::uint32_t t : caps) {
      const Tri& c = tris[t];
      double longest = -1;
      int k_best = 0;
      for (int k = 0; k < 3; ++k) {
        const double e = length_squared(to_double(p[c[(k + 1) % 3]]) - to_double(p[c[k]]));
        if (e > longest) {
          longest = e;
          k_best = k;
        }
      }
      const Cap info{t, c[k_best], c[(k_best + 1) % 3], c[(k_best + 2) % 3]};
      wanted.emplace(edge_key(info.b, info.a), static_cast<std::uint32_t>(cap_info.size()));
      cap_info.push_back(info);
    }
    std::vector<std::uint32_t> neighbour(cap_info.size(), UINT32_MAX);
    std::vector<std::uint32_t> neighbours_found(cap_info.size(), 0);
    for (std::uint32_t t = 0; t < tris.size(); ++t)
      for (int k = 0; k < 3; ++k) {
        const auto it = wanted.find(edge_key(tris[t][k], tris[t][(k + 1) % 3]));
        if (it == wanted.end()) continue;
        neighbour[it->second] = t;
        ++neighbours_found[it->second];
      }
    std::vector<char> touched(tris.size(), 0), drop(tris.size(), 0);
    for (std::uint32_t t : caps) touched[t] = 1;
    std::vector<Tri> added;
    bool progress = false;
    for (std::size_t i = 0; i < cap_info.size(); ++i) {
      const Cap& c = cap_info[i];
      const std::uint32_t n = neighbour[i];
      if (neighbours_found[i] != 1) {
        drop[c.tri] = 1;
        ++r.removed;
        progress = true;
        continue;
      }
      if (touched[n]) {
        if (round == 7) {
          drop[c.tri] = 1;
          ++r.removed;
        }
        continue;  // the neighbour is a cap or split this round: next round
      }
      // Neighbour (b, a, d) in its own rotation.
      const Tri& nt = tris[n];
      std::uint32_t d = UINT32_MAX;
      for (int k = 0; k < 3; ++k)
        if (nt[k] == c.b && nt[(k + 1) % 3] == c.a) d = nt[(k + 2) % 3];
      touched[n] = 1;
      drop[n] = 1;
      drop[c.tri] = 1;
      added.push_back({c.b, c.c, d});
      added.push_back({c.c, c.a, d});
      ++r.flipped;
      progress = true;
    }
    std::size_t w = 0;
    for (std::size_t t = 0; t < tris.size(); ++t)
      if (!drop[t]) tris[w++] = tris[t];
    tris.resize(w);
    tris.insert(tris.end(), added.begin(), added.end());
    if (!progress) break;
  }

  return r;
}

TriangleDefects count_triangle_defects(const imt::SurfaceMesh& mesh) {
  TriangleDefects d;
  d.triangles = mesh.triangles.size();
  d.zero_area = count_zero_area(mesh.positions, mesh.triangles);
  d.duplicates = count_duplicates(mesh.triangles, position_groups(mesh.positions));
  return d;
}

std::vector<Vec3f> gather(const std::vector<Vec3f>& positions,
                          const std::vector<std::uint32_t>& origin) {
  std::vector<Vec3f> out(origin.size());
  for (std::size_t v = 0; v < origin.size(); ++v) out[v] = positions[origin[v]];
  return out;
}

CleanTopology clean_topology(const imt::SurfaceMesh& mesh,
                             const std::vector<const std::vector<Vec3f>*>& other_states,
                             float tolerance) {
  const std::size_t nv = mesh.positions.size();
  require(mesh.labels.size() == nv, "clean_topology: a label per vertex");
  for (const auto* s : other_states)
    require(s && s->size() == nv, "clean_topology: every state has the mesh's vertices");
  CleanTopology out;
  CleanupReport& r = out.report;
  r.before.triangles = mesh.triangles.size();
  r.before.zero_area = count_zero_area(mesh.positions, mesh.triangles);

  // 1. Weld.
  std::vector<std::uint32_t> group = position_groups(mesh.positions);
  r.before.duplicates = count_duplicates(mesh.triangles, group);
  if (!other_states.empty()) {
    const float tol2 = tolerance * tolerance;
    for (std::uint32_t v = 0; v < nv; ++v) {
      const std::uint32_t g = group[v];
      if (g == v) continue;
      for (const auto* s : other_states)
        if (length_squared((*s)[v] - (*s)[g]) > tol2) {
          group[v] = v;  // moves apart later: keeps its own vertex
          break;
        }
    }
  }
  for (std::uint32_t v = 0; v < nv; ++v) r.welded_vertices += group[v] != v;

  // 2. Collapsed triangles.
  std::vector<Tri> tris;
  tris.reserve(mesh.triangles.size());
  for (const Tri& t : mesh.triangles) {
    const Tri w{group[t[0]], group[t[1]], group[t[2]]};
    if (w[0] == w[1] || w[1] == w[2] || w[2] == w[0]) {
      ++r.collapsed_removed;
      continue;
    }
    tris.push_back(w);
  }

  // 3. Duplicates and fins.
  const DuplicateRemoval dup = drop_duplicate_triangles(tris);
  r.duplicates_removed = dup.duplicates;
  r.fins_removed = dup.fins;

  // 4. Caps.
  const CapRemoval caps = flip_caps(tris, mesh.positions);
  r.caps_flipped = caps.flipped;
  r.caps_removed = caps.removed;

  // Compact: the vertices triangles use, in index order.
  std::vector<std::uint32_t> index_of(nv, UINT32_MAX);
  for (const Tri& t : tris)
    for (std::uint32_t v : t) index_of[v] = 0;
  for (std::uint32_t v = 0; v < nv; ++v)
    if (index_of[v] == 0) {
      index_of[v] = static_cast<std::uint32_t>(out.origin.size());
      out.origin.push_back(v);
      out.labels.push_back(mesh.labels[v]);
    }
  out.triangles.reserve(tris.size());
  for (const Tri& t : tris)
    out.triangles.push_back({index_of[t[0]], index_of[t[1]], index_of[t[2]]});

  r.after.triangles = out.triangles.size();
  const auto& p = mesh.positions;
  for (const Tri& t : out.triangles)
    r.after.zero_area +=
        zero_area_triangle(p[out.origin[t[0]]], p[out.origin[t[1]]], p[out.origin[t[2]]]);
  // Step 3 left no duplicates; only a flip could make one (its new triangles).
  if (r.caps_flipped > 0) {
    std::vector<std::uint32_t> identity(out.origin.size());
    std::iota(identity.begin(), identity.end(), 0u);
    r.after.duplicates = count_duplicates(out.triangles, identity);
  }
  return out;
}

}  // namespace tsf::exporter
