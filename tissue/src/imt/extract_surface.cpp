#include "tsf/imt/extract_surface.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <string>

#include "lattice_window.h"
#include "surface_internals.h"
#include "tsf/common/error.h"
#include "tsf/common/stopwatch.h"

namespace tsf::imt {

void SurfaceOptions::validate() const {
  require(std::isfinite(iso) && iso > 0.0f && iso <= 1.0f,
          "surface option iso must lie in (0, 1], got " + std::to_string(iso));
  require(std::isfinite(snap_epsilon) && snap_epsilon >= 0.0f && snap_epsilon < 0.5f,
          "surface option snap_epsilon must lie in [0, 0.5), got " + std::to_string(snap_epsilon));
}

namespace detail {

namespace {
constexpr std::int64_t kParallelBricks = 512;  // bricks before range passes go parallel
}  // namespace

std::vector<VoxelVolume::BrickRange> current_brick_ranges(const VoxelVolume& volume,
                                                          double* seconds) {
  Stopwatch clock;
  if (volume.brick_ranges_current()) {
    if (seconds) *seconds = 0.0;
    return volume.brick_ranges();
  }
  const Int3 bd = volume.brick_dims();
  std::vector<VoxelVolume::BrickRange> ranges(volume.brick_count());
  const std::int64_t n = bd.volume();
#pragma omp parallel for schedule(dynamic, 8) if (n >= kParallelBricks)
  for (std::int64_t b = 0; b < n; ++b) {
    const int bi = static_cast<int>(b % bd.x), bj = static_cast<int>((b / bd.x) % bd.y);
    const int bk = static_cast<int>(b / (static_cast<std::int64_t>(bd.x) * bd.y));
    ranges[static_cast<std::size_t>(b)] = volume.compute_brick_range(bi, bj, bk);
  }
  if (seconds) *seconds = clock.seconds();
  return ranges;
}

bool range_straddles(const VoxelVolume& volume, const std::vector<VoxelVolume::BrickRange>& ranges,
                     const Int3& lo, const Int3& hi, float iso) {
  const Int3& n = volume.dims();
  bool below = lo.x < 0 || lo.y < 0 || lo.z < 0 || hi.x >= n.x || hi.y >= n.y || hi.z >= n.z;
  bool above = false;
  const Int3 a{std::max(lo.x, 0), std::max(lo.y, 0), std::max(lo.z, 0)};
  const Int3 b{std::min(hi.x, n.x - 1), std::min(hi.y, n.y - 1), std::min(hi.z, n.z - 1)};
  if (a.x > b.x || a.y > b.y || a.z > b.z) return false;  // entirely outside: all zero
  const int s = VoxelVolume::kBrickSize;
  for (int bk = a.z / s; bk <= b.z / s; ++bk)
    for (int bj = a.y / s; bj <= b.y / s; ++bj)
      for (int bi = a.x / s; bi <= b.x / s; ++bi) {
        const auto& r = ranges[volume.brick_index(bi, bj, bk)];
        below = below || r.min < iso;
        above = above || r.max >= iso;
        if (below && above) return true;
      }
  return false;
}

namespace {

constexpr int kBlock = 16;  // cubes per block edge
constexpr int kCubesPerBlock = kBlock * kBlock * kBlock;
constexpr std::int64_t kParallelBlocks = 16;  // active blocks before the passes go parallel

/// Bits set in each byte value (the build assumes no popcnt instruction).
constexpr std::array<std::uint8_t, 256> kBitsSet = [] {
  std::array<std::uint8_t, 256> t{};
  for (int i = 0; i < 256; ++i)
    for (int b = 0; b < 8; ++b)
      t[static_cast<std::size_t>(i)] =
          static_cast<std::uint8_t>(t[static_cast<std::size_t>(i)] + ((i >> b) & 1));
  return t;
}();
inline std::uint32_t popcount16(std::uint16_t v) {
  return kBitsSet[v & 0xFFu] + kBitsSet[v >> 8];
}

struct BlockRecord {
  std::size_t vertex_count = 0, triangle_count = 0;    // pass 2
  std::size_t vertex_offset = 0, triangle_offset = 0;  // pass 3: where the block writes
};

/// One full surfacing, in the vtkFlyingEdges3D style: the owner cubes are tiled by blocks of
/// kBlock³; each pass below reads what the earlier ones wrote (named in its comment).
class BlockedExtraction {
 public:
  BlockedExtraction(const VoxelVolume& volume, const SurfaceOptions& options)
      : volume_(volume),
        options_(options),
        grid_(volume.dims()),
        nb_{(grid_.size.x + kBlock - 1) / kBlock, (grid_.size.y + kBlock - 1) / kBlock,
            (grid_.size.z + kBlock - 1) / kBlock} {}

  /// Pass 1. Reads the brick density ranges; writes active_of_block_, active_blocks_ (z-major)
  /// and parallel_, and stats' ranges_s, blocks and active_blocks.
  void find_active_blocks(SurfaceBuildStats& stats);
  /// Pass 2. Reads the active blocks' lattice windows; writes slot_mask_ and slot_prefix_ (per
  /// block cube: the vertex slots it owns, and the block's vertices before it), merged_ (the
  /// merging decisions, for pass 3 to replay) and records_' counts.
  void count_blocks();
  /// Prefix sums over records_' counts: writes their offsets; returns the totals.
  void place_blocks(std::size_t& vertices, std::size_t& triangles);
  /// Pass 3. Reads everything above; writes every block's vertices and triangles in place in
  /// `mesh` (allocated by the caller) and `extras`. False when a triangle refers to a vertex no
  /// block made, or a block makes other counts than pass 2's (an internal error).
  bool write_blocks(SurfaceMesh& mesh, ExtractionExtras* extras) const;
  /// Normals. Reads mesh positions and triangles and records_; returns the fixed-point
  /// area-weighted normal sum of every vertex.
  std::vector<NormalSum> sum_normals(const SurfaceMesh& mesh) const;

  bool parallel() const { return parallel_; }

 private:
  /// Owner cubes [c0, c1) of block b.
  void block_cubes(std::int64_t b, Int3& c0, Int3& c1) const;
  static int block_local(const Int3& c, const Int3& c0) {
    return (c.x - c0.x) + kBlock * ((c.y - c0.y) + kBlock * (c.z - c0.z));
  }
  void count_block(LatticeWindow& window, std::size_t a);
  bool write_block(LatticeWindow& window, std::size_t a, SurfaceMesh& mesh,
                   ExtractionExtras* extras) const;
  /// Vertex index of lattice slot `slot` of the owner cube at u coordinates `u` (c + 1); false
  /// when no block made that vertex.
  bool vertex_index(const Int3& u, int slot, std::uint32_t& index) const;
  /// Per slab of blocks z, the first active block at or after it (active blocks are z-major).
  std::vector<std::size_t> slab_first_blocks() const;

  const VoxelVolume& volume_;
  const SurfaceOptions& options_;
  const CubeGrid grid_;
  const Int3 nb_;  // blocks per axis
  bool parallel_ = false;
  std::vector<std::int32_t> active_of_block_;  // per block: its active index, −1 when inactive
  std::vector<std::int64_t> active_blocks_;    // per active block: its block index
  std::vector<std::uint16_t> slot_mask_;
  std::vector<std::uint32_t> slot_prefix_;
  std::vector<BlockRecord> records_;
  std::vector<std::vector<LatticeWindow::MergedPoint>> merged_;
};

void BlockedExtraction::block_cubes(std::int64_t b, Int3& c0, Int3& c1) const {
  const Int3 bi{static_cast<int>(b % nb_.x), static_cast<int>((b / nb_.x) % nb_.y),
                static_cast<int>(b / (static_cast<std::int64_t>(nb_.x) * nb_.y))};
  c0 = {bi.x * kBlock - 1, bi.y * kBlock - 1, bi.z * kBlock - 1};
  c1 = {std::min(c0.x + kBlock, grid_.size.x - 1), std::min(c0.y + kBlock, grid_.size.y - 1),
        std::min(c0.z + kBlock, grid_.size.z - 1)};
}

void BlockedExtraction::find_active_blocks(SurfaceBuildStats& stats) {
  const auto ranges = current_brick_ranges(volume_, &stats.ranges_s);
  const int margin = LatticeWindow::margin(options_.snap_epsilon > 0.0f);
  const std::int64_t block_count = nb_.volume();
  stats.blocks = static_cast<std::size_t>(block_count);
  std::vector<std::uint8_t> active(static_cast<std::size_t>(block_count), 0);
#pragma omp parallel for schedule(dynamic, 64) if (block_count >= kParallelBricks)
  for (std::int64_t b = 0; b < block_count; ++b) {
    Int3 c0, c1;
    block_cubes(b, c0, c1);
    const Int3 lo{c0.x - margin, c0.y - margin, c0.z - margin};
    const Int3 hi{c1.x + margin - 1, c1.y + margin - 1, c1.z + margin - 1};
    active[static_cast<std::size_t>(b)] = range_straddles(volume_, ranges, lo, hi, options_.iso);
  }
  active_of_block_.assign(static_cast<std::size_t>(block_count), -1);
  active_blocks_.clear();
  for (std::int64_t b = 0; b < block_count; ++b) {
    if (!active[static_cast<std::size_t>(b)]) continue;
    active_of_block_[static_cast<std::size_t>(b)] =
        static_cast<std::int32_t>(active_blocks_.size());
    active_blocks_.push_back(b);
  }
  stats.active_blocks = active_blocks_.size();
  // Small volumes run on the calling thread: a parallel region costs more than it saves there,
  // and far more when the machine is oversubscribed.
  parallel_ = static_cast<std::int64_t>(active_blocks_.size()) >= kParallelBlocks;
}

void BlockedExtraction::count_blocks() {
  const std::size_t n_active = active_blocks_.size();
  slot_mask_.assign(n_active * kCubesPerBlock, 0);
  slot_prefix_.assign(n_active * kCubesPerBlock, 0);
  records_.assign(n_active, BlockRecord{});
  merged_.assign(n_active, {});
#pragma omp parallel if (parallel_)
  {
    LatticeWindow window;
#pragma omp for schedule(dynamic, 4)
    for (std::int64_t a = 0; a < static_cast<std::int64_t>(n_active); ++a)
      count_block(window, static_cast<std::size_t>(a));
  }
}

void BlockedExtraction::count_block(LatticeWindow& window, std::size_t a) {
  Int3 c0, c1;
  block_cubes(active_blocks_[a], c0, c1);
  window.compute(volume_, options_, c0, c1);
  std::uint16_t* mask = &slot_mask_[a * kCubesPerBlock];
  std::uint32_t* prefix = &slot_prefix_[a * kCubesPerBlock];
  std::uint32_t vertices = 0;
  std::size_t triangles = 0;
  for (const auto& cube : window.relevant_cubes()) {
    const int bl = block_local(cube.c, c0);
    prefix[bl] = vertices;
    mask[bl] = window.referenced_slots(cube.local);
    vertices += popcount16(mask[bl]);
    triangles += static_cast<std::size_t>(window.count_triangles(cube.local));
  }
  if (options_.snap_epsilon > 0.0f) window.merged_points(merged_[a]);
  records_[a].vertex_count = vertices;
  records_[a].triangle_count = triangles;
}

void BlockedExtraction::place_blocks(std::size_t& vertices, std::size_t& triangles) {
  vertices = 0;
  triangles = 0;
  for (BlockRecord& rec : records_) {
    rec.vertex_offset = vertices;
    rec.triangle_offset = triangles;
    vertices += rec.vertex_count;
    triangles += rec.triangle_count;
  }
}

bool BlockedExtraction::write_blocks(SurfaceMesh& mesh, ExtractionExtras* extras) const {
  std::atomic<bool> broken_reference{false};
#pragma omp parallel if (parallel_)
  {
    LatticeWindow window;
#pragma omp for schedule(dynamic, 4)
    for (std::int64_t a = 0; a < static_cast<std::int64_t>(active_blocks_.size()); ++a)
      if (!write_block(window, static_cast<std::size_t>(a), mesh, extras)) broken_reference = true;
  }
  return !broken_reference;
}

bool BlockedExtraction::write_block(LatticeWindow& window, std::size_t a, SurfaceMesh& mesh,
                                    ExtractionExtras* extras) const {
  Int3 c0, c1;
  block_cubes(active_blocks_[a], c0, c1);
  window.compute_replaying(volume_, options_, c0, c1, merged_[a]);
  const VolumeGeometry& geometry = volume_.geometry();
  const BlockRecord& rec = records_[a];
  const std::uint16_t* mask = &slot_mask_[a * kCubesPerBlock];
  std::size_t v = rec.vertex_offset;
  for (const auto& cube : window.relevant_cubes()) {
    for (unsigned bits = mask[block_local(cube.c, c0)]; bits; bits &= bits - 1) {
      const int slot = __builtin_ctz(bits);
      Vec3d ip;
      window.vertex(cube.c, cube.local, slot, ip, mesh.labels[v]);
      mesh.positions[v] = tissue_position(geometry, ip);
      if (extras) extras->vertex_keys[v] = grid_.key(cube.c, slot);
      ++v;
    }
  }
  bool intact = true;
  std::size_t t = rec.triangle_offset;
  const std::size_t t_end = rec.triangle_offset + rec.triangle_count;
  for (const auto& cube : window.relevant_cubes()) {
    const Int3& c = cube.c;
    const std::uint64_t owner = grid_.linear(c);
    const std::uint32_t signature = extras ? window.signature(cube.local) : 0u;
    window.mesh_cube(cube.local, [&](const LatticeRef* keys) {
      if (t >= t_end) {  // pass 3 must make what pass 2 counted
        intact = false;
        return;
      }
      auto& tri = mesh.triangles[t];
      for (int k = 0; k < 3; ++k) {
        const Int3 u{c.x + keys[k].offset[0] + 1, c.y + keys[k].offset[1] + 1,
                     c.z + keys[k].offset[2] + 1};  // u coordinates of the owner cube
        std::uint32_t id = 0;
        if (!vertex_index(u, keys[k].slot, id)) intact = false;
        tri[static_cast<std::size_t>(k)] = id;
      }
      if (extras) {
        extras->triangle_owner[t] = owner;
        extras->triangle_owner_signature[t] = signature;
      }
      ++t;
    });
  }
  return intact && t == t_end && v == rec.vertex_offset + rec.vertex_count;
}

bool BlockedExtraction::vertex_index(const Int3& u, int slot, std::uint32_t& index) const {
  if (u.x < 0 || u.y < 0 || u.z < 0 || u.x >= grid_.size.x || u.y >= grid_.size.y ||
      u.z >= grid_.size.z)
    return false;
  const std::int64_t ob =
      (u.x / kBlock) + nb_.x * ((u.y / kBlock) + static_cast<std::int64_t>(nb_.y) * (u.z / kBlock));
  const std::int32_t oa = active_of_block_[static_cast<std::size_t>(ob)];
  if (oa < 0) return false;
  const int ol = (u.x % kBlock) + kBlock * ((u.y % kBlock) + kBlock * (u.z % kBlock));
  const std::size_t at =
      static_cast<std::size_t>(oa) * kCubesPerBlock + static_cast<std::size_t>(ol);
  if (!((slot_mask_[at] >> slot) & 1u)) return false;
  index = static_cast<std::uint32_t>(
      records_[static_cast<std::size_t>(oa)].vertex_offset + slot_prefix_[at] +
      popcount16(static_cast<std::uint16_t>(slot_mask_[at] & ((1u << slot) - 1u))));
  return true;
}

std::vector<std::size_t> BlockedExtraction::slab_first_blocks() const {
  const std::size_t n_active = active_blocks_.size();
  std::vector<std::size_t> slab_first(static_cast<std::size_t>(nb_.z) + 1, n_active);
  for (std::size_t a = n_active; a-- > 0;)
    slab_first[static_cast<std::size_t>(active_blocks_[a] /
                                        (static_cast<std::int64_t>(nb_.x) * nb_.y))] = a;
  for (int z = nb_.z - 1; z >= 0; --z)
    slab_first[static_cast<std::size_t>(z)] = std::min(slab_first[static_cast<std::size_t>(z)],
                                                       slab_first[static_cast<std::size_t>(z) + 1]);
  return slab_first;
}

// A triangle of a block touches vertices of blocks one slab (z) away at most. Each thread takes
// a contiguous range of slabs: the inside of every range first (ranges' vertices are then
// disjoint), then the first slabs of all ranges, then the last ones — three barriers, whatever
// the volume size (barriers are what hurts when the machine is oversubscribed).
std::vector<NormalSum> BlockedExtraction::sum_normals(const SurfaceMesh& mesh) const {
  std::vector<NormalSum> sums(mesh.positions.size());
  const double scale = normal_scale(volume_.geometry());
  const std::vector<std::size_t> slab_first = slab_first_blocks();
  auto add_slab = [&](int z) {
    for (std::size_t a = slab_first[static_cast<std::size_t>(z)];
         a < slab_first[static_cast<std::size_t>(z) + 1]; ++a) {
      const BlockRecord& rec = records_[a];
      for (std::size_t t = rec.triangle_offset; t < rec.triangle_offset + rec.triangle_count; ++t) {
        const auto& tri = mesh.triangles[t];
        const NormalSum n = face_normal_sum(mesh.positions[tri[0]], mesh.positions[tri[1]],
                                            mesh.positions[tri[2]], scale);
        for (int k = 0; k < 3; ++k) sums[tri[static_cast<std::size_t>(k)]] += n;
      }
    }
  };
  const int slabs = nb_.z;
  const int teams = parallel_ ? std::max(1, std::min(omp_get_max_threads(), slabs / 3)) : 1;
  if (teams == 1) {
    for (int z = 0; z < slabs; ++z) add_slab(z);
    return sums;
  }
#pragma omp parallel num_threads(teams)
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    const int z0 = static_cast<int>(static_cast<std::int64_t>(slabs) * t / nt);
    const int z1 = static_cast<int>(static_cast<std::int64_t>(slabs) * (t + 1) / nt);
    for (int z = z0 + 1; z < z1 - 1; ++z) add_slab(z);
#pragma omp barrier
    add_slab(z0);
#pragma omp barrier
    if (z1 - 1 > z0) add_slab(z1 - 1);
  }
  return sums;
}

/// Sizes the mesh (and extras) for the counted vertices and triangles.
void allocate_output(std::size_t vertices, std::size_t triangles, SurfaceMesh& mesh,
                     ExtractionExtras* extras) {
  mesh.positions.resize(vertices);
  mesh.labels.resize(vertices);
  mesh.triangles.resize(triangles);
  if (extras) {
    extras->vertex_keys.resize(vertices);
    extras->triangle_owner.resize(triangles);
    extras->triangle_owner_signature.resize(triangles);
  }
}

/// Unit normals from the fixed-point sums.
void write_unit_normals(const std::vector<NormalSum>& sums, bool parallel, SurfaceMesh& mesh) {
  mesh.normals.resize(sums.size());
#pragma omp parallel for schedule(static) if (parallel)
  for (std::int64_t v = 0; v < static_cast<std::int64_t>(sums.size()); ++v)
    mesh.normals[static_cast<std::size_t>(v)] = unit_normal(sums[static_cast<std::size_t>(v)]);
}

}  // namespace

SurfaceMesh extract_surface_detailed(const VoxelVolume& volume, const SurfaceOptions& options,
                                     SurfaceBuildStats* stats_out, bool compute_normals,
                                     ExtractionExtras* extras) {
  options.validate();
  Stopwatch total;
  SurfaceBuildStats stats;
  BlockedExtraction extraction(volume, options);
  extraction.find_active_blocks(stats);
  stats.threads = extraction.parallel() ? std::max(1, omp_get_max_threads()) : 1;

  Stopwatch clock;
  extraction.count_blocks();
  std::size_t n_vertices = 0, n_triangles = 0;
  extraction.place_blocks(n_vertices, n_triangles);
  stats.mesh_s = clock.seconds();

  clock.restart();
  SurfaceMesh mesh;
  allocate_output(n_vertices, n_triangles, mesh, extras);
  require(extraction.write_blocks(mesh, extras),
          "IMT: a triangle refers to a lattice edge that made no vertex (internal error)");
  stats.assemble_s = clock.seconds();

  clock.restart();
  if (compute_normals || extras) {
    std::vector<NormalSum> sums = extraction.sum_normals(mesh);
    if (compute_normals) write_unit_normals(sums, extraction.parallel(), mesh);
    if (extras) extras->normal_sums = std::move(sums);
  }
  stats.normals_s = clock.seconds();
  stats.total_s = total.seconds();
  if (stats_out) *stats_out = stats;
  return mesh;
}

}  // namespace detail

SurfaceMesh extract_surface(const VoxelVolume& volume, const SurfaceOptions& options,
                            SurfaceBuildStats* stats, bool compute_normals) {
  return detail::extract_surface_detailed(volume, options, stats, compute_normals, nullptr);
}

}  // namespace tsf::imt
