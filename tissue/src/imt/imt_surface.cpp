#include "tsf/imt/imt_surface.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include <omp.h>

#include "lattice_window.h"
#include "surface_internals.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"

namespace tsf::imt {

using detail::CubeGrid;
using detail::LatticeWindow;
using detail::NormalSum;

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
constexpr std::uint64_t kNoKey = std::numeric_limits<std::uint64_t>::max();
constexpr int kPageEdge = 8;  // cubes per record page edge
constexpr int kPageCubes = kPageEdge * kPageEdge * kPageEdge;
constexpr int kChunk = 32;  // cubes per window edge when re-meshing a large region
/// Batches of at least this many chunks make their vertices and refresh plans ahead on the
/// threads; smaller ones only their windows (on 2 cores, working ahead on 2 chunks was slower).
constexpr std::int64_t kAheadChunks = 4;

// Change-tracking bits (per slot, since the last take_changes()).
constexpr std::uint8_t kTouched = 1, kWasLive = 2, kModified = 4, kNormal = 8;

constexpr std::uint32_t kNoSignature = 0xFFFFFFFFu;  // signatures use 24 bits

struct CubeRecord {
  std::uint32_t vertex[kSlotsPerCube];  // vertex slot per lattice slot, 0 = none
  std::uint32_t first_triangle;         // head of the cube's triangle list, kNone = empty
  std::uint32_t signature;              // LatticeWindow::signature its triangles were made from
};

}  // namespace

struct ImtSurface::State {
  SurfaceOptions options;
  double headroom = 0.5;
  bool built = false;
  VolumeGeometry geometry;
  CubeGrid grid{Int3{0, 0, 0}};
  Int3 pages{0, 0, 0};
  double normal_scale = 1.0;

  // Vertices (SoA, size = capacity).
  std::vector<Vec3f> positions, normals;
  std::vector<std::uint8_t> labels;
  std::vector<std::uint32_t> refcount;
  std::vector<std::uint64_t> key;
  std::vector<NormalSum> normal_sum;
  std::vector<std::uint32_t> stamp;
  std::vector<std::uint8_t> vchange;
  std::vector<std::uint8_t> live;  // 1 while the slot holds a vertex (compact: hot in cache)
  std::uint32_t vertex_slots = 1;  // slot 0: sentinel
  std::vector<std::uint32_t> free_vertices;

  // Triangles.
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint32_t> next_triangle;
  std::vector<std::uint8_t> tchange;
  std::uint32_t triangle_slots = 0;
  std::vector<std::uint32_t> free_triangles;

  // Cube records: page per 8³ cubes, record per cube that owns vertices or triangles.
  std::vector<std::uint32_t> page_of;  // per page cell: 0 = none, else page index + 1
  std::vector<std::array<std::uint32_t, kPageCubes>> page_records;  // record id, 0 = none
  std::vector<CubeRecord> records{CubeRecord{}};                    // record 0 unused
  std::vector<std::uint32_t> free_records;

  // Changes and scratch.
  std::vector<std::uint32_t> touched_vertices, touched_triangles;
  bool reallocated = false;
  std::uint32_t generation = 0;
  std::vector<std::uint32_t> released_vertices, normal_dirty;
  std::vector<Int3> released_cubes;
  std::vector<std::uint8_t> normal_dirty_flag;
  /// A vertex of an unchanged cube's triangles as its chunk's window makes it now: `moved` when
  /// that differs from the vertex's position or label.
  struct Refresh {
    std::uint32_t vertex;
    Vec3f position;
    std::uint8_t label;
    bool moved;
  };
  /// What a chunk's unchanged cubes need, worked out with its window: per relevant cube, whether
  /// it keeps its triangles and lies in the core (then its vertices are refreshed), and those
  /// vertices in the order the cube's triangles first use them.
  struct ChunkPlan {
    bool ready = false;                   // made ahead (a batch of several chunks)
    std::vector<std::uint8_t> refreshed;  // per relevant cube
    std::vector<std::uint32_t> first;     // per relevant cube + 1: its range in `refreshes`
    std::vector<Refresh> refreshes;
    std::vector<std::uint32_t> planned;  // open-addressing set of the vertices planned so far
  };
  /// A chunk's window and plan, one allocation per chunk of a batch (computed in parallel: no
  /// two threads write to one cache line).
  /// The vertices of a chunk's own cubes in the core (where vertices can move), made with its
  /// window: per cube of [c0, c1) the slots made and where the first one is.
  struct VertexTable {
    Int3 c0{0, 0, 0}, c1{0, 0, 0};
    std::vector<std::uint16_t> made;
    std::vector<std::uint32_t> first;
    std::vector<Vec3f> positions;
    std::vector<std::uint8_t> labels;

    /// The vertex in slot `slot` of cube o, if this table made it.
    bool find(const Int3& o, int slot, Vec3f& p, std::uint8_t& label) const {
      if (o.x < c0.x || o.y < c0.y || o.z < c0.z || o.x >= c1.x || o.y >= c1.y || o.z >= c1.z)
        return false;
      const std::size_t i =
          static_cast<std::size_t>(o.x - c0.x) +
          static_cast<std::size_t>(c1.x - c0.x) *
              (static_cast<std::size_t>(o.y - c0.y) +
               static_cast<std::size_t>(c1.y - c0.y) * static_cast<std::size_t>(o.z - c0.z));
      const unsigned m = made[i];
      if (!((m >> slot) & 1u)) return false;
      const std::size_t at =
          first[i] + static_cast<std::size_t>(__builtin_popcount(m & ((1u << slot) - 1u)));
      p = positions[at];
      label = labels[at];
      return true;
    }
  };
  struct ChunkWork {
    LatticeWindow window;
    ChunkPlan plan;
    VertexTable table;
    bool meshed = false;  // the chunk can hold surface: window, plan and table are current
  };
  std::vector<std::unique_ptr<ChunkWork>> chunk_work;
  std::size_t batch_size = 0;             // chunks of chunk_work in the batch being meshed
  const LatticeWindow* window = nullptr;  // the one being meshed
  const ChunkWork* work = nullptr;        // its chunk
  SurfaceUpdateStats stats;

  // ---- capacity ---------------------------------------------------------------------------------
  void resize_vertices(std::size_t capacity) {
    positions.resize(capacity);
    normals.resize(capacity);
    labels.resize(capacity, 0);
    refcount.resize(capacity, 0);
    key.resize(capacity, kNoKey);
    normal_sum.resize(capacity);
    stamp.resize(capacity, 0);
    vchange.resize(capacity, 0);
    live.resize(capacity, 0);
    normal_dirty_flag.resize(capacity, 0);
    pending.resize(capacity, 0);
  }
  void resize_triangles(std::size_t capacity) {
    triangles.resize(capacity, {0, 0, 0});
    next_triangle.resize(capacity, kNone);
    tchange.resize(capacity, 0);
  }
  static std::size_t grown(std::size_t needed) { return needed + needed / 2 + 1024; }

  // ---- change tracking --------------------------------------------------------------------------
  bool vertex_live(std::uint32_t v) const { return live[v] != 0; }
  void touch_vertex(std::uint32_t v, std::uint8_t bits) {
    if (!(vchange[v] & kTouched)) {
      vchange[v] = static_cast<std::uint8_t>(kTouched | (vertex_live(v) ? kWasLive : 0));
      touched_vertices.push_back(v);
    }
    vchange[v] = static_cast<std::uint8_t>(vchange[v] | bits);
  }
  void touch_triangle(std::uint32_t t) {
    if (!(tchange[t] & kTouched)) {
      tchange[t] = static_cast<std::uint8_t>(kTouched | (triangles[t][0] != 0 ? kWasLive : 0));
      touched_triangles.push_back(t);
    }
  }
  void mark_normal_dirty(std::uint32_t v) {
    if (!normal_dirty_flag[v]) {
      normal_dirty_flag[v] = 1;
      normal_dirty.push_back(v);
    }
  }

  // ---- records ----------------------------------------------------------------------------------
  // u = c + 1 >= 0 always: unsigned shifts and masks (kPageEdge = 8).
  std::size_t page_cell(const Int3& u) const {
    const auto x = static_cast<unsigned>(u.x) >> 3, y = static_cast<unsigned>(u.y) >> 3,
               z = static_cast<unsigned>(u.z) >> 3;
    return x + static_cast<std::size_t>(pages.x) *
                   (y + static_cast<std::size_t>(pages.y) * static_cast<std::size_t>(z));
  }
  static int page_local(const Int3& u) {
    const auto x = static_cast<unsigned>(u.x) & 7u, y = static_cast<unsigned>(u.y) & 7u,
               z = static_cast<unsigned>(u.z) & 7u;
    return static_cast<int>(x + 8u * (y + 8u * z));
  }
  /// Record id of cube c, 0 when it has none (read only: safe on several threads).
  std::uint32_t find_record(const Int3& c) const {
    const Int3 u{c.x + 1, c.y + 1, c.z + 1};
    const std::uint32_t page = page_of[page_cell(u)];
    return page == 0 ? 0 : page_records[page - 1][static_cast<std::size_t>(page_local(u))];
  }
  /// Record id of cube c (0 when it has none and `create` is false).
  std::uint32_t record_of(const Int3& c, bool create) {
    const Int3 u{c.x + 1, c.y + 1, c.z + 1};
    std::uint32_t& page = page_of[page_cell(u)];
    if (page == 0) {
      if (!create) return 0;
      page_records.emplace_back();
      page_records.back().fill(0);
      page = static_cast<std::uint32_t>(page_records.size());
    }
    std::uint32_t& rid = page_records[page - 1][static_cast<std::size_t>(page_local(u))];
    if (rid == 0 && create) {
      if (!free_records.empty()) {
        rid = free_records.back();
        free_records.pop_back();
      } else {
        records.emplace_back();
        rid = static_cast<std::uint32_t>(records.size() - 1);
      }
      CubeRecord& r = records[rid];
      std::fill(std::begin(r.vertex), std::end(r.vertex), 0u);
      r.first_triangle = kNone;
      r.signature = kNoSignature;
    }
    return rid;
  }
  void release_record_if_empty(const Int3& c) {
    const Int3 u{c.x + 1, c.y + 1, c.z + 1};
    const std::uint32_t page = page_of[page_cell(u)];
    if (page == 0) return;
    std::uint32_t& rid = page_records[page - 1][static_cast<std::size_t>(page_local(u))];
    if (rid == 0) return;
    const CubeRecord& r = records[rid];
    if (r.first_triangle != kNone) return;
    for (std::uint32_t v : r.vertex)
      if (v != 0) return;
    free_records.push_back(rid);
    rid = 0;
  }

  // ---- slots ------------------------------------------------------------------------------------
  std::uint32_t allocate_vertex() {
    std::uint32_t v;
    if (!free_vertices.empty()) {
      v = free_vertices.back();
      free_vertices.pop_back();
    } else {
      if (vertex_slots == positions.size()) {
        resize_vertices(grown(vertex_slots));
        reallocated = true;
      }
      v = vertex_slots++;
    }
    return v;
  }
  std::uint32_t allocate_triangle() {
    std::uint32_t t;
    if (!free_triangles.empty()) {
      t = free_triangles.back();
      free_triangles.pop_back();
    } else {
      if (triangle_slots == triangles.size()) {
        resize_triangles(grown(triangle_slots));
        reallocated = true;
      }
      t = triangle_slots++;
    }
    return t;
  }
  void free_vertex(std::uint32_t v) {
    touch_vertex(v, 0);
    const std::uint64_t k = key[v];
    const Int3 c = grid.cube(k / kSlotsPerCube);
    const std::uint32_t rid = record_of(c, false);
    if (rid != 0) records[rid].vertex[k % kSlotsPerCube] = 0;
    release_record_if_empty(c);
    key[v] = kNoKey;
    live[v] = 0;
    normal_sum[v] = {};
    normals[v] = {};
    free_vertices.push_back(v);
    ++stats.vertices_freed;
  }

  NormalSum face_sum(const std::array<std::uint32_t, 3>& t) const {
    return detail::face_normal_sum(positions[t[0]], positions[t[1]], positions[t[2]], normal_scale);
  }

  /// Releases every triangle of record `rid`.
  void release_triangles(std::uint32_t rid) {
    std::uint32_t t = records[rid].first_triangle;
    while (t != kNone) {
      const std::uint32_t next = next_triangle[t];
      const NormalSum n = face_sum(triangles[t]);
      for (std::uint32_t v : triangles[t]) {
        normal_sum[v] -= n;
        mark_normal_dirty(v);
        if (--refcount[v] == 0) released_vertices.push_back(v);
      }
      touch_triangle(t);
      triangles[t] = {0, 0, 0};
      next_triangle[t] = kNone;
      free_triangles.push_back(t);
      ++stats.triangles_released;
      t = next;
    }
    records[rid].first_triangle = kNone;
  }

  /// Position and label of the vertex in slot `slot` of cube `o`: from the table of the batch's
  /// chunk that owns o when it made it (the current chunk first), else from the current window
  /// (every window makes a vertex alike: the merging decisions they hold agree).
  void made_vertex(const Int3& o, int slot, Vec3f& p, std::uint8_t& label) const {
    if (work->table.find(o, slot, p, label)) return;
    for (std::size_t b = 0; b < batch_size; ++b) {
      const ChunkWork& other = *chunk_work[b];
      if (&other != work && other.meshed && other.table.find(o, slot, p, label)) return;
    }
    Vec3d ip;
    window->vertex(o, window->local_index(o), slot, ip, label);
    p = detail::tissue_position(geometry, ip);
  }

  /// The vertex for lattice slot `slot` of cube `o`: made from the current window when new;
  /// refreshed once per update otherwise, a changed position or label going to `moved` (applied
  /// after the old normal contributions are taken off).
  std::uint32_t vertex_for(const Int3& o, int slot) {
    const std::uint32_t rid = record_of(o, true);
    std::uint32_t v = records[rid].vertex[slot];
    if (v != 0 && stamp[v] == generation) return v;
    Vec3f p;
    std::uint8_t label = 0;
    made_vertex(o, slot, p, label);
    if (v == 0) {
      v = allocate_vertex();
      touch_vertex(v, kModified);
      records[rid].vertex[slot] = v;
      key[v] = grid.key(o, slot);
      live[v] = 1;
      positions[v] = p;
      labels[v] = label;
      refcount[v] = 0;
      normal_sum[v] = {};
      created.push_back(v);
      ++stats.vertices_made;
    } else if (!(positions[v] == p) || labels[v] != label) {
      moved.push_back({v, p, label});
      pending[v] = 1;
      ++stats.vertices_moved;
    }
    stamp[v] = generation;
    return v;
  }

  /// Takes triangle t's normal contribution off (or puts it on) its vertices.
  void add_normal(std::uint32_t t, bool add) {
    const NormalSum n = face_sum(triangles[t]);
    for (std::uint32_t v : triangles[t]) {
      if (add)
        normal_sum[v] += n;
      else
        normal_sum[v] -= n;
      mark_normal_dirty(v);
    }
  }

  /// A new triangle of record rid (appended to its list's head).
  void make_triangle(std::uint32_t rid, const std::array<std::uint32_t, 3>& ids) {
    const std::uint32_t t = allocate_triangle();
    touch_triangle(t);
    triangles[t] = ids;
    next_triangle[t] = records[rid].first_triangle;
    records[rid].first_triangle = t;
    for (std::uint32_t v : ids) ++refcount[v];
    add_normal(t, true);
    ++stats.triangles_made;
  }

  /// vertex_for through a cache local to one owner cube: its triangles share most vertices.
  /// Keys are packed (offset + 1 per axis, 2 bits each; slot, 4 bits) into 10 bits.
  std::uint32_t cube_cache_stamp = 0;
  std::array<std::uint32_t, 1024> cube_cache_stamps{};
  std::array<std::uint32_t, 1024> cube_cache_ids{};
  void begin_cube() {
    if (++cube_cache_stamp == 0) {
      cube_cache_stamps.fill(0);
      cube_cache_stamp = 1;
    }
  }
  std::uint32_t cube_vertex(const Int3& c, const LatticeRef& k) {
    const unsigned packed =
        static_cast<unsigned>(k.offset[0] + 1) | (static_cast<unsigned>(k.offset[1] + 1) << 2) |
        (static_cast<unsigned>(k.offset[2] + 1) << 4) | (static_cast<unsigned>(k.slot) << 6);
    if (cube_cache_stamps[packed] == cube_cache_stamp) return cube_cache_ids[packed];
    const std::uint32_t v =
        vertex_for({c.x + k.offset[0], c.y + k.offset[1], c.z + k.offset[2]}, k.slot);
    cube_cache_stamps[packed] = cube_cache_stamp;
    cube_cache_ids[packed] = v;
    return v;
  }

  // Per-update scratch.
  struct Moved {
    std::uint32_t vertex;
    Vec3f position;
    std::uint8_t label;
  };
  struct ChangedCube {
    Int3 c;
    std::uint32_t first, count;  // new triangles in new_triangles
    std::uint32_t signature;
  };
  std::vector<std::uint32_t> created;
  std::vector<Moved> moved;
  std::vector<ChangedCube> changed_cubes;
  std::vector<std::array<std::uint32_t, 3>> new_triangles;
  std::vector<std::uint32_t> kept_records, readd;
  std::vector<std::uint32_t> record_stamp;  // per record: generation when last visited
  std::vector<std::uint8_t> pending;        // per vertex slot: moved in this update

  /// Owner cubes whose tetrahedra can see a changed value or a changed merging decision (`changed`
  /// inside the volume): the changed samples touch cubes [lo − 1, hi − 1] and their centres; a
  /// tetrahedron of cube c spans cubes c − 1 .. c; merging decisions look two lattice steps (one
  /// cube) further each way.
  VoxelBox update_region(const VoxelBox& changed) const {
    const int margin = LatticeWindow::margin(options.snap_epsilon > 0.0f);
    return changed.dilated(margin, margin)
        .intersected({{-1, -1, -1}, {grid.size.x - 1, grid.size.y - 1, grid.size.z - 1}});
  }

  // ---- update passes (ImtSurface::update runs them in this order) ---------------------------
  /// Starts an update: a new generation (stamps of older ones go stale) and empty scratch.
  void begin_update();
  /// Pass 1. Reads the volume over `region` (owner cubes) chunk by chunk and the cube records;
  /// writes changed_cubes and new_triangles (cubes whose triangles change, with their new ones),
  /// kept_records (unchanged cubes in `core` with a moved vertex), and through vertex_for
  /// created and moved. `margin`: how far, in cubes, a chunk's lattice window reaches
  /// (LatticeWindow::margin).
  void remesh_region(const VoxelVolume& volume, const VoxelBox& region, const VoxelBox& core,
                     int margin);
  bool refreshes_cube(const LatticeWindow& w, const LatticeWindow::Cube& cube,
                      const VoxelBox& core) const;
  template <typename Needs>
  void plan_cube(const LatticeWindow& w, const VertexTable& table, const LatticeWindow::Cube& cube,
                 std::vector<Refresh>& out, Needs&& needs) const;
  void plan_chunk(const LatticeWindow& w, const VertexTable& table, const VoxelBox& core,
                  ChunkPlan& plan) const;
  std::vector<Refresh> cube_refreshes;  // scratch: one cube's plan, made as it is meshed
  void make_chunk_vertices(const LatticeWindow& w, const Int3& c0, const Int3& c1,
                           const VoxelBox& near, VertexTable& table) const;
  void remesh_cube(const LatticeWindow::Cube& cube, const ChunkPlan& plan, std::size_t index,
                   const VoxelBox& core);
  void collect_emptied_cubes(const Int3& c0, const Int3& c1);
  void collect_emptied_cubes_in_page(std::uint32_t page, const Int3& p, const VoxelBox& chunk);
  /// Pass 2. Reads changed_cubes and kept_records, with the old positions; releases the changed
  /// cubes' triangles (released_cubes, released_vertices) and takes the kept triangles' normal
  /// contributions off (readd).
  void take_off_changed_normals();
  /// Pass 3. Reads moved, readd, changed_cubes and new_triangles; writes the new positions and
  /// labels, puts the kept contributions back and makes the new triangles.
  void move_vertices_and_make_triangles();
  /// Pass 4. Reads released_vertices, created and released_cubes; frees the vertices no triangle
  /// uses and the records left empty.
  void free_unused_vertices();
  /// Pass 5. Reads normal_dirty and the normal sums; writes the normals that changed.
  void refresh_dirty_normals();
};

ImtSurface::ImtSurface(const SurfaceOptions& options, double headroom)
    : s_(std::make_unique<State>()) {
  options.validate();
  require(std::isfinite(headroom) && headroom >= 0.0 && headroom <= 16.0,
          "ImtSurface headroom must lie in [0, 16], got " + std::to_string(headroom));
  s_->options = options;
  s_->headroom = headroom;
}
ImtSurface::~ImtSurface() = default;
ImtSurface::ImtSurface(ImtSurface&&) noexcept = default;
ImtSurface& ImtSurface::operator=(ImtSurface&&) noexcept = default;

const SurfaceOptions& ImtSurface::options() const {
  return s_->options;
}
bool ImtSurface::built() const {
  return s_->built;
}

void ImtSurface::build(const VoxelVolume& volume) {
  State& s = *s_;
  detail::ExtractionExtras extras;
  SurfaceMesh mesh = detail::extract_surface_detailed(volume, s.options, nullptr, true, &extras);
  const Int3 dims = volume.dims();

  State fresh;
  fresh.options = s.options;
  fresh.headroom = s.headroom;
  fresh.built = true;
  fresh.geometry = volume.geometry();
  fresh.grid = CubeGrid(dims);
  fresh.pages = {(fresh.grid.size.x + kPageEdge - 1) / kPageEdge,
                 (fresh.grid.size.y + kPageEdge - 1) / kPageEdge,
                 (fresh.grid.size.z + kPageEdge - 1) / kPageEdge};
  fresh.page_of.assign(static_cast<std::size_t>(fresh.pages.volume()), 0);
  fresh.normal_scale = detail::normal_scale(fresh.geometry);

  const std::size_t nv = mesh.vertex_count(), nt = mesh.triangle_count();
  fresh.resize_vertices(static_cast<std::size_t>(static_cast<double>(nv + 1) * (1.0 + s.headroom)) +
                        1024);
  fresh.resize_triangles(static_cast<std::size_t>(static_cast<double>(nt) * (1.0 + s.headroom)) +
                         1024);
  fresh.positions[0] = to_float(fresh.geometry.origin);  // the sentinel
  fresh.normals[0] = {};
  for (std::size_t v = 0; v < nv; ++v) {
    const auto slot = static_cast<std::uint32_t>(v + 1);
    fresh.positions[slot] = mesh.positions[v];
    fresh.normals[slot] = mesh.normals[v];
    fresh.labels[slot] = mesh.labels[v];
    fresh.key[slot] = extras.vertex_keys[v];
    fresh.live[slot] = 1;
    fresh.normal_sum[slot] = extras.normal_sums[v];
    const std::uint64_t k = extras.vertex_keys[v];
    const std::uint32_t rid = fresh.record_of(fresh.grid.cube(k / kSlotsPerCube), true);
    fresh.records[rid].vertex[k % kSlotsPerCube] = slot;
  }
  fresh.vertex_slots = static_cast<std::uint32_t>(nv + 1);
  for (std::size_t t = 0; t < nt; ++t) {
    std::array<std::uint32_t, 3> tri{};
    for (int k = 0; k < 3; ++k) {
      tri[static_cast<std::size_t>(k)] = mesh.triangles[t][static_cast<std::size_t>(k)] + 1;
      ++fresh.refcount[tri[static_cast<std::size_t>(k)]];
    }
    fresh.triangles[t] = tri;
    const std::uint32_t rid = fresh.record_of(fresh.grid.cube(extras.triangle_owner[t]), true);
    fresh.next_triangle[t] = fresh.records[rid].first_triangle;
    fresh.records[rid].first_triangle = static_cast<std::uint32_t>(t);
    fresh.records[rid].signature = extras.triangle_owner_signature[t];
  }
  fresh.triangle_slots = static_cast<std::uint32_t>(nt);
  fresh.reallocated = true;
  *s_ = std::move(fresh);
}

void ImtSurface::State::begin_update() {
  ++generation;
  if (generation == 0) {  // wrapped: stale stamps could alias
    std::fill(stamp.begin(), stamp.end(), 0u);
    std::fill(record_stamp.begin(), record_stamp.end(), 0u);
    generation = 1;
  }
  created.clear();
  moved.clear();
  changed_cubes.clear();
  new_triangles.clear();
  kept_records.clear();
  readd.clear();
  released_vertices.clear();
  if (record_stamp.size() < records.size()) record_stamp.resize(records.size() * 2, 0);
  if (pending.size() < positions.size()) pending.resize(positions.size(), 0);
}

void ImtSurface::State::remesh_region(const VoxelVolume& volume, const VoxelBox& region,
                                      const VoxelBox& core, int margin) {
  const bool ranges = volume.brick_ranges_current();
  struct Chunk {
    Int3 c0, c1;
  };
  std::vector<Chunk> chunks;
  for (int z0 = region.lo.z; z0 < region.hi.z; z0 += kChunk)
    for (int y0 = region.lo.y; y0 < region.hi.y; y0 += kChunk)
      for (int x0 = region.lo.x; x0 < region.hi.x; x0 += kChunk)
        chunks.push_back({{x0, y0, z0},
                          {std::min(x0 + kChunk, region.hi.x), std::min(y0 + kChunk, region.hi.y),
                           std::min(z0 + kChunk, region.hi.z)}});
  // The chunks go in batches of one per thread. Each batch's lattice windows (the volume read,
  // the merging decisions: pure functions of the volume) and plans (the unchanged cubes' vertices
  // made again and compared: reads of the records and positions, which this pass does not
  // write) are computed in parallel; then its cubes are meshed against the records on this
  // thread in the serial order, so the slots, lists and change lists are the same on any number
  // of threads.
  const auto batch = static_cast<std::size_t>(std::max(1, omp_get_max_threads()));
  while (chunk_work.size() < std::min(batch, chunks.size()))
    chunk_work.push_back(std::make_unique<ChunkWork>());
  for (std::size_t first = 0; first < chunks.size(); first += batch) {
    const auto count = static_cast<std::int64_t>(std::min(batch, chunks.size() - first));
    const bool ahead = count >= kAheadChunks;
    Stopwatch on_threads;
#pragma omp parallel for schedule(dynamic, 1) if (count > 1)
    for (std::int64_t b = 0; b < count; ++b) {
      const Chunk& ch = chunks[first + static_cast<std::size_t>(b)];
      const bool may_hold_surface =
          !ranges ||
          detail::range_straddles(
              volume, volume.brick_ranges(), {ch.c0.x - margin, ch.c0.y - margin, ch.c0.z - margin},
              {ch.c1.x + margin - 1, ch.c1.y + margin - 1, ch.c1.z + margin - 1}, options.iso);
      ChunkWork& cw = *chunk_work[static_cast<std::size_t>(b)];
      cw.meshed = may_hold_surface;
      if (may_hold_surface) {
        cw.window.compute(volume, options, ch.c0, ch.c1);
        // Working ahead (the vertex table, the plan) is ~1.3× the work the serial meshing saves:
        // a batch of fewer than kAheadChunks chunks plans its cubes as they are meshed.
        make_chunk_vertices(cw.window, ch.c0, ch.c1, ahead ? core : VoxelBox{}, cw.table);
        cw.plan.ready = ahead;
        if (cw.plan.ready) plan_chunk(cw.window, cw.table, core, cw.plan);
      }
    }
    stats.classify_threads_seconds += on_threads.seconds();
    stats.chunks_meshed += static_cast<std::size_t>(count);
    if (ahead) stats.chunks_ahead += static_cast<std::size_t>(count);
    batch_size = static_cast<std::size_t>(count);
    for (std::int64_t b = 0; b < count; ++b) {
      const Chunk& ch = chunks[first + static_cast<std::size_t>(b)];
      work = chunk_work[static_cast<std::size_t>(b)].get();
      if (work->meshed) {
        window = &work->window;
        const auto& cubes = window->relevant_cubes();
        for (std::size_t i = 0; i < cubes.size(); ++i) remesh_cube(cubes[i], work->plan, i, core);
      }
      collect_emptied_cubes(ch.c0, ch.c1);
    }
  }
  window = nullptr;
  work = nullptr;
  batch_size = 0;
}

/// The table of the vertices of chunk [c0, c1)'s relevant cubes in `near` (the core): every slot a
/// triangle uses (LatticeWindow::referenced_slots), made with the chunk's window. Reads only.
void ImtSurface::State::make_chunk_vertices(const LatticeWindow& w, const Int3& c0, const Int3& c1,
                                            const VoxelBox& near, VertexTable& table) const {
  table.c0 = c0;
  table.c1 = near.empty() ? c0 : c1;
  const Int3 e{table.c1.x - c0.x, table.c1.y - c0.y, table.c1.z - c0.z};
  table.made.assign(static_cast<std::size_t>(e.volume()), 0);
  table.first.resize(table.made.size());
  table.positions.clear();
  table.labels.clear();
  for (const auto& cube : w.relevant_cubes()) {
    if (!near.contains(cube.c.x, cube.c.y, cube.c.z)) continue;
    const std::size_t i =
        static_cast<std::size_t>(cube.c.x - c0.x) +
        static_cast<std::size_t>(e.x) *
            (static_cast<std::size_t>(cube.c.y - c0.y) +
             static_cast<std::size_t>(e.y) * static_cast<std::size_t>(cube.c.z - c0.z));
    const std::uint16_t made = w.referenced_slots(cube.local);
    table.made[i] = made;
    table.first[i] = static_cast<std::uint32_t>(table.positions.size());
    for (unsigned bits = made; bits; bits &= bits - 1) {
      const int slot = __builtin_ctz(bits);
      Vec3d ip;
      std::uint8_t label = 0;
      w.vertex(cube.c, cube.local, slot, ip, label);
      table.positions.push_back(detail::tissue_position(geometry, ip));
      table.labels.push_back(label);
    }
  }
}

/// Whether unchanged-or-not cube `cube` of window `w` keeps its triangles, holds some and lies in
/// the core: then its vertices are refreshed. Reads only.
bool ImtSurface::State::refreshes_cube(const LatticeWindow& w, const LatticeWindow::Cube& cube,
                                       const VoxelBox& core) const {
  const std::uint32_t rid = find_record(cube.c);
  return rid != 0 && records[rid].signature == w.signature(cube.local) &&
         records[rid].first_triangle != kNone && core.contains(cube.c.x, cube.c.y, cube.c.z);
}

/// The refresh of an unchanged cube: its vertices in the order its triangles first use them, each
/// made again (from `table`, else the window) where `needs(vertex)` and compared with what the
/// vertex holds. Reads only: runs on any thread.
template <typename Needs>
void ImtSurface::State::plan_cube(const LatticeWindow& w, const VertexTable& table,
                                  const LatticeWindow::Cube& cube, std::vector<Refresh>& out,
                                  Needs&& needs) const {
  std::array<unsigned, 64> seen{};  // packed keys of the cube's vertices so far
  std::size_t n_seen = 0;
  w.mesh_cube(cube.local, [&](const LatticeRef* keys) {
    for (int k = 0; k < 3; ++k) {
      const LatticeRef& ref = keys[k];
      const unsigned packed = static_cast<unsigned>(ref.offset[0] + 1) |
                              (static_cast<unsigned>(ref.offset[1] + 1) << 2) |
                              (static_cast<unsigned>(ref.offset[2] + 1) << 4) |
                              (static_cast<unsigned>(ref.slot) << 6);
      if (std::find(seen.begin(), seen.begin() + static_cast<std::ptrdiff_t>(n_seen), packed) !=
          seen.begin() + static_cast<std::ptrdiff_t>(n_seen))
        continue;
      if (n_seen < seen.size()) seen[n_seen++] = packed;
      const Int3 o{cube.c.x + ref.offset[0], cube.c.y + ref.offset[1], cube.c.z + ref.offset[2]};
      const std::uint32_t orid = find_record(o);
      const std::uint32_t v = orid == 0 ? 0 : records[orid].vertex[ref.slot];
      if (v != 0 && !needs(v)) {
        out.push_back({v, Vec3f{}, 0, false});
        continue;
      }
      Vec3f p;
      std::uint8_t label = 0;
      if (!table.find(o, ref.slot, p, label)) {
        Vec3d ip;
        w.vertex(o, w.local_index(o), ref.slot, ip, label);
        p = detail::tissue_position(geometry, ip);
      }
      const bool differs = v != 0 && (!(positions[v] == p) || labels[v] != label);
      out.push_back({v, p, label, differs});
    }
  });
}

/// Plans chunk `w`'s refreshed cubes ahead (plan_cube on each, in order). A vertex already
/// planned through an earlier cube of the chunk is stamped by the time the plan is followed: it
/// needs no position. Reads only: runs on any thread.
void ImtSurface::State::plan_chunk(const LatticeWindow& w, const VertexTable& table,
                                   const VoxelBox& core, ChunkPlan& plan) const {
  const auto& cubes = w.relevant_cubes();
  plan.refreshed.assign(cubes.size(), 0);
  plan.first.resize(cubes.size() + 1);
  plan.refreshes.clear();
  std::size_t capacity = 64;
  while (capacity < 8 * cubes.size()) capacity *= 2;
  plan.planned.assign(capacity, 0);
  auto first_time = [&](std::uint32_t v) {
    for (std::size_t h = (v * 2654435761u) & (capacity - 1);; h = (h + 1) & (capacity - 1)) {
      if (plan.planned[h] == v) return false;
      if (plan.planned[h] == 0) {
        plan.planned[h] = v;
        return true;
      }
    }
  };
  for (std::size_t i = 0; i < cubes.size(); ++i) {
    plan.first[i] = static_cast<std::uint32_t>(plan.refreshes.size());
    if (!refreshes_cube(w, cubes[i], core)) continue;
    plan.refreshed[i] = 1;
    plan_cube(w, table, cubes[i], plan.refreshes, first_time);
  }
  plan.first[cubes.size()] = static_cast<std::uint32_t>(plan.refreshes.size());
}

void ImtSurface::State::remesh_cube(const LatticeWindow::Cube& cube, const ChunkPlan& plan,
                                    std::size_t index, const VoxelBox& core) {
  const std::uint32_t signature = window->signature(cube.local);
  const std::uint32_t rid = record_of(cube.c, false);
  if (rid != 0) {
    if (rid >= record_stamp.size()) record_stamp.resize(2 * rid + 2, 0);
    record_stamp[rid] = generation;
  }
  if (rid != 0 && records[rid].signature == signature) {
    // Same triangles (as lattice keys, so as vertex ids). Only near the change can their
    // vertices have moved: refresh those (planned with the window); the cube's fan is redone
    // when one moved, now or earlier in this update through another cube.
    const Refresh* begin = nullptr;
    const Refresh* end = nullptr;
    if (plan.ready) {
      if (!plan.refreshed[index]) return;
      begin = plan.refreshes.data() + plan.first[index];
      end = plan.refreshes.data() + plan.first[index + 1];
    } else {
      if (records[rid].first_triangle == kNone || !core.contains(cube.c.x, cube.c.y, cube.c.z))
        return;  // refreshes_cube, with the record and signature known
      cube_refreshes.clear();
      plan_cube(*window, work->table, cube, cube_refreshes,
                [&](std::uint32_t v) { return stamp[v] != generation; });
      begin = cube_refreshes.data();
      end = begin + cube_refreshes.size();
    }
    bool any_moved = false;
    for (const Refresh* e = begin; e != end; ++e) {
      const Refresh& r = *e;
      if (r.vertex == 0)
        throw Error(
            "ImtSurface::update: an unchanged cube's triangle uses a vertex its cube "
            "record does not hold (internal)");
      if (stamp[r.vertex] == generation) {
        any_moved = any_moved || pending[r.vertex];
        continue;
      }
      stamp[r.vertex] = generation;
      if (!r.moved) continue;
      moved.push_back({r.vertex, r.position, r.label});
      pending[r.vertex] = 1;
      ++stats.vertices_moved;
      any_moved = true;
    }
    if (any_moved) kept_records.push_back(rid);
    return;
  }
  const auto first = static_cast<std::uint32_t>(new_triangles.size());
  begin_cube();
  window->mesh_cube(cube.local, [&](const LatticeRef* keys) {
    new_triangles.push_back(
        {cube_vertex(cube.c, keys[0]), cube_vertex(cube.c, keys[1]), cube_vertex(cube.c, keys[2])});
  });
  const auto count = static_cast<std::uint32_t>(new_triangles.size()) - first;
  changed_cubes.push_back({cube.c, first, count, signature});
}

/// Cubes of chunk [c0, c1) that held triangles and are not relevant any more lose them all:
/// queued as changed cubes with no new triangles.
void ImtSurface::State::collect_emptied_cubes(const Int3& c0, const Int3& c1) {
  for (int pz = (c0.z + 1) / kPageEdge; pz <= c1.z / kPageEdge; ++pz)
    for (int py = (c0.y + 1) / kPageEdge; py <= c1.y / kPageEdge; ++py)
      for (int px = (c0.x + 1) / kPageEdge; px <= c1.x / kPageEdge; ++px) {
        if (px >= pages.x || py >= pages.y || pz >= pages.z) continue;
        const std::uint32_t page =
            page_of[static_cast<std::size_t>(px) +
                    static_cast<std::size_t>(pages.x) *
                        (static_cast<std::size_t>(py) +
                         static_cast<std::size_t>(pages.y) * static_cast<std::size_t>(pz))];
        if (page != 0) collect_emptied_cubes_in_page(page, {px, py, pz}, VoxelBox{c0, c1});
      }
}

/// collect_emptied_cubes over the cubes of record page `page` (at page cell p) in `chunk`.
void ImtSurface::State::collect_emptied_cubes_in_page(std::uint32_t page, const Int3& p,
                                                      const VoxelBox& chunk) {
  const VoxelBox cubes = VoxelBox{
      {p.x * kPageEdge - 1, p.y * kPageEdge - 1, p.z * kPageEdge - 1},
      {p.x * kPageEdge + kPageEdge - 1, p.y * kPageEdge + kPageEdge - 1,
       p.z * kPageEdge + kPageEdge -
           1}}.intersected(chunk);
  const std::uint32_t* cells = page_records[page - 1].data();
  for (int z = cubes.lo.z; z < cubes.hi.z; ++z)
    for (int y = cubes.lo.y; y < cubes.hi.y; ++y) {
      const std::uint32_t* row = cells + kPageEdge * (((y + 1) & 7) + kPageEdge * ((z + 1) & 7));
      for (int x = cubes.lo.x; x < cubes.hi.x; ++x) {
        const std::uint32_t rid = row[(x + 1) & 7];
        if (rid == 0 || records[rid].first_triangle == kNone) continue;
        if (rid < record_stamp.size() && record_stamp[rid] == generation)
          continue;  // visited as a relevant cube
        changed_cubes.push_back(
            {{x, y, z}, static_cast<std::uint32_t>(new_triangles.size()), 0, kNoSignature});
      }
    }
}

void ImtSurface::State::take_off_changed_normals() {
  for (const auto& cc : changed_cubes) {
    const std::uint32_t rid = record_of(cc.c, false);
    if (rid != 0 && records[rid].first_triangle != kNone) {
      release_triangles(rid);
      released_cubes.push_back(cc.c);
    }
  }
  for (std::uint32_t rid : kept_records)  // kept cubes with a moved vertex: redo their fans
    for (std::uint32_t t = records[rid].first_triangle; t != kNone; t = next_triangle[t]) {
      add_normal(t, false);
      readd.push_back(t);
    }
}

void ImtSurface::State::move_vertices_and_make_triangles() {
  for (const Moved& m : moved) {
    touch_vertex(m.vertex, kModified);
    positions[m.vertex] = m.position;
    labels[m.vertex] = m.label;
    pending[m.vertex] = 0;
  }
  for (std::uint32_t t : readd) add_normal(t, true);  // same indices: not a triangle change
  for (const auto& cc : changed_cubes) {
    if (cc.count == 0) {
      const std::uint32_t rid = record_of(cc.c, false);
      if (rid != 0) records[rid].signature = kNoSignature;
      continue;
    }
    const std::uint32_t rid = record_of(cc.c, true);
    records[rid].signature = cc.signature;
    for (std::uint32_t i = cc.first + cc.count; i-- > cc.first;)  // reversed: list keeps order
      make_triangle(rid, new_triangles[i]);
  }
}

void ImtSurface::State::free_unused_vertices() {
  for (std::uint32_t v : released_vertices)
    if (vertex_live(v) && refcount[v] == 0) free_vertex(v);
  for (std::uint32_t v : created)
    if (vertex_live(v) && refcount[v] == 0) free_vertex(v);
  released_vertices.clear();
  for (const Int3& c : released_cubes) release_record_if_empty(c);
  released_cubes.clear();
}

void ImtSurface::State::refresh_dirty_normals() {
  for (std::uint32_t v : normal_dirty) {
    normal_dirty_flag[v] = 0;
    if (!vertex_live(v)) continue;
    const Vec3f n = detail::unit_normal(normal_sum[v]);
    if (!(n == normals[v])) {
      normals[v] = n;
      touch_vertex(v, kNormal);
    }
  }
  normal_dirty.clear();
}

SurfaceUpdateStats ImtSurface::update(const VoxelVolume& volume, const VoxelBox& changed_voxels) {
  State& s = *s_;
  require(s.built, "ImtSurface::update called before build()");
  require(volume.dims() == s.geometry.dims,
          "ImtSurface::update: the volume is " + std::to_string(volume.dims().x) + "x" +
              std::to_string(volume.dims().y) + "x" + std::to_string(volume.dims().z) +
              ", the surface was built from " + std::to_string(s.geometry.dims.x) + "x" +
              std::to_string(s.geometry.dims.y) + "x" + std::to_string(s.geometry.dims.z));
  Stopwatch clock;
  s.stats = {};
  const VoxelBox changed = changed_voxels.intersected(VoxelBox::of_dims(volume.dims()));
  if (changed.empty()) return s.stats;
  s.begin_update();

  const int margin = LatticeWindow::margin(s.options.snap_epsilon > 0.0f);
  const VoxelBox region = s.update_region(changed);
  s.stats.cubes_remeshed = static_cast<std::size_t>(region.voxel_count());
  // Cubes whose triangles can use a vertex that moved: vertices move only on edges with a changed
  // end value, and the tetrahedra holding those edges belong to these cubes.
  const VoxelBox core = changed.dilated(1, 1);

  Stopwatch phase;
  auto lap = [&](int i) {
    s.stats.phase_seconds[i] = phase.seconds();
    phase.restart();
  };
  s.remesh_region(volume, region, core, margin);  // 1. what each cube holds now
  lap(0);
  s.take_off_changed_normals();  // 2. with the old positions
  lap(1);
  s.move_vertices_and_make_triangles();  // 3. new positions, new triangles
  lap(2);
  s.free_unused_vertices();  // 4. vertices no triangle uses; tidy records
  lap(3);
  s.refresh_dirty_normals();  // 5. normals of the vertices whose fans changed
  lap(4);
  s.stats.seconds = clock.seconds();
  return s.stats;
}

std::size_t ImtSurface::update_chunks(const VoxelBox& changed_voxels) const {
  const State& s = *s_;
  if (!s.built) return 0;
  const VoxelBox changed = changed_voxels.intersected(VoxelBox::of_dims(s.geometry.dims));
  if (changed.empty()) return 0;
  const VoxelBox region = s.update_region(changed);
  if (region.empty()) return 0;
  const Int3 e = region.extent();
  auto per_axis = [](int n) { return static_cast<std::size_t>((n + kChunk - 1) / kChunk); };
  return per_axis(e.x) * per_axis(e.y) * per_axis(e.z);
}

std::uint32_t ImtSurface::vertex_slot_count() const {
  return s_->vertex_slots;
}
std::uint32_t ImtSurface::triangle_slot_count() const {
  return s_->triangle_slots;
}
std::uint32_t ImtSurface::vertex_capacity() const {
  return static_cast<std::uint32_t>(s_->positions.size());
}
std::uint32_t ImtSurface::triangle_capacity() const {
  return static_cast<std::uint32_t>(s_->triangles.size());
}
std::size_t ImtSurface::live_vertex_count() const {
  return s_->vertex_slots == 0 ? 0 : s_->vertex_slots - 1 - s_->free_vertices.size();
}
std::size_t ImtSurface::live_triangle_count() const {
  return s_->triangle_slots - s_->free_triangles.size();
}
const std::vector<Vec3f>& ImtSurface::positions() const {
  return s_->positions;
}
const std::vector<Vec3f>& ImtSurface::normals() const {
  return s_->normals;
}
const std::vector<std::uint8_t>& ImtSurface::labels() const {
  return s_->labels;
}
const std::vector<std::array<std::uint32_t, 3>>& ImtSurface::triangles() const {
  return s_->triangles;
}
bool ImtSurface::vertex_live(std::uint32_t slot) const {
  return slot < s_->vertex_slots && s_->vertex_live(slot);
}
bool ImtSurface::triangle_live(std::uint32_t slot) const {
  return slot < s_->triangle_slots && s_->triangles[slot][0] != 0;
}
std::uint64_t ImtSurface::vertex_key(std::uint32_t slot) const {
  require(vertex_live(slot),
          "ImtSurface::vertex_key: slot " + std::to_string(slot) + " is not live");
  return s_->key[slot];
}

SurfaceBuffersView ImtSurface::view() const {
  SurfaceBuffersView v;
  v.positions = s_->positions.data();
  v.normals = s_->normals.data();
  v.labels = s_->labels.data();
  v.triangles = s_->triangles.empty() ? nullptr : s_->triangles.front().data();
  v.vertex_slots = s_->vertex_slots;
  v.triangle_slots = s_->triangle_slots;
  return v;
}

SurfaceChanges ImtSurface::take_changes() {
  State& s = *s_;
  SurfaceChanges out;
  out.reallocated = s.reallocated;
  s.reallocated = false;
  for (std::uint32_t v : s.touched_vertices) {
    const std::uint8_t c = s.vchange[v];
    s.vchange[v] = 0;
    const bool was = c & kWasLive, now = s.vertex_live(v);
    if (!was && now)
      out.vertices_added.push_back(v);
    else if (was && !now)
      out.vertices_freed.push_back(v);
    else if (was && now && (c & kModified))
      out.vertices_modified.push_back(v);
    else if (was && now && (c & kNormal))
      out.vertices_normal_changed.push_back(v);
  }
  s.touched_vertices.clear();
  for (std::uint32_t t : s.touched_triangles) {
    const std::uint8_t c = s.tchange[t];
    s.tchange[t] = 0;
    const bool was = c & kWasLive, now = s.triangles[t][0] != 0;
    if (now)
      out.triangles_added.push_back(t);
    else if (was)
      out.triangles_freed.push_back(t);
  }
  s.touched_triangles.clear();
  return out;
}

SurfaceMesh ImtSurface::compact(std::vector<std::uint32_t>* vertex_slots) const {
  const State& s = *s_;
  SurfaceMesh mesh;
  std::vector<std::uint32_t> index_of(s.vertex_slots, kNone);
  if (vertex_slots) vertex_slots->clear();
  for (std::uint32_t v = 1; v < s.vertex_slots; ++v) {
    if (!s.vertex_live(v)) continue;
    index_of[v] = static_cast<std::uint32_t>(mesh.positions.size());
    mesh.positions.push_back(s.positions[v]);
    mesh.normals.push_back(s.normals[v]);
    mesh.labels.push_back(s.labels[v]);
    if (vertex_slots) vertex_slots->push_back(v);
  }
  for (std::uint32_t t = 0; t < s.triangle_slots; ++t) {
    const auto& tri = s.triangles[t];
    if (tri[0] == 0) continue;
    mesh.triangles.push_back({index_of[tri[0]], index_of[tri[1]], index_of[tri[2]]});
  }
  return mesh;
}

std::size_t ImtSurface::memory_bytes() const {
  const State& s = *s_;
  const std::size_t per_vertex = sizeof(Vec3f) * 2 + 1 + 4 + 8 + sizeof(NormalSum) + 4 + 1 + 1;
  const std::size_t per_triangle = sizeof(std::array<std::uint32_t, 3>) + 4 + 1;
  return s.positions.capacity() * per_vertex + s.triangles.capacity() * per_triangle +
         (s.free_vertices.capacity() + s.free_triangles.capacity()) * 4 + s.page_of.capacity() * 4 +
         s.page_records.capacity() * sizeof(s.page_records[0]) +
         s.records.capacity() * sizeof(CubeRecord) + s.free_records.capacity() * 4;
}

void ImtSurface::check_invariants() const {
  const State& s = *s_;
  auto fail = [](const std::string& what) { throw Error("ImtSurface invariant broken: " + what); };
  if (!s.built) return;
  if (s.key[0] != kNoKey) fail("sentinel vertex 0 carries a key");
  std::vector<std::uint32_t> uses(s.vertex_slots, 0);
  std::vector<NormalSum> sums(s.vertex_slots);
  std::size_t live_triangles = 0;
  for (std::uint32_t t = 0; t < s.triangle_slots; ++t) {
    const auto& tri = s.triangles[t];
    if (tri[0] == 0) {
      if (tri[1] != 0 || tri[2] != 0) fail("triangle " + std::to_string(t) + " half collapsed");
      continue;
    }
    ++live_triangles;
    for (std::uint32_t v : tri) {
      if (v >= s.vertex_slots || !s.vertex_live(v))
        fail("triangle " + std::to_string(t) + " uses free vertex " + std::to_string(v));
      ++uses[v];
    }
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2])
      fail("triangle " + std::to_string(t) + " repeats a vertex");
    const NormalSum n = s.face_sum(tri);
    for (std::uint32_t v : tri) sums[v] += n;
  }
  if (live_triangles != live_triangle_count()) fail("live triangle count disagrees with free list");
  for (std::uint32_t v = 1; v < s.vertex_slots; ++v) {
    if (!s.vertex_live(v)) {
      if (uses[v] != 0) fail("free vertex " + std::to_string(v) + " is used");
      continue;
    }
    if (uses[v] != s.refcount[v])
      fail("vertex " + std::to_string(v) + " refcount " + std::to_string(s.refcount[v]) +
           " but used by " + std::to_string(uses[v]) + " triangles");
    if (uses[v] == 0) fail("live vertex " + std::to_string(v) + " is used by no triangle");
    if (!(sums[v] == s.normal_sum[v])) fail("vertex " + std::to_string(v) + " normal sum drifted");
    const std::uint64_t k = s.key[v];
    const Int3 c = s.grid.cube(k / kSlotsPerCube);
    const Int3 u{c.x + 1, c.y + 1, c.z + 1};
    const std::uint32_t page = s.page_of[s.page_cell(u)];
    const std::uint32_t rid =
        page == 0 ? 0 : s.page_records[page - 1][static_cast<std::size_t>(State::page_local(u))];
    if (rid == 0 || s.records[rid].vertex[k % kSlotsPerCube] != v)
      fail("vertex " + std::to_string(v) + " is not found through its cube record");
  }
  // Every live triangle is on exactly one record list.
  std::vector<std::uint8_t> listed(s.triangle_slots, 0);
  for (std::size_t rid = 1; rid < s.records.size(); ++rid) {
    if (std::find(s.free_records.begin(), s.free_records.end(), rid) != s.free_records.end())
      continue;
    for (std::uint32_t t = s.records[rid].first_triangle; t != kNone; t = s.next_triangle[t]) {
      if (t >= s.triangle_slots || s.triangles[t][0] == 0)
        fail("record " + std::to_string(rid) + " lists a free triangle");
      if (listed[t]++) fail("triangle " + std::to_string(t) + " listed twice");
    }
  }
  for (std::uint32_t t = 0; t < s.triangle_slots; ++t)
    if (s.triangles[t][0] != 0 && !listed[t])
      fail("triangle " + std::to_string(t) + " is on no cube record");
}

}  // namespace tsf::imt
