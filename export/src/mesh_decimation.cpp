#include "tsf/export/mesh_decimation.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <time.h>

#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"
#include "tsf/export/export_normals.h"
#include "tsf/export/mesh_cleanup.h"
#include "tsf/export/surface_deviation.h"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace tsf::exporter {

namespace {

using Tri = std::array<std::uint32_t, 3>;

/// Vertices and indices handed to meshoptimizer, with where each vertex came from.
struct Buffer {
  std::vector<float> xyz;              ///< 3 per vertex
  std::vector<std::uint32_t> id;       ///< the vertex's index in the buffer it was cut from
  std::vector<std::uint32_t> origin;   ///< input mesh vertex
  std::vector<std::uint32_t> part;     ///< the part (tissue, interface) of the vertex's copy
  std::vector<char> locked;            ///< must not move (see lock_copies)
  std::vector<std::uint32_t> indices;  ///< 3 per triangle

  std::size_t vertices() const { return origin.size(); }
  void add_vertex(const Vec3f& p, std::uint32_t from, std::uint32_t mesh_vertex,
                  std::uint32_t part_of) {
    xyz.insert(xyz.end(), {p.x, p.y, p.z});
    id.push_back(from);
    origin.push_back(mesh_vertex);
    part.push_back(part_of);
    locked.push_back(0);
  }
};

/// meshoptimizer's error target: relative to the mesh extent; "no bound" for a count target alone.
float relative_error(const DecimationOptions& o, float scale) {
  if (o.max_error_mm <= 0.0) return std::numeric_limits<float>::max();
  return static_cast<float>(o.max_error_mm / o.mm_per_unit /
                            static_cast<double>(std::max(scale, 1e-30f)));
}

std::size_t target_indices(std::size_t target_triangles, std::size_t triangles) {
  return target_triangles > 0 ? 3 * std::min(target_triangles, triangles) : 0;
}

/// The vertices `indices` (into `in`) use, renumbered in order of first use; `id` = index in `in`.
Buffer compact(const Buffer& in, const std::vector<std::uint32_t>& indices) {
  Buffer out;
  std::vector<std::uint32_t> index_of(in.vertices(), UINT32_MAX);
  out.indices.reserve(indices.size());
  for (std::uint32_t v : indices) {
    if (index_of[v] == UINT32_MAX) {
      index_of[v] = static_cast<std::uint32_t>(out.origin.size());
      out.add_vertex({in.xyz[3 * v], in.xyz[3 * v + 1], in.xyz[3 * v + 2]}, v, in.origin[v],
                     in.part[v]);
      out.locked.back() = in.locked[v];
    }
    out.indices.push_back(index_of[v]);
  }
  return out;
}

/// One meshoptimizer call; the result compacted (ids index `in`), meshopt's error (mm) raised.
/// Locked vertices: meshoptimizer 0.18 has no per-vertex lock, but it never moves a vertex with
/// three or more copies at its position (it cannot classify it: Kind_Locked), and it counts
/// copies over the whole vertex buffer, used or not. So each locked vertex gets two unused
/// copies appended to the buffer it sees.
Buffer simplify(const Buffer& in, std::size_t target_index_count, float error_rel, float scale,
                unsigned flags, double& error_mm) {
  std::vector<std::uint32_t> out(in.indices.size());
  float result_error = 0.0f;
  std::vector<float> locked_xyz;
  for (std::size_t v = 0; v < in.vertices(); ++v)
    if (in.locked[v])
      for (int copy = 0; copy < 2; ++copy)
        locked_xyz.insert(locked_xyz.end(), in.xyz.begin() + static_cast<std::ptrdiff_t>(3 * v),
                          in.xyz.begin() + static_cast<std::ptrdiff_t>(3 * v + 3));
  std::vector<float> with_copies;
  if (!locked_xyz.empty()) {
    with_copies = in.xyz;
    with_copies.insert(with_copies.end(), locked_xyz.begin(), locked_xyz.end());
  }
  const std::vector<float>& xyz = locked_xyz.empty() ? in.xyz : with_copies;
  const std::size_t n =
      meshopt_simplify(out.data(), in.indices.data(), in.indices.size(), xyz.data(), xyz.size() / 3,
                       3 * sizeof(float), target_index_count, error_rel, flags, &result_error);
  out.resize(n);
  // In the mesh's units here; run() converts to mm.
  error_mm = std::max(error_mm, static_cast<double>(result_error) * static_cast<double>(scale));
  return compact(in, out);
}

/// CPU time of the calling thread, s.
double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

int thread_count(int requested) {
#ifdef _OPENMP
  return requested > 0 ? requested : omp_get_max_threads();
#else
  (void)requested;
  return 1;
#endif
}

/// Slab cut of `in`'s triangles along its longest axis: per slab the triangle numbers.
std::vector<std::vector<std::uint32_t>> slab_triangles(const Buffer& in, int slabs) {
  const std::size_t triangles = in.indices.size() / 3;
  float lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::numeric_limits<float>::max();
    hi[k] = std::numeric_limits<float>::lowest();
  }
  for (std::size_t v = 0; v < in.vertices(); ++v)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], in.xyz[3 * v + k]);
      hi[k] = std::max(hi[k], in.xyz[3 * v + k]);
    }
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (hi[k] - lo[k] > hi[axis] - lo[axis]) axis = k;
  std::vector<float> centre(triangles);
  for (std::size_t t = 0; t < triangles; ++t)
    centre[t] = in.xyz[3 * in.indices[3 * t] + axis] + in.xyz[3 * in.indices[3 * t + 1] + axis] +
                in.xyz[3 * in.indices[3 * t + 2] + axis];
  std::vector<std::uint32_t> order(triangles);
  for (std::uint32_t t = 0; t < triangles; ++t) order[t] = t;
  std::vector<std::size_t> bounds(static_cast<std::size_t>(slabs) + 1);
  for (int s = 0; s <= slabs; ++s)
    bounds[static_cast<std::size_t>(s)] =
        triangles * static_cast<std::size_t>(s) / static_cast<std::size_t>(slabs);
  const auto by_centre = [&](std::uint32_t a, std::uint32_t b) { return centre[a] < centre[b]; };
  for (int s = 1; s < slabs; ++s)
    std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(bounds[s - 1]),
                     order.begin() + static_cast<std::ptrdiff_t>(bounds[s]), order.end(),
                     by_centre);
  std::vector<std::vector<std::uint32_t>> out(static_cast<std::size_t>(slabs));
  for (int s = 0; s < slabs; ++s)
    out[static_cast<std::size_t>(s)].assign(
        order.begin() + static_cast<std::ptrdiff_t>(bounds[s]),
        order.begin() + static_cast<std::ptrdiff_t>(bounds[s + 1]));
  return out;
}

/// Simplifies `in` once, in slabs on several threads when it is large (see the header); ids of
/// the result index `in`.
Buffer attempt(const Buffer& in, const DecimationOptions& o, DecimatedMesh& d) {
  const std::size_t triangles = in.indices.size() / 3;
  const float scale = meshopt_simplifyScale(in.xyz.data(), in.vertices(), 3 * sizeof(float));
  const float error_rel = relative_error(o, scale);
  const int threads = thread_count(o.threads);
  const bool split = threads > 1 && triangles >= o.parallel_min_triangles &&
                     (o.target_triangles == 0 || o.target_triangles < triangles / 4);
  d.slabs = 1;
  if (!split)
    return simplify(in, target_indices(o.target_triangles, triangles), error_rel, scale, 0,
                    d.meshopt_error_mm);
  const int slabs = threads;
  const auto cut = slab_triangles(in, slabs);
  std::vector<Buffer> parts(cut.size());
  std::vector<double> errors(cut.size(), 0.0), slab_cpu(cut.size(), 0.0);
#pragma omp parallel for num_threads(slabs) schedule(static, 1)
  for (int s = 0; s < slabs; ++s) {
    const double cpu0 = thread_cpu_seconds();
    const auto& tris = cut[static_cast<std::size_t>(s)];
    std::vector<std::uint32_t> indices;
    indices.reserve(3 * tris.size());
    for (std::uint32_t t : tris)
      for (int k = 0; k < 3; ++k) indices.push_back(in.indices[3 * t + k]);
    const Buffer local = compact(in, indices);
    const std::size_t target =
        o.target_triangles > 0
            ? std::max<std::size_t>(1, o.target_triangles * tris.size() / triangles)
            : 0;
    Buffer& part = parts[static_cast<std::size_t>(s)];
    part = simplify(local, target_indices(target, tris.size()), error_rel, scale,
                    meshopt_SimplifyLockBorder, errors[static_cast<std::size_t>(s)]);
    for (std::uint32_t& id : part.id) id = local.id[id];  // slab-local -> `in`
    slab_cpu[static_cast<std::size_t>(s)] = thread_cpu_seconds() - cpu0;
  }
  // Slab 0 ran on this thread (schedule static, 1), the others beside it: the critical path
  // has the longest slab where this thread's time has slab 0.
  d.critical_path_cpu_s += *std::max_element(slab_cpu.begin(), slab_cpu.end()) - slab_cpu[0];
  // Stitch, then simplify the whole once more, unlocked (the slab cuts go there).
  std::vector<std::uint32_t> merged;
  for (const Buffer& part : parts)
    for (std::uint32_t i : part.indices) merged.push_back(part.id[i]);
  const Buffer stitched = compact(in, merged);
  for (double e : errors) d.meshopt_error_mm = std::max(d.meshopt_error_mm, e);
  Buffer result =
      simplify(stitched, target_indices(o.target_triangles, stitched.indices.size() / 3), error_rel,
               scale, 0, d.meshopt_error_mm);
  for (std::uint32_t& id : result.id) id = stitched.id[id];  // stitched -> `in`
  d.slabs = slabs;
  return result;
}

/// Per vertex of `b`: one number per source vertex (one surface) or per source vertex and part
/// (parts that are surfaces of their own), so copies that are one vertex compare equal.
std::vector<std::uint32_t> vertex_keys(const Buffer& b, bool one_surface) {
  if (one_surface) return b.origin;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> source(b.vertices());
  for (std::uint32_t v = 0; v < source.size(); ++v)
    source[v] = {(static_cast<std::uint64_t>(b.part[v]) << 32) | b.origin[v], v};
  std::sort(source.begin(), source.end());
  std::vector<std::uint32_t> key(b.vertices());
  std::uint32_t next = 0;
  for (std::size_t i = 0; i < source.size(); ++i) {
    if (i > 0 && source[i].first != source[i - 1].first) ++next;
    key[source[i].second] = next;
  }
  return key;
}

/// Source vertices (origin) on edges that more than two triangles share, compared by `key`.
std::vector<std::uint32_t> nonmanifold_sources(const Buffer& b,
                                               const std::vector<std::uint32_t>& key) {
  std::vector<std::uint64_t> edges;
  edges.reserve(b.indices.size());
  for (std::size_t t = 0; t < b.indices.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      std::uint32_t u = key[b.indices[t + k]], v = key[b.indices[t + (k + 1) % 3]];
      if (u > v) std::swap(u, v);
      edges.push_back((static_cast<std::uint64_t>(u) << 32) | v);
    }
  std::sort(edges.begin(), edges.end());
  std::vector<std::uint32_t> vertex_of_key(
      key.empty() ? 0 : *std::max_element(key.begin(), key.end()) + 1u, 0);
  for (std::uint32_t v = 0; v < b.vertices(); ++v) vertex_of_key[key[v]] = v;
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i > 2)
      for (std::uint32_t k : {static_cast<std::uint32_t>(edges[i] >> 32),
                              static_cast<std::uint32_t>(edges[i] & 0xffffffffu)})
        out.push_back(b.origin[vertex_of_key[k]]);
    i = j;
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

/// Locks in `in` every copy of the source vertices `sources` (and of their neighbours in `in`).
void lock_around(Buffer& in, const std::vector<std::uint32_t>& sources, bool neighbours = true) {
  std::vector<char> hit(*std::max_element(in.origin.begin(), in.origin.end()) + 1u, 0);
  for (std::uint32_t s : sources)
    if (s < hit.size()) hit[s] = 1;
  if (!neighbours) {
    for (std::size_t v = 0; v < in.vertices(); ++v)
      if (hit[in.origin[v]]) in.locked[v] = 1;
    return;
  }
  std::vector<char> near(hit.size(), 0);
  for (std::size_t t = 0; t < in.indices.size(); t += 3) {
    bool touches = false;
    for (int k = 0; k < 3; ++k) touches |= hit[in.origin[in.indices[t + k]]] != 0;
    if (touches)
      for (int k = 0; k < 3; ++k) near[in.origin[in.indices[t + k]]] = 1;
  }
  for (std::size_t v = 0; v < in.vertices(); ++v)
    if (near[in.origin[v]]) in.locked[v] = 1;
}

/// Locks the closed pieces too small for the budget: a component whose share of the target
/// would be under `min_triangles` keeps all its triangles (meshoptimizer would squash it to
/// nothing, and its surface would be missing from the result).
void lock_small_components(Buffer& in, std::size_t target_triangles, std::size_t min_triangles) {
  const std::size_t triangles = in.indices.size() / 3;
  if (target_triangles == 0 || target_triangles >= triangles) return;
  const std::size_t sources = *std::max_element(in.origin.begin(), in.origin.end()) + 1u;
  std::vector<std::uint32_t> parent(sources);
  for (std::uint32_t v = 0; v < sources; ++v) parent[v] = v;
  const auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (std::size_t t = 0; t < in.indices.size(); t += 3) {
    const std::uint32_t a = find(in.origin[in.indices[t]]);
    for (int k = 1; k < 3; ++k) parent[find(in.origin[in.indices[t + k]])] = a;
  }
  std::vector<std::uint32_t> count(sources, 0);
  for (std::size_t t = 0; t < in.indices.size(); t += 3) ++count[find(in.origin[in.indices[t]])];
  for (std::size_t v = 0; v < in.vertices(); ++v) {
    const std::size_t n = count[find(in.origin[v])];
    if (static_cast<double>(n) * static_cast<double>(target_triangles) /
            static_cast<double>(triangles) <
        static_cast<double>(min_triangles))
      in.locked[v] = 1;
  }
}

/// meshoptimizer can fold two triangles onto each other (a zero-volume fin on an edge, which
/// then has four triangles; what a thin plate collapses to) and leave collinear triangles: drop
/// fins and exact duplicates (compared by source vertex, and part when parts are surfaces of
/// their own), flip caps.
void repair(Buffer& result, bool one_surface, DecimatedMesh& d) {
  {
    std::vector<std::array<std::uint32_t, 3>> tris(result.indices.size() / 3);
    for (std::size_t t = 0; t < tris.size(); ++t)
      tris[t] = {result.indices[3 * t], result.indices[3 * t + 1], result.indices[3 * t + 2]};
    const DuplicateRemoval removed =
        drop_duplicate_triangles(tris, vertex_keys(result, one_surface));
    std::vector<Vec3f> positions(result.vertices());
    for (std::size_t v = 0; v < positions.size(); ++v)
      positions[v] = {result.xyz[3 * v], result.xyz[3 * v + 1], result.xyz[3 * v + 2]};
    const CapRemoval caps = flip_caps(tris, positions);
    d.fins_removed = removed.fins + removed.duplicates;
    d.caps_flipped = caps.flipped;
    d.caps_removed = caps.removed;
    if (d.fins_removed + caps.flipped + caps.removed > 0) {
      std::vector<std::uint32_t> indices;
      for (const auto& t : tris) indices.insert(indices.end(), t.begin(), t.end());
      result = compact(result, indices);
    }
  }
}

/// Decimates `in` (ids index the caller's vertices): small pieces locked, meshoptimizer, then
/// the repairs meshoptimizer 0.18 needs (see the header); the result's `origin`/`labels` are
/// `in`'s.
DecimatedMesh run(Buffer in, const DecimationOptions& o, bool one_surface, Stopwatch clock) {
  DecimatedMesh d;
  lock_small_components(in, o.target_triangles, 48);
  if (!o.locked_sources.empty()) lock_around(in, o.locked_sources);
  Buffer result;
  const int runs = std::max(o.manifold_runs, o.max_error_mm > 0.0 ? o.error_runs : 1);
  for (int round = 0;; ++round) {
    d.meshopt_error_mm = 0.0;
    result = attempt(in, o, d);
    repair(result, one_surface, d);
    d.rounds = round + 1;
    if (round + 1 >= runs) break;
    bool again = false;
    // Measured error bound: the input vertices farther than max_error from the result are kept
    // in the next run (a kept vertex is on the result, distance 0).
    if (o.max_error_mm > 0.0 && round + 1 < o.error_runs) {
      std::vector<Vec3f> points(in.vertices()), result_points(result.vertices());
      for (std::size_t v = 0; v < points.size(); ++v)
        points[v] = {in.xyz[3 * v], in.xyz[3 * v + 1], in.xyz[3 * v + 2]};
      for (std::size_t v = 0; v < result_points.size(); ++v)
        result_points[v] = {result.xyz[3 * v], result.xyz[3 * v + 1], result.xyz[3 * v + 2]};
      std::vector<std::array<std::uint32_t, 3>> tris(result.indices.size() / 3);
      for (std::size_t t = 0; t < tris.size(); ++t)
        tris[t] = {result.indices[3 * t], result.indices[3 * t + 1], result.indices[3 * t + 2]};
      const std::vector<double> dist = distances_to_surface({&result_points, &tris}, points);
      // A far vertex that was kept already lost its triangles (a collapse around it, or a fold
      // dropped as a fin): keep its neighbours too.
      std::vector<std::uint32_t> far, far_kept;
      const double bound = o.max_error_mm / o.mm_per_unit;
      for (std::size_t v = 0; v < dist.size(); ++v)
        if (dist[v] > bound) (in.locked[v] ? far_kept : far).push_back(in.origin[v]);
      d.error_locked += far.size();
      if (!far.empty()) lock_around(in, far, false);
      if (!far_kept.empty()) lock_around(in, far_kept, true);
      again = !far.empty() || !far_kept.empty();
    }
    if (round + 1 < o.manifold_runs) {
      const std::vector<std::uint32_t> bad =
          nonmanifold_sources(result, vertex_keys(result, one_surface));
      if (!bad.empty()) {
        lock_around(in, bad);  // and again, keeping meshoptimizer away from there
        again = true;
      }
    }
    if (!again) break;
  }
  d.meshopt_error_mm *= o.mm_per_unit;
  d.nonmanifold_vertices = nonmanifold_sources(result, vertex_keys(result, one_surface)).size();
  for (std::size_t v = 0; v < in.vertices(); ++v) d.locked_vertices += in.locked[v] != 0;
  d.one_surface = one_surface;
  d.origin = std::move(result.origin);
  d.part = std::move(result.part);
  d.labels.resize(d.part.size());
  for (std::size_t v = 0; v < d.part.size(); ++v)
    d.labels[v] = static_cast<std::uint8_t>(d.part[v]);
  d.triangles.resize(result.indices.size() / 3);
  for (std::size_t t = 0; t < d.triangles.size(); ++t)
    d.triangles[t] = {result.indices[3 * t], result.indices[3 * t + 1], result.indices[3 * t + 2]};
  d.seconds = clock.seconds();
  return d;
}

}  // namespace

void DecimationOptions::validate() const {
  require(target_triangles > 0 || max_error_mm > 0.0,
          "decimation needs a triangle count (--decimate N) or a maximum error (--max-error MM)");
  require(std::isfinite(max_error_mm) && max_error_mm >= 0.0,
          "maximum error " + std::to_string(max_error_mm) + " mm must be finite and positive");
  require(threads >= 0, "decimation threads must be 0 (all) or more");
  require(manifold_runs >= 1 && error_runs >= 1, "decimation: runs must be 1 or more");
  require(std::isfinite(mm_per_unit) && mm_per_unit > 0.0, "decimation: mm per unit must be > 0");
}

DecimatedMesh decimate_parts(const std::vector<Vec3f>& positions,
                             const std::vector<std::array<std::uint32_t, 3>>& triangles,
                             const std::vector<std::uint32_t>& triangle_part,
                             const DecimationOptions& options, bool one_surface) {
  Stopwatch clock;
  const double cpu0 = thread_cpu_seconds();
  options.validate();
  require(triangle_part.size() == triangles.size(), "decimate_parts: a part per triangle");
  // One copy of each vertex per part of its triangles: part borders become seams. Triangles in
  // part order (a counting sort: parts are small numbers).
  const std::uint32_t parts =
      triangle_part.empty() ? 0 : *std::max_element(triangle_part.begin(), triangle_part.end()) + 1;
  std::vector<std::uint32_t> start(static_cast<std::size_t>(parts) + 1, 0);
  for (std::uint32_t p : triangle_part) ++start[p + 1];
  for (std::size_t p = 0; p < parts; ++p) start[p + 1] += start[p];
  std::vector<std::uint32_t> order(triangles.size());
  for (std::uint32_t t = 0; t < order.size(); ++t) order[start[triangle_part[t]]++] = t;
  Buffer in;
  in.indices.reserve(3 * triangles.size());
  std::vector<std::uint32_t> copy_of(positions.size(), UINT32_MAX);
  std::vector<std::uint32_t> touched;
  for (std::size_t i = 0; i < order.size(); ++i) {
    const std::uint32_t part = triangle_part[order[i]];
    if (i > 0 && part != triangle_part[order[i - 1]]) {
      for (std::uint32_t v : touched) copy_of[v] = UINT32_MAX;
      touched.clear();
    }
    for (std::uint32_t v : triangles[order[i]]) {
      if (copy_of[v] == UINT32_MAX) {
        copy_of[v] = static_cast<std::uint32_t>(in.vertices());
        in.add_vertex(positions[v], copy_of[v], v, part);
        touched.push_back(v);
      }
      in.indices.push_back(copy_of[v]);
    }
  }
  DecimatedMesh d = run(std::move(in), options, one_surface, clock);
  d.critical_path_cpu_s += thread_cpu_seconds() - cpu0;
  return d;
}

DecimatedMesh decimate(const imt::SurfaceMesh& mesh, const DecimationOptions& options) {
  std::vector<std::uint32_t> part(mesh.triangles.size(), 0);
  if (options.keep_tissue_borders)
    for (std::size_t t = 0; t < part.size(); ++t) part[t] = imt::triangle_label(mesh, t);
  DecimatedMesh d = decimate_parts(mesh.positions, mesh.triangles, part, options, true);
  if (!options.keep_tissue_borders)
    for (std::size_t v = 0; v < d.origin.size(); ++v) d.labels[v] = mesh.labels[d.origin[v]];
  return d;
}

DecimatedMesh decimate_further(const imt::SurfaceMesh& mesh, const DecimatedMesh& level,
                               const DecimationOptions& options) {
  Stopwatch clock;
  const double cpu0 = thread_cpu_seconds();
  options.validate();
  Buffer in;
  for (std::uint32_t v = 0; v < level.origin.size(); ++v)
    in.add_vertex(mesh.positions[level.origin[v]], v, level.origin[v],
                  level.part.empty() ? level.labels[v] : level.part[v]);
  for (const auto& t : level.triangles) in.indices.insert(in.indices.end(), t.begin(), t.end());
  DecimatedMesh d = run(std::move(in), options, level.one_surface, clock);
  d.critical_path_cpu_s += thread_cpu_seconds() - cpu0;
  return d;
}

imt::SurfaceMesh decimated_surface(const imt::SurfaceMesh& mesh, const DecimatedMesh& d) {
  imt::SurfaceMesh out;
  out.positions = gather(mesh.positions, d.origin);
  out.labels = d.labels;
  out.triangles = d.triangles;
  out.normals = area_weighted_normals(out.positions, out.triangles, d.origin);
  return out;
}

}  // namespace tsf::exporter
