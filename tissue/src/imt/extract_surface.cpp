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

constexpr int kBlock = 16;                    // cubes per block edge
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

}  // namespace

SurfaceMesh extract_surface_detailed(const VoxelVolume& volume, const SurfaceOptions& options,
                                     SurfaceBuildStats* stats_out, bool compute_normals,
                                     ExtractionExtras* extras) {
  options.validate();
  Stopwatch total;
  SurfaceBuildStats stats;
  const VolumeGeometry& geometry = volume.geometry();
  const CubeGrid grid(volume.dims());
  const bool snapping = options.snap_epsilon > 0.0f;
  const int lower = LatticeWindow::margin(snapping);
  const int upper = LatticeWindow::margin(snapping);

  // ---- pass 1: which blocks can hold surface --------------------------------------------------
  const auto ranges = current_brick_ranges(volume, &stats.ranges_s);
  const Int3 nb{(grid.size.x + kBlock - 1) / kBlock, (grid.size.y + kBlock - 1) / kBlock,
                (grid.size.z + kBlock - 1) / kBlock};
  const std::int64_t block_count = nb.volume();
  stats.blocks = static_cast<std::size_t>(block_count);
  std::vector<std::int32_t> active_of_block(static_cast<std::size_t>(block_count), -1);
  auto block_cubes = [&](std::int64_t b, Int3& c0, Int3& c1) {
    const Int3 bi{static_cast<int>(b % nb.x), static_cast<int>((b / nb.x) % nb.y),
                  static_cast<int>(b / (static_cast<std::int64_t>(nb.x) * nb.y))};
    c0 = {bi.x * kBlock - 1, bi.y * kBlock - 1, bi.z * kBlock - 1};
    c1 = {std::min(c0.x + kBlock, grid.size.x - 1), std::min(c0.y + kBlock, grid.size.y - 1),
          std::min(c0.z + kBlock, grid.size.z - 1)};
  };
  {
    std::vector<std::uint8_t> active(static_cast<std::size_t>(block_count), 0);
#pragma omp parallel for schedule(dynamic, 64) if (block_count >= kParallelBricks)
    for (std::int64_t b = 0; b < block_count; ++b) {
      Int3 c0, c1;
      block_cubes(b, c0, c1);
      const Int3 lo{c0.x - lower, c0.y - lower, c0.z - lower};
      const Int3 hi{c1.x + upper - 1, c1.y + upper - 1, c1.z + upper - 1};
      active[static_cast<std::size_t>(b)] = range_straddles(volume, ranges, lo, hi, options.iso);
    }
    std::int32_t n_active = 0;
    for (std::int64_t b = 0; b < block_count; ++b)
      if (active[static_cast<std::size_t>(b)])
        active_of_block[static_cast<std::size_t>(b)] = n_active++;
    stats.active_blocks = static_cast<std::size_t>(n_active);
  }
  std::vector<std::int64_t> active_blocks(stats.active_blocks);
  for (std::int64_t b = 0; b < block_count; ++b)
    if (active_of_block[static_cast<std::size_t>(b)] >= 0)
      active_blocks[static_cast<std::size_t>(active_of_block[static_cast<std::size_t>(b)])] = b;
  const std::size_t n_active = active_blocks.size();
  // Small volumes run on the calling thread: a parallel region costs more than it saves there,
  // and far more when the machine is oversubscribed.
  const bool parallel_blocks = n_active >= kParallelBlocks;

  // ---- pass 2: count each active block's vertices (slot masks) and triangles ------------------
  Stopwatch clock;
  constexpr int kCubesPerBlock = kBlock * kBlock * kBlock;
  std::vector<std::uint16_t> slot_mask(n_active * kCubesPerBlock, 0);
  std::vector<std::uint32_t> slot_prefix(n_active * kCubesPerBlock, 0);
  std::vector<BlockRecord> records(n_active);
  std::vector<std::vector<LatticeWindow::MergedPoint>> merged(n_active);
  stats.threads = parallel_blocks ? std::max(1, omp_get_max_threads()) : 1;
  auto block_local = [](const Int3& c, const Int3& c0) {
    return (c.x - c0.x) + kBlock * ((c.y - c0.y) + kBlock * (c.z - c0.z));
  };
#pragma omp parallel if (parallel_blocks)
  {
    LatticeWindow window;
#pragma omp for schedule(dynamic, 4)
    for (std::int64_t a = 0; a < static_cast<std::int64_t>(n_active); ++a) {
      Int3 c0, c1;
      block_cubes(active_blocks[static_cast<std::size_t>(a)], c0, c1);
      window.compute(volume, options, c0, c1);
      std::uint16_t* mask = &slot_mask[static_cast<std::size_t>(a) * kCubesPerBlock];
      std::uint32_t* prefix = &slot_prefix[static_cast<std::size_t>(a) * kCubesPerBlock];
      std::uint32_t vertices = 0;
      std::size_t triangles = 0;
      for (const auto& cube : window.relevant_cubes()) {
        const int bl = block_local(cube.c, c0);
        prefix[bl] = vertices;
        mask[bl] = window.referenced_slots(cube.local);
        vertices += popcount16(mask[bl]);
        triangles += static_cast<std::size_t>(window.count_triangles(cube.local));
      }
      if (snapping) window.merged_points(merged[static_cast<std::size_t>(a)]);
      records[static_cast<std::size_t>(a)].vertex_count = vertices;
      records[static_cast<std::size_t>(a)].triangle_count = triangles;
    }
  }

  // ---- pass 3: offsets; then each block writes its vertices and triangles in place -------------
  std::size_t n_vertices = 0, n_triangles = 0;
  for (BlockRecord& rec : records) {
    rec.vertex_offset = n_vertices;
    rec.triangle_offset = n_triangles;
    n_vertices += rec.vertex_count;
    n_triangles += rec.triangle_count;
  }
  stats.mesh_s = clock.seconds();
  clock.restart();
  SurfaceMesh mesh;
  mesh.positions.resize(n_vertices);
  mesh.labels.resize(n_vertices);
  mesh.triangles.resize(n_triangles);
  if (extras) {
    extras->vertex_keys.resize(n_vertices);
    extras->triangle_owner.resize(n_triangles);
    extras->triangle_owner_signature.resize(n_triangles);
  }
  std::atomic<bool> broken_reference{false};
#pragma omp parallel if (parallel_blocks)
  {
    LatticeWindow window;
#pragma omp for schedule(dynamic, 4)
    for (std::int64_t a = 0; a < static_cast<std::int64_t>(n_active); ++a) {
      Int3 c0, c1;
      block_cubes(active_blocks[static_cast<std::size_t>(a)], c0, c1);
      window.compute_replaying(volume, options, c0, c1, merged[static_cast<std::size_t>(a)]);
      const BlockRecord& rec = records[static_cast<std::size_t>(a)];
      const std::uint16_t* mask = &slot_mask[static_cast<std::size_t>(a) * kCubesPerBlock];
      std::size_t v = rec.vertex_offset;
      for (const auto& cube : window.relevant_cubes()) {
        const Int3& c = cube.c;
        for (unsigned bits = mask[block_local(c, c0)]; bits; bits &= bits - 1) {
          const int slot = __builtin_ctz(bits);
          Vec3d ip;
          window.vertex(c, cube.local, slot, ip, mesh.labels[v]);
          mesh.positions[v] = tissue_position(geometry, ip);
          if (extras) extras->vertex_keys[v] = grid.key(c, slot);
          ++v;
        }
      }
      std::size_t t = rec.triangle_offset;
      const std::size_t t_end = rec.triangle_offset + rec.triangle_count;
      for (const auto& cube : window.relevant_cubes()) {
        const Int3& c = cube.c;
        const std::uint64_t owner = grid.linear(c);
        const std::uint32_t signature = extras ? window.signature(cube.local) : 0u;
        window.mesh_cube(cube.local, [&](const LatticeRef* keys) {
          if (t >= t_end) {  // pass 3 must make what pass 2 counted
            broken_reference = true;
            return;
          }
          auto& tri = mesh.triangles[t];
          for (int k = 0; k < 3; ++k) {
            const Int3 o{c.x + keys[k].offset[0] + 1, c.y + keys[k].offset[1] + 1,
                         c.z + keys[k].offset[2] + 1};  // u coordinates of the owner cube
            std::uint32_t id = 0;
            if (o.x >= 0 && o.y >= 0 && o.z >= 0 && o.x < grid.size.x && o.y < grid.size.y &&
                o.z < grid.size.z) {
              const std::int64_t ob =
                  (o.x / kBlock) +
                  nb.x * ((o.y / kBlock) + static_cast<std::int64_t>(nb.y) * (o.z / kBlock));
              const std::int32_t oa = active_of_block[static_cast<std::size_t>(ob)];
              const int ol = (o.x % kBlock) + kBlock * ((o.y % kBlock) + kBlock * (o.z % kBlock));
              const std::size_t at =
                  static_cast<std::size_t>(oa) * kCubesPerBlock + static_cast<std::size_t>(ol);
              if (oa >= 0 && ((slot_mask[at] >> keys[k].slot) & 1u)) {
                id = static_cast<std::uint32_t>(
                    records[static_cast<std::size_t>(oa)].vertex_offset + slot_prefix[at] +
                    popcount16(
                        static_cast<std::uint16_t>(slot_mask[at] & ((1u << keys[k].slot) - 1u))));
              } else {
                broken_reference = true;
              }
            } else {
              broken_reference = true;
            }
            tri[static_cast<std::size_t>(k)] = id;
          }
          if (extras) {
            extras->triangle_owner[t] = owner;
            extras->triangle_owner_signature[t] = signature;
          }
          ++t;
        });
      }
      if (t != t_end || v != rec.vertex_offset + rec.vertex_count) broken_reference = true;
    }
  }
  require(!broken_reference,
          "IMT: a triangle refers to a lattice edge that made no vertex (internal error)");
  stats.assemble_s = clock.seconds();

  // ---- normals: fixed-point sums ---------------------------------------------------------------
  // A triangle of a block touches vertices of blocks one slab (z) away at most. Each thread takes
  // a contiguous range of slabs: the inside of every range first (ranges' vertices are then
  // disjoint), then the first slabs of all ranges, then the last ones — three barriers, whatever
  // the volume size (barriers are what hurts when the machine is oversubscribed).
  clock.restart();
  if (compute_normals || extras) {
    std::vector<NormalSum> sums(n_vertices);
    const double scale = normal_scale(geometry);
    std::vector<std::size_t> slab_first(static_cast<std::size_t>(nb.z) + 1, n_active);
    for (std::size_t a = n_active; a-- > 0;)  // active blocks are in z-major order
      slab_first[static_cast<std::size_t>(active_blocks[a] /
                                          (static_cast<std::int64_t>(nb.x) * nb.y))] = a;
    for (int z = nb.z - 1; z >= 0; --z)
      slab_first[static_cast<std::size_t>(z)] = std::min(
          slab_first[static_cast<std::size_t>(z)], slab_first[static_cast<std::size_t>(z) + 1]);
    auto add_slab = [&](int z) {
      for (std::size_t a = slab_first[static_cast<std::size_t>(z)];
           a < slab_first[static_cast<std::size_t>(z) + 1]; ++a) {
        const BlockRecord& rec = records[a];
        for (std::size_t t = rec.triangle_offset; t < rec.triangle_offset + rec.triangle_count;
             ++t) {
          const auto& tri = mesh.triangles[t];
          const NormalSum n = face_normal_sum(mesh.positions[tri[0]], mesh.positions[tri[1]],
                                              mesh.positions[tri[2]], scale);
          for (int k = 0; k < 3; ++k) sums[tri[static_cast<std::size_t>(k)]] += n;
        }
      }
    };
    const int slabs = nb.z;
    const int teams = parallel_blocks ? std::max(1, std::min(omp_get_max_threads(), slabs / 3)) : 1;
    if (teams == 1) {
      for (int z = 0; z < slabs; ++z) add_slab(z);
    } else {
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
    }
    if (compute_normals) {
      mesh.normals.resize(n_vertices);
#pragma omp parallel for schedule(static) if (parallel_blocks)
      for (std::int64_t v = 0; v < static_cast<std::int64_t>(n_vertices); ++v)
        mesh.normals[static_cast<std::size_t>(v)] = unit_normal(sums[static_cast<std::size_t>(v)]);
    }
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
