#include "tsf/imt/mesh_topology.h"

#include <algorithm>
#include <cstdint>
#include <numeric>

namespace tsf::imt {

namespace {

struct DisjointSets {
  std::vector<std::uint32_t> parent;
  explicit DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void join(std::uint32_t a, std::uint32_t b) { parent[find(a)] = find(b); }
};

struct DirectedEdge {
  std::uint64_t key;  // (min << 32) | max
  std::uint32_t triangle;
  bool forward;  // runs min -> max
};

}  // namespace

MeshTopology analyse_topology(const SurfaceMesh& mesh) {
  MeshTopology r;
  const std::size_t nv = mesh.positions.size();
  const std::size_t nt = mesh.triangles.size();
  r.triangles = nt;

  std::vector<std::uint32_t> uses(nv, 0);
  std::vector<DirectedEdge> edges;
  edges.reserve(3 * nt);
  for (std::uint32_t t = 0; t < nt; ++t) {
    const auto& tri = mesh.triangles[t];
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      ++r.degenerate_triangles;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = tri[static_cast<std::size_t>(k)],
                          b = tri[static_cast<std::size_t>((k + 1) % 3)];
      ++uses[a];
      const std::uint32_t lo = std::min(a, b), hi = std::max(a, b);
      edges.push_back({(static_cast<std::uint64_t>(lo) << 32) | hi, t, a == lo});
    }
  }
  for (std::size_t v = 0; v < nv; ++v) {
    if (uses[v] == 0)
      ++r.unreferenced_vertices;
    else
      ++r.vertices;
  }
  std::sort(edges.begin(), edges.end(), [](const DirectedEdge& a, const DirectedEdge& b) {
    return a.key != b.key ? a.key < b.key : a.triangle < b.triangle;
  });

  DisjointSets vertex_sets(nv);
  std::vector<std::uint64_t> edge_keys;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j].key == edges[i].key) ++j;
    const std::size_t count = j - i;
    ++r.edges;
    edge_keys.push_back(edges[i].key);
    if (count == 1) ++r.boundary_edges;
    if (count > 2) ++r.nonmanifold_edges;
    if (count == 2 && edges[i].forward == edges[i + 1].forward) ++r.misoriented_edges;
    vertex_sets.join(static_cast<std::uint32_t>(edges[i].key >> 32),
                     static_cast<std::uint32_t>(edges[i].key & 0xffffffffu));
    i = j;
  }

  // Fans: around each vertex, triangles sharing an edge through the vertex are joined.
  std::vector<std::uint32_t> first(nv + 1, 0);
  for (std::uint32_t t = 0; t < nt; ++t) {
    const auto& tri = mesh.triangles[t];
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
    for (std::uint32_t v : tri) ++first[v + 1];
  }
  std::partial_sum(first.begin(), first.end(), first.begin());
  std::vector<std::uint32_t> incident(first[nv]);
  {
    std::vector<std::uint32_t> fill(first.begin(), first.end() - 1);
    for (std::uint32_t t = 0; t < nt; ++t) {
      const auto& tri = mesh.triangles[t];
      if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
      for (std::uint32_t v : tri) incident[fill[v]++] = t;
    }
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> spokes;  // (other vertex, local triangle)
  std::vector<std::uint32_t> local_parent;
  for (std::uint32_t v = 0; v < nv; ++v) {
    const std::uint32_t b = first[v], e = first[v + 1];
    if (e - b < 2) continue;
    spokes.clear();
    for (std::uint32_t i = b; i < e; ++i)
      for (std::uint32_t u : mesh.triangles[incident[i]])
        if (u != v) spokes.emplace_back(u, i - b);
    std::sort(spokes.begin(), spokes.end());
    local_parent.resize(e - b);
    std::iota(local_parent.begin(), local_parent.end(), 0u);
    auto find = [&](std::uint32_t x) {
      while (local_parent[x] != x) x = local_parent[x] = local_parent[local_parent[x]];
      return x;
    };
    for (std::size_t i = 1; i < spokes.size(); ++i)
      if (spokes[i].first == spokes[i - 1].first)
        local_parent[find(spokes[i].second)] = find(spokes[i - 1].second);
    std::uint32_t fans = 0;
    for (std::uint32_t i = 0; i < e - b; ++i) fans += find(i) == i;
    if (fans > 1) ++r.nonmanifold_vertices;
  }

  // Components and their Euler characteristics.
  std::vector<long> comp_v(nv, 0), comp_e(nv, 0), comp_f(nv, 0);
  for (std::uint32_t v = 0; v < nv; ++v)
    if (uses[v]) ++comp_v[vertex_sets.find(v)];
  for (std::uint64_t k : edge_keys) ++comp_e[vertex_sets.find(static_cast<std::uint32_t>(k >> 32))];
  for (std::uint32_t t = 0; t < nt; ++t) {
    const auto& tri = mesh.triangles[t];
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
    ++comp_f[vertex_sets.find(tri[0])];
  }
  std::vector<std::pair<long, long>> comps;  // (triangles, euler)
  for (std::uint32_t v = 0; v < nv; ++v)
    if (uses[v] && vertex_sets.find(v) == v)
      comps.emplace_back(comp_f[v], comp_v[v] - comp_e[v] + comp_f[v]);
  std::sort(comps.begin(), comps.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  r.components = comps.size();
  for (const auto& c : comps) {
    r.component_triangles.push_back(static_cast<std::size_t>(c.first));
    r.component_euler.push_back(c.second);
  }
  return r;
}

}  // namespace tsf::imt
