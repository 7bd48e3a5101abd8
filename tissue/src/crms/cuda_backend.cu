// CUDA backend: the per-node physics of node_force.h / node_update.h in thin kernels.
//
// Kernels of one step:
// * per node (gather form, ForceEvaluation::kPerNode): one thread per node evaluates the node's
//   whole stencil and integrates it.
// * shared (symmetric form, the default): each angle is evaluated once (node_force.h). A thread
//   block owns a tile of 32 × kRows columns and marches through `planes` z-planes: for plane t
//   every thread evaluates its node's terms (self + 6 reactions, 7-node stencil); the in-plane
//   reactions go through shared memory (double-buffered by plane parity, one barrier per plane),
//   the z-reactions stay in the thread's registers (the z-neighbours are the same thread's
//   previous and next planes). Halo work: the 2·(32 + kRows) nodes around the tile and the planes
//   just below and above the block's z-range evaluate only their reaction towards it (4 angles
//   instead of 12). Plane t − 1 is finished (force, integration, store) while plane t is
//   evaluated. Global memory traffic: the state once per step plus the tile borders (L1/L2).
//   Tiles in which no node moves (dead or anchored: most of a patient's lattice box) only copy
//   their state (TilePlan). Two kernels do this (CudaTileKernel): the staged one (the default of
//   the graphs launch, staged_tile_step) first copies each plane's state of the tile and its ring
//   into shared memory and splits the halo's reactions over two threads; the direct one
//   (shared_tile_step, also the persistent launch's) reads neighbours from global memory.
// * node-parallel (symmetric form, small lattices, CudaLaunch::kNodes): every alive node's terms
//   split over three threads by angle plane (node_force_planes.h), then a pass that sums and
//   integrates; see node_step_kernel.
//
// The lattice and both state buffers live on the device for the solver's lifetime; the host sees
// them only through explicit queries. How the n steps of a call are launched (CudaLaunch):
// * graphs: CUDA graphs of `steps_per_graph` kernels (ping-pong buffers baked in, the graph count
//   even so the current buffer returns to where it started), which removes the per-launch CPU
//   cost; a remainder runs as plain launches;
// * persistent: one cooperative launch of the tile kernel's body for all n steps, a grid barrier
//   between steps;
// * nodes (the default up to 2^18 nodes where bricks are not): one cooperative launch of the
//   node-parallel kernel, two grid barriers per step. On a small lattice a step's arithmetic is
//   shorter than a launch, and its time is set by one thread's chain of dependent instructions,
//   which the split into planes cuts to a third (docs/crms.md "Small lattices");
// * bricks (the default where every brick of the lattice has a resident block): one cooperative
//   launch of cuda_brick_step.cuh, one grid barrier per step.
// A guard word in device memory records the first non-finite node; kernels of later steps see it
// and copy their input unchanged, so the state stays finite and the host learns about it at the
// next synchronize(). The stability monitor's signals (energies, velocity sums against the state
// before the last step, which is the other ping-pong buffer) are one reduction pass and a
// read-back of nine numbers (step_signals).
//
// Snapshots: a kernel writes positions (rest + u) into a device staging buffer on the compute
// stream; a side stream copies staging → pinned host (the SnapshotBuffer's back buffer) after an
// event, and the next poll publishes it. The solver never waits for that copy; a request while
// one is in flight is dropped.
#include <cooperative_groups.h>
#include <cuda_pipeline.h>
#include <cuda_runtime.h>

#include <algorithm>
#include <climits>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "solver_backend.h"
#include "tsf/common/cuda_check.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/device_buffer.h"
#include "tsf/common/error.h"
#include "tsf/crms/device_bandwidth.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/node_energy.h"
#include "tsf/crms/node_force_planes.h"
#include "tsf/crms/node_update.h"
#include "tsf/crms/stencil.h"
#include "tsf/crms/volume_term.h"

namespace tsf::crms {
namespace {

constexpr unsigned long long kNoNode = ULLONG_MAX;
/// The node-parallel launch is the default (CudaLaunch::kAuto) for lattices of up to kNodesMaxNodes
/// nodes (its terms, 180 bytes a node, stay in L2) with up to kNodesMaxAlive alive ones: above
/// that, graphs of the tile kernel step faster (docs/crms.md "Small lattices", measured on an
/// H200: cubes of 195 k nodes 37 µs a step with graphs against 39 µs).
constexpr std::int64_t kNodesMaxNodes = std::int64_t{1} << 18;
constexpr std::int64_t kNodesMaxAlive = std::int64_t{1} << 17;
constexpr long long kNoStep = LLONG_MAX;

/// Device-side guard and step counter.
struct Guard {
  unsigned long long bad_node;  ///< lowest failing node of the failing step
  long long bad_step;           ///< failing step, kNoStep while none
  long long step_base;          ///< steps completed before the current launch batch
};

/// Writes node n's new state and, when it is not finite, records it in the guard (every failing
/// thread of a step writes the same step; the lowest node wins).
__device__ __forceinline__ void store_node_step(const StateView& out, std::int64_t n,
                                                const NodeStepResult& r, Guard* guard,
                                                long long step) {
  out.u[0][n] = r.u.x, out.u[1][n] = r.u.y, out.u[2][n] = r.u.z;
  out.v[0][n] = r.v.x, out.v[1][n] = r.v.y, out.v[2][n] = r.v.z;
  if (!r.finite) {
    guard->bad_step = step;
    atomicMin(&guard->bad_node, static_cast<unsigned long long>(n));
  }
}

/// The volumetric term as the brick and node-parallel kernels see it (FoldedVolumeTerm): off, or
/// folded into every step of the launch.
struct VolumeFold {
  bool on = false;
  FoldedVolumeTerm term;
};

/// The folded volumetric term's kick (kick_after_step) on a moving node's step result r, whose
/// state before the step had displacement u_before; a non-finite result is kept out as
/// integrate_node keeps one (u kept, v = 0) and reported by store_node_step.
__device__ __forceinline__ void kick_step_result(NodeStepResult& r, const Vec3f& u_before,
                                                 const Vec3f& force, float inv_mass,
                                                 const StepParameters& p) {
  if (!r.finite) return;
  kick_after_step(r.u, r.v, force, inv_mass, p.dt, p.velocity_limit,
                  p.scheme != static_cast<int>(ExplicitScheme::kExplicitEuler));
  r.finite = crms_finite(r.u) & crms_finite(r.v);
  if (!r.finite) {
    r.u = u_before;
    r.v = {0.0f, 0.0f, 0.0f};
  }
}

static_assert(sizeof(StepParameters) == sizeof(float) * 6 + sizeof(int) + sizeof(MaterialPalette),
              "StepParameters must have no padding: graphs are keyed on its bytes");

static_assert(sizeof(Vec3f) == 3 * sizeof(float), "Vec3f arrays are copied as float triples");

const dim3 kBlock(32, 4, 2);

template <unsigned F>
__global__ void __launch_bounds__(256)
    step_kernel(LatticeView lat, ConstStateView in, StateView out, StepParameters p, Guard* guard,
                int local_step) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const int j = blockIdx.y * blockDim.y + threadIdx.y;
  const int k = blockIdx.z * blockDim.z + threadIdx.z;
  if (i >= lat.dims.x || j >= lat.dims.y || k >= lat.dims.z) return;
  const std::int64_t n = i + j * lat.stride_y + k * lat.stride_z;
  const long long step = guard->step_base + local_step;
  if (guard->bad_step < step) {  // halted by an earlier step: keep the state as it is
    for (int a = 0; a < 3; ++a) {
      out.u[a][n] = in.u[a][n];
      out.v[a][n] = in.v[a][n];
    }
    return;
  }
  const IndexedStencil st{lat, in, n, i, j, k};
  const NodeStepResult r = step_node<F>(st, lat.rest_length, p);
  store_node_step(out, n, r, guard, step);
}

constexpr int kTileX = 32;

__device__ __forceinline__ Vec3f select_if(bool on, const Vec3f& a) {
  return {on ? a.x : 0.0f, on ? a.y : 0.0f, on ? a.z : 0.0f};
}

/// The tiles of the shared evaluation: 32 × rows columns of nodes, `planes` z-planes deep, listed
/// active first (a tile is active when one of its nodes moves: alive and not fixed); an idle tile
/// only copies its displacements and zeroes its velocities, which is what integrate_node gives
/// every node that does not move, whatever its force.
struct TilePlan {
  int tiles_x = 1, tiles_y = 1, tiles_z = 1;
  int planes = 1;
  int count = 0;                ///< tiles_x · tiles_y · tiles_z
  const int* list = nullptr;    ///< tile indices, the active ones first
  const int* active = nullptr;  ///< device word: how many of `list` are active
};

/// In-plane reactions of a tile and its halo, by plane parity:
/// [parity][0: reaction +x, 1: −x, 2: +y, 3: −y][component][row][column].
template <int kRows>
using InPlane = float[2][4][3][kRows + 2][kTileX + 2];

/// The in-plane reactions node (r, c) of a tile receives from its linked neighbours: −x sent its
/// +x reaction (q 0), +x its −x (q 1), −y its +y (q 2), +y its −y (q 3).
template <int kRows>
__device__ __forceinline__ Vec3f in_plane_reactions(const InPlane<kRows>& in_plane, int parity,
                                                    int r, int c, unsigned fl) {
  const int dr[4] = {0, 0, -1, 1}, dc[4] = {-1, 1, 0, 0};
  Vec3f f{0.0f, 0.0f, 0.0f};
#pragma unroll
  for (int q = 0; q < 4; ++q) {
    const int rr = r + dr[q], cc = c + dc[q];
    f += select_if(((fl >> q) & 1u) != 0,
                   Vec3f{in_plane[parity][q][0][rr][cc], in_plane[parity][q][1][rr][cc],
                         in_plane[parity][q][2][rr][cc]});
  }
  return f;
}

/// A step of the nodes of one tile that no node of moves: u kept, v = 0 (integrate_node).
__device__ void idle_tile_step(const LatticeView& lat, const ConstStateView& in,
                               const StateView& out, int i0, int j0, int k0, int k1, bool halted,
                               int rows) {
  const int tid = threadIdx.x + kTileX * threadIdx.y;
  const int i = i0 + tid % kTileX, j = j0 + tid / kTileX;
  if (tid >= kTileX * rows || i >= lat.dims.x || j >= lat.dims.y) return;
  for (int k = k0; k < k1; ++k) {
    const std::int64_t n = i + j * lat.stride_y + static_cast<std::int64_t>(k) * lat.stride_z;
    for (int a = 0; a < 3; ++a) {
      out.u[a][n] = in.u[a][n];
      out.v[a][n] = halted ? in.v[a][n] : 0.0f;
    }
  }
}

/// The shared evaluation of the symmetric form for one tile (see header). Block (32, kRows).
template <unsigned F, int kRows>
__device__ void shared_tile_step(const LatticeView& lat, const ConstStateView& in,
                                 const StateView& out, const StepParameters& p, Guard* guard,
                                 long long step, bool halted, int bx, int by, int bz, int planes,
                                 InPlane<kRows>& in_plane) {
  static_assert((F & features::kSymmetricReactions) != 0, "shared evaluation is symmetric only");
  const int nx = lat.dims.x, ny = lat.dims.y, nz = lat.dims.z;
  const int tx = threadIdx.x, ty = threadIdx.y;
  const int i0 = bx * kTileX, j0 = by * kRows;
  const int i = i0 + tx, j = j0 + ty;
  const int k0 = bz * planes;
  const int k1 = min(k0 + planes, nz);
  const bool inside = i < nx && j < ny;
  const std::int64_t column = i + j * lat.stride_y;
  if (halted) {  // halted by an earlier step (uniform): keep the state
    if (inside)
      for (int k = k0; k < k1; ++k) {
        const std::int64_t n = column + k * lat.stride_z;
        for (int a = 0; a < 3; ++a) {
          out.u[a][n] = in.u[a][n];
          out.v[a][n] = in.v[a][n];
        }
      }
    return;
  }

  // This thread's halo node, if any: the rows below/above the tile, then the columns left/right.
  const int tid = tx + kTileX * ty;
  int hi = -1, hj = -1, hd = 0, hq = 0, hr = 0, hc = 0;
  if (tid < kTileX) {
    hi = i0 + tid, hj = j0 - 1, hd = 3, hq = 2, hr = 0, hc = tid + 1;
  } else if (tid < 2 * kTileX) {
    hi = i0 + tid - kTileX, hj = j0 + kRows, hd = 2, hq = 3, hr = kRows + 1, hc = tid - kTileX + 1;
  } else if (tid < 2 * kTileX + kRows) {
    hi = i0 - 1, hj = j0 + tid - 2 * kTileX, hd = 1, hq = 0, hr = tid - 2 * kTileX + 1, hc = 0;
  } else if (tid < 2 * kTileX + 2 * kRows) {
    hi = i0 + kTileX, hj = j0 + tid - 2 * kTileX - kRows, hd = 0, hq = 1;
    hr = tid - 2 * kTileX - kRows + 1, hc = kTileX + 1;
  }
  const bool has_halo_slot = tid < 2 * kTileX + 2 * kRows;
  const bool halo_inside = has_halo_slot && hi >= 0 && hi < nx && hj >= 0 && hj < ny;

  const Vec3f zero{0.0f, 0.0f, 0.0f};
  Vec3f up_two = zero, up_one = zero;  // reaction[+z] of planes t − 2 and t − 1 (this column)
  Vec3f partial = zero;                // plane t − 1: self + in-plane reactions received
  for (int t = k0 - 1; t <= k1; ++t) {
    const int parity = t & 1;
    const bool plane_inside = t >= 0 && t < nz;
    const std::int64_t n = column + static_cast<std::int64_t>(t) * lat.stride_z;
    Vec3f up = zero, down = zero, self = zero;  // reaction[+z], reaction[−z], self of plane t
    if (t == k0 - 1 || t == k1) {
      // A plane just outside the block: only its reaction towards the block.
      if (inside && plane_inside) {
        const IndexedStencil st{lat, in, n, i, j, t};
        if (t == k0 - 1)
          up = reaction_towards<F>(st, 5, lat.rest_length, p.palette);
        else
          down = reaction_towards<F>(st, 4, lat.rest_length, p.palette);
      }
    } else {
      NodeSpringTerms<float> terms;
      if (inside) {
        const IndexedStencil st{lat, in, n, i, j, t};
        node_spring_terms<F>(st, lat.rest_length, p.palette, terms);
      } else {
        terms.self = zero;
        for (int d = 0; d < 6; ++d) terms.reaction[d] = zero;
      }
      const int sends[4] = {1, 0, 3, 2};  // reaction towards +x, −x, +y, −y
#pragma unroll
      for (int q = 0; q < 4; ++q) {
        in_plane[parity][q][0][ty + 1][tx + 1] = terms.reaction[sends[q]].x;
        in_plane[parity][q][1][ty + 1][tx + 1] = terms.reaction[sends[q]].y;
        in_plane[parity][q][2][ty + 1][tx + 1] = terms.reaction[sends[q]].z;
      }
      up = terms.reaction[5];
      down = terms.reaction[4];
      self = terms.self;
      if (has_halo_slot) {
        Vec3f r = zero;
        if (halo_inside) {
          const std::int64_t nh =
              hi + hj * lat.stride_y + static_cast<std::int64_t>(t) * lat.stride_z;
          const IndexedStencil st{lat, in, nh, hi, hj, t};
          r = reaction_towards<F>(st, hd, lat.rest_length, p.palette);
        }
        in_plane[parity][hq][0][hr][hc] = r.x;
        in_plane[parity][hq][1][hr][hc] = r.y;
        in_plane[parity][hq][2][hr][hc] = r.z;
      }
    }

    // Finish plane t − 1: its z-neighbours' reactions are in this thread's registers.
    const int kf = t - 1;
    if (kf >= k0 && kf < k1 && inside) {
      const std::int64_t nf = column + static_cast<std::int64_t>(kf) * lat.stride_z;
      const unsigned fl = lat.flags[nf];
      Vec3f f = partial;
      f += select_if(((fl >> 4) & 1u) != 0, up_two);
      f += select_if(((fl >> 5) & 1u) != 0, down);
      Vec3f external = zero;
      if constexpr ((F & features::kExternalForces) != 0)
        external = {lat.external_force[0][nf], lat.external_force[1][nf],
                    lat.external_force[2][nf]};
      const Vec3f u{in.u[0][nf], in.u[1][nf], in.u[2][nf]};
      const Vec3f v{in.v[0][nf], in.v[1][nf], in.v[2][nf]};
      const NodeStepResult r = integrate_node<F>(fl, u, v, lat.inv_mass[nf], external, f, p);
      store_node_step(out, nf, r, guard, step);
    }
    __syncthreads();  // in_plane[parity] complete (and the other parity free for plane t + 1)
    if (t >= k0 && t < k1 && inside) {
      const unsigned fl = lat.flags[n];
      const int r = ty + 1, c = tx + 1;
      Vec3f f = self;
      f += in_plane_reactions<kRows>(in_plane, parity, r, c, fl);
      partial = f;
    }
    up_two = up_one;
    up_one = up;
  }
}

/// Tile `q` of the plan: its coordinates, and whether it is active.
__device__ __forceinline__ void plan_tile(const TilePlan& plan, int q, int& bx, int& by, int& bz,
                                          bool& active) {
  const int tile = plan.list[q];
  bx = tile % plan.tiles_x;
  by = (tile / plan.tiles_x) % plan.tiles_y;
  bz = tile / (plan.tiles_x * plan.tiles_y);
  active = q < *plan.active;
}

/// Whether the guard halted the solver before `step` (read from memory every time: another
/// block may have written it before the last grid barrier).
__device__ __forceinline__ bool halted_before(const Guard* guard, long long step) {
  return *reinterpret_cast<const volatile long long*>(&guard->bad_step) < step;
}

/// One step of the shared evaluation: block q of the grid does tile q of the plan.
template <unsigned F, int kRows>
__global__ void __launch_bounds__(kTileX* kRows, 2048 / (kTileX * kRows) / 4)
    shared_step_kernel(LatticeView lat, ConstStateView in, StateView out, StepParameters p,
                       Guard* guard, int local_step, TilePlan plan) {
  __shared__ InPlane<kRows> in_plane;
  const long long step = guard->step_base + local_step;
  const bool halted = halted_before(guard, step);
  int bx, by, bz;
  bool active;
  plan_tile(plan, blockIdx.x, bx, by, bz, active);
  if (active)
    shared_tile_step<F, kRows>(lat, in, out, p, guard, step, halted, bx, by, bz, plan.planes,
                               in_plane);
  else
    idle_tile_step(lat, in, out, bx * kTileX, by * kRows, bz * plan.planes,
                   min(bz * plan.planes + plan.planes, lat.dims.z), halted, kRows);
}

/// The staged tile kernel (CudaTileKernel::kStaged, the default of the graphs launch; docs/crms.md
/// "The default kernel against the roofline"): shared_tile_step's evaluation with each plane's
/// state (u, v, 1/m, flags) of the tile and its one-node ring, corners included, staged in shared
/// memory, so the stencil reads are shared-memory loads at fixed offsets instead of L1/L2 loads
/// behind 64-bit address arithmetic. A ring of four planes: while plane t is evaluated (it reads
/// planes t − 1, t and t + 1, and finishes t − 1), plane t + 2 streams in (cp.async) into the slot
/// of plane t − 2, whose last reader passed the previous barrier; one barrier per plane as before.
/// The halo's reaction towards the tile (4 angles) is split over two threads by angle plane
/// (add_reaction_towards_in_plane) where the block has the threads, which halves the extra work
/// of the threads that also evaluate the halo (the others wait for them at the barrier).
template <int kRows>
struct StagedTile {
  static constexpr int kPitch = kTileX + 2;            ///< cells per staged row
  static constexpr int kCells = (kRows + 2) * kPitch;  ///< cells per staged plane
  static constexpr int kArrays = 7;                    ///< u x/y/z, v x/y/z, 1/m
  static constexpr int kRing = 4;                      ///< planes held
  static constexpr int kThreads = kTileX * kRows;
  static constexpr int kHalo = 2 * kTileX + 2 * kRows;              ///< halo nodes per plane
  static constexpr int kHaloSplit = 2 * kHalo <= kThreads ? 2 : 1;  ///< threads per halo node
  static constexpr std::size_t kRingOffset = sizeof(InPlane<kRows>);
  static constexpr std::size_t kFlagsOffset =
      kRingOffset + sizeof(float) * kRing * kArrays * kCells;
  static constexpr std::size_t kBytes = kFlagsOffset + kRing * kCells;
};

/// Stencil accessor over the staged planes (the 7-node stencil of node_spring_terms and
/// reaction_towards; no edge-diagonal slots): slot 0 the cell, 1 + d its face neighbour d.
template <int kRows>
struct StagedStencil {
  using Scalar = float;
  static constexpr int kPitch = StagedTile<kRows>::kPitch;
  static constexpr int kCells = StagedTile<kRows>::kCells;
  const float* below;  ///< plane t − 1, array 0 (the arrays follow kCells apart)
  const float* here;   ///< plane t
  const float* above;  ///< plane t + 1
  const std::uint8_t* flags_below;
  const std::uint8_t* flags_here;
  const std::uint8_t* flags_above;
  int cell;
  // Material lookups (heterogeneous lattices) read the global arrays.
  const LatticeView* lattice;
  std::int64_t n;
  int i, j, k;

  __device__ __forceinline__ int offset(int slot) const {
    return cell + (slot == 1 ? -1 : slot == 2 ? 1 : slot == 3 ? -kPitch : slot == 4 ? kPitch : 0);
  }
  __device__ __forceinline__ const float* plane(int slot) const {
    return slot == 5 ? below : (slot == 6 ? above : here);
  }
  __device__ __forceinline__ Vec3f u(int slot) const {
    const float* p = plane(slot) + offset(slot);
    return {p[0], p[kCells], p[2 * kCells]};
  }
  __device__ __forceinline__ Vec3f v(int slot) const {
    const float* p = plane(slot) + offset(slot);
    return {p[3 * kCells], p[4 * kCells], p[5 * kCells]};
  }
  __device__ __forceinline__ unsigned flags(int slot) const {
    const std::uint8_t* f = slot == 5 ? flags_below : (slot == 6 ? flags_above : flags_here);
    return f[offset(slot)];
  }
  __device__ __forceinline__ MaterialBlend material(int slot) const {
    return node_material(*lattice, stencil_node(*lattice, n, i, j, k, slot));
  }
};

/// The staged evaluation of the symmetric form for one tile (see StagedTile). Block (32, kRows);
/// `smem` holds StagedTile<kRows>::kBytes.
template <unsigned F, int kRows>
__device__ void staged_tile_step(const LatticeView& lat, const ConstStateView& in,
                                 const StateView& out, const StepParameters& p, Guard* guard,
                                 long long step, bool halted, int bx, int by, int bz, int planes,
                                 unsigned char* smem) {
  static_assert((F & features::kSymmetricReactions) != 0, "shared evaluation is symmetric only");
  using Tile = StagedTile<kRows>;
  constexpr int kPitch = Tile::kPitch, kCells = Tile::kCells, kThreads = Tile::kThreads;
  constexpr int kPlane = Tile::kArrays * kCells;  // floats per staged plane
  constexpr int kSplit = Tile::kHaloSplit;
  InPlane<kRows>& in_plane = *reinterpret_cast<InPlane<kRows>*>(smem);
  float* const ring = reinterpret_cast<float*>(smem + Tile::kRingOffset);
  std::uint8_t* const ring_flags = smem + Tile::kFlagsOffset;

  const int nx = lat.dims.x, ny = lat.dims.y, nz = lat.dims.z;
  const int tx = threadIdx.x, ty = threadIdx.y;
  const int tid = tx + kTileX * ty;
  const int i0 = bx * kTileX, j0 = by * kRows;
  const int i = i0 + tx, j = j0 + ty;
  const int k0 = bz * planes;
  const int k1 = min(k0 + planes, nz);
  const bool inside = i < nx && j < ny;
  const std::int64_t column = i + j * lat.stride_y;
  if (halted) {  // halted by an earlier step (uniform): keep the state
    if (inside)
      for (int k = k0; k < k1; ++k) {
        const std::int64_t n = column + k * lat.stride_z;
        for (int a = 0; a < 3; ++a) {
          out.u[a][n] = in.u[a][n];
          out.v[a][n] = in.v[a][n];
        }
      }
    return;
  }
  const int cell = (ty + 1) * kPitch + tx + 1;

  // The cells this thread stages: e = tid and tid + kThreads (row-major over the ring's rows).
  std::int64_t stage_column[2];
  bool stage_inside[2];
  const bool stage_second = tid + kThreads < kCells;
#pragma unroll
  for (int s = 0; s < 2; ++s) {
    const int e = tid + s * kThreads;
    const int si = i0 - 1 + e % kPitch, sj = j0 - 1 + e / kPitch;
    stage_inside[s] = (s == 0 || stage_second) && si >= 0 && si < nx && sj >= 0 && sj < ny;
    stage_column[s] = si + sj * lat.stride_y;
  }
  const float* const sources[Tile::kArrays] = {in.u[0], in.u[1], in.u[2],     in.v[0],
                                               in.v[1], in.v[2], lat.inv_mass};
  // Starts copying plane t into its ring slot (cp.async; cells outside the lattice are zeroed)
  // and returns the flags of this thread's cells, which the caller stores later (a byte cannot
  // be copied asynchronously): their load then overlaps the evaluation.
  auto stage = [&](int t, std::uint8_t flags_out[2]) {
    float* slot = ring + (t & 3) * kPlane;
    const bool plane_in = t >= 0 && t < nz;
#pragma unroll
    for (int s = 0; s < 2; ++s) {
      flags_out[s] = 0;
      if (s == 1 && !stage_second) break;
      const int e = tid + s * kThreads;
      if (plane_in && stage_inside[s]) {
        const std::int64_t n = stage_column[s] + static_cast<std::int64_t>(t) * lat.stride_z;
#pragma unroll
        for (int a = 0; a < Tile::kArrays; ++a)
          __pipeline_memcpy_async(slot + a * kCells + e, sources[a] + n, sizeof(float));
        flags_out[s] = lat.flags[n];
      } else {
#pragma unroll
        for (int a = 0; a < Tile::kArrays; ++a) slot[a * kCells + e] = 0.0f;
      }
    }
    __pipeline_commit();
  };
  auto store_flags = [&](int t, const std::uint8_t flags_in[2]) {
    std::uint8_t* f = ring_flags + (t & 3) * kCells;
    f[tid] = flags_in[0];
    if (stage_second) f[tid + kThreads] = flags_in[1];
  };
  {
    std::uint8_t f0[2], f1[2];
    stage(k0 - 1, f0);
    stage(k0, f1);
    store_flags(k0 - 1, f0);
    store_flags(k0, f1);
    __pipeline_wait_prior(0);
    __syncthreads();
  }

  // This thread's halo item, if any: halo node h (the rows below/above the tile, then the
  // columns left/right) and, split over two threads, the angle plane q of its reaction.
  const int h = kSplit == 2 ? tid >> 1 : tid;
  const int hplane = kSplit == 2 ? tid & 1 : 0;
  int hi = -1, hj = -1, hd = 0, hq = 0, hr = 0, hc = 0;
  if (h < kTileX) {
    hi = i0 + h, hj = j0 - 1, hd = 3, hq = 2, hr = 0, hc = h + 1;
  } else if (h < 2 * kTileX) {
    hi = i0 + h - kTileX, hj = j0 + kRows, hd = 2, hq = 3, hr = kRows + 1, hc = h - kTileX + 1;
  } else if (h < 2 * kTileX + kRows) {
    hi = i0 - 1, hj = j0 + h - 2 * kTileX, hd = 1, hq = 0, hr = h - 2 * kTileX + 1, hc = 0;
  } else if (h < Tile::kHalo) {
    hi = i0 + kTileX, hj = j0 + h - 2 * kTileX - kRows, hd = 0, hq = 1;
    hr = h - 2 * kTileX - kRows + 1, hc = kTileX + 1;
  }
  const bool has_halo_item = h < Tile::kHalo;
  const bool halo_inside = has_halo_item && hi >= 0 && hi < nx && hj >= 0 && hj < ny;
  const bool halo_writer = has_halo_item && hplane == 0;
  const int halo_cell = hr * kPitch + hc;

  const Vec3f zero{0.0f, 0.0f, 0.0f};
  Vec3f up_two = zero, up_one = zero;  // reaction[+z] of planes t − 2 and t − 1 (this column)
  Vec3f partial = zero;                // plane t − 1: self + in-plane reactions received
  for (int t = k0 - 1; t <= k1; ++t) {
    const int parity = t & 1;
    const bool staging = t + 2 <= k1;  // uniform
    std::uint8_t next_flags[2];
    if (staging) stage(t + 2, next_flags);
    const float* below = ring + ((t - 1) & 3) * kPlane;
    const float* here = ring + (t & 3) * kPlane;
    const float* above = ring + ((t + 1) & 3) * kPlane;
    const std::uint8_t* flags_below = ring_flags + ((t - 1) & 3) * kCells;
    const std::uint8_t* flags_here = ring_flags + (t & 3) * kCells;
    const std::uint8_t* flags_above = ring_flags + ((t + 1) & 3) * kCells;
    const bool plane_inside = t >= 0 && t < nz;
    const std::int64_t n = column + static_cast<std::int64_t>(t) * lat.stride_z;
    const StagedStencil<kRows> st{below, here, above, flags_below, flags_here, flags_above,
                                  cell,  &lat, n,     i,           j,          t};
    Vec3f up = zero, down = zero, self = zero;  // reaction[+z], reaction[−z], self of plane t
    if (t == k0 - 1 || t == k1) {
      // A plane just outside the block: only its reaction towards the block.
      if (inside && plane_inside) {
        if (t == k0 - 1)
          up = reaction_towards<F>(st, 5, lat.rest_length, p.palette);
        else
          down = reaction_towards<F>(st, 4, lat.rest_length, p.palette);
      }
    } else {
      NodeSpringTerms<float> terms;
      if (inside) {
        node_spring_terms<F>(st, lat.rest_length, p.palette, terms);
      } else {
        terms.self = zero;
        for (int d = 0; d < 6; ++d) terms.reaction[d] = zero;
      }
      const int sends[4] = {1, 0, 3, 2};  // reaction towards +x, −x, +y, −y
#pragma unroll
      for (int q = 0; q < 4; ++q) {
        in_plane[parity][q][0][ty + 1][tx + 1] = terms.reaction[sends[q]].x;
        in_plane[parity][q][1][ty + 1][tx + 1] = terms.reaction[sends[q]].y;
        in_plane[parity][q][2][ty + 1][tx + 1] = terms.reaction[sends[q]].z;
      }
      up = terms.reaction[5];
      down = terms.reaction[4];
      self = terms.self;
      Vec3f r = zero;
      if (halo_inside) {
        const std::int64_t nh =
            hi + hj * lat.stride_y + static_cast<std::int64_t>(t) * lat.stride_z;
        const StagedStencil<kRows> hs{below,     here, above, flags_below, flags_here, flags_above,
                                      halo_cell, &lat, nh,    hi,          hj,         t};
        if constexpr (kSplit == 2) {
          const unsigned links = hs.flags(0) & kLinkBits;
          const SpringConstants& own = own_constants<F>(hs, p.palette);
          const Vec3f u0 = hs.u(0), v0 = hs.v(0);
          const Arm<float> toward = arm_of(hs, links, u0, v0, lat.rest_length, hd);
          add_reaction_towards_in_plane<F>(hs, links, own, u0, v0, toward, hd, hplane,
                                           lat.rest_length, r);
        } else {
          r = reaction_towards<F>(hs, hd, lat.rest_length, p.palette);
        }
      }
      if constexpr (kSplit == 2) {  // the two angle planes of a halo node are adjacent lanes
        r.x += __shfl_xor_sync(0xffffffffu, r.x, 1);
        r.y += __shfl_xor_sync(0xffffffffu, r.y, 1);
        r.z += __shfl_xor_sync(0xffffffffu, r.z, 1);
      }
      if (halo_writer) {
        in_plane[parity][hq][0][hr][hc] = r.x;
        in_plane[parity][hq][1][hr][hc] = r.y;
        in_plane[parity][hq][2][hr][hc] = r.z;
      }
    }

    // Finish plane t − 1: its z-neighbours' reactions are in this thread's registers, its state
    // in the ring.
    const int kf = t - 1;
    if (kf >= k0 && kf < k1 && inside) {
      const std::int64_t nf = column + static_cast<std::int64_t>(kf) * lat.stride_z;
      const unsigned fl = flags_below[cell];
      Vec3f f = partial;
      f += select_if(((fl >> 4) & 1u) != 0, up_two);
      f += select_if(((fl >> 5) & 1u) != 0, down);
      Vec3f external = zero;
      if constexpr ((F & features::kExternalForces) != 0)
        external = {lat.external_force[0][nf], lat.external_force[1][nf],
                    lat.external_force[2][nf]};
      const float* s = below + cell;
      const Vec3f u{s[0], s[kCells], s[2 * kCells]};
      const Vec3f v{s[3 * kCells], s[4 * kCells], s[5 * kCells]};
      const NodeStepResult r = integrate_node<F>(fl, u, v, s[6 * kCells], external, f, p);
      store_node_step(out, nf, r, guard, step);
    }
    if (staging) {
      store_flags(t + 2, next_flags);
      __pipeline_wait_prior(0);
    }
    __syncthreads();  // in_plane[parity] and plane t + 2 complete (the other parity free)
    if (t >= k0 && t < k1 && inside) {
      const unsigned fl = flags_here[cell];
      const int r = ty + 1, c = tx + 1;
      Vec3f f = self;
      f += in_plane_reactions<kRows>(in_plane, parity, r, c, fl);
      partial = f;
    }
    up_two = up_one;
    up_one = up;
  }
}

/// One step of the staged evaluation: block q of the grid does tile q of the plan (dynamic
/// shared memory: StagedTile<kRows>::kBytes).
template <unsigned F, int kRows>
__global__ void __launch_bounds__(kTileX* kRows, 2048 / (kTileX * kRows) / 4)
    staged_step_kernel(LatticeView lat, ConstStateView in, StateView out, StepParameters p,
                       Guard* guard, int local_step, TilePlan plan) {
  extern __shared__ __align__(16) unsigned char staged_shared[];
  const long long step = guard->step_base + local_step;
  const bool halted = halted_before(guard, step);
  int bx, by, bz;
  bool active;
  plan_tile(plan, blockIdx.x, bx, by, bz, active);
  if (active)
    staged_tile_step<F, kRows>(lat, in, out, p, guard, step, halted, bx, by, bz, plan.planes,
                               staged_shared);
  else
    idle_tile_step(lat, in, out, bx * kTileX, by * kRows, bz * plan.planes,
                   min(bz * plan.planes + plan.planes, lat.dims.z), halted, kRows);
}

/// Lets every compiled symmetric feature set's staged kernels use their dynamic shared memory
/// (above the 48 KB default for 8 rows), with the largest shared-memory carveout so that the
/// blocks the registers allow (2 of 8 rows, 4 of 4 rows per multiprocessor) fit.
template <unsigned F>
void allow_staged_shared_memory() {
  if constexpr ((F & features::kSymmetricReactions) != 0) {
    TSF_CUDA_CHECK(cudaFuncSetAttribute(staged_step_kernel<F, 8>,
                                        cudaFuncAttributeMaxDynamicSharedMemorySize,
                                        static_cast<int>(StagedTile<8>::kBytes)));
    TSF_CUDA_CHECK(cudaFuncSetAttribute(staged_step_kernel<F, 4>,
                                        cudaFuncAttributeMaxDynamicSharedMemorySize,
                                        static_cast<int>(StagedTile<4>::kBytes)));
    TSF_CUDA_CHECK(cudaFuncSetAttribute(staged_step_kernel<F, 8>,
                                        cudaFuncAttributePreferredSharedMemoryCarveout,
                                        cudaSharedmemCarveoutMaxShared));
    TSF_CUDA_CHECK(cudaFuncSetAttribute(staged_step_kernel<F, 4>,
                                        cudaFuncAttributePreferredSharedMemoryCarveout,
                                        cudaSharedmemCarveoutMaxShared));
  }
}
template <unsigned... Sets>
void allow_staged_shared_memory(std::integer_sequence<unsigned, Sets...>) {
  (allow_staged_shared_memory<Sets>(), ...);
}

/// `steps` steps in one launch (small lattices: the launch, not the arithmetic, bounds a step).
/// Every block strides over the plan's tiles; a grid barrier separates the steps, and the state
/// ping-pongs between a and b (step s reads a when s is even). Launched cooperatively, so every
/// block is resident and the barrier cannot deadlock.
template <unsigned F, int kRows>
__global__ void __launch_bounds__(kTileX* kRows, 256 / (kTileX * kRows))
    persistent_step_kernel(LatticeView lat, StateView a, StateView b, StepParameters p,
                           Guard* guard, int steps, TilePlan plan) {
  __shared__ InPlane<kRows> in_plane;
  cooperative_groups::grid_group grid = cooperative_groups::this_grid();
  const long long base = guard->step_base;
  for (int s = 0; s < steps; ++s) {
    const ConstStateView in = (s & 1) ? b : a;
    const StateView out = (s & 1) ? a : b;
    const long long step = base + s;
    const bool halted = halted_before(guard, step);
    for (int q = blockIdx.x; q < plan.count; q += gridDim.x) {
      int bx, by, bz;
      bool active;
      plan_tile(plan, q, bx, by, bz, active);
      if (active)
        shared_tile_step<F, kRows>(lat, in, out, p, guard, step, halted, bx, by, bz, plan.planes,
                                   in_plane);
      else
        idle_tile_step(lat, in, out, bx * kTileX, by * kRows, bz * plan.planes,
                       min(bz * plan.planes + plan.planes, lat.dims.z), halted, kRows);
      __syncthreads();  // in_plane is reused by the next tile
    }
    grid.sync();
  }
}

/// The node-parallel step for small lattices (CudaLaunch::kNodes; docs/crms.md "Small
/// lattices"): on a few thousand nodes a step is bounded by the longest chain of dependent
/// instructions one thread executes, not by arithmetic throughput, so each node's springs and
/// angles are spread over three threads, one per angle plane (node_force_planes.h), and a step
/// is two phases separated by grid barriers:
///   1. terms: for every alive node and plane, the plane's self term and the reactions it puts
///      on the plane's 4 neighbours, into `terms` (SoA: [plane][slot: self, reaction 0..3][xyz]
///      × count floats; L2-resident at these sizes); warps are plane-uniform (no divergence);
///   2. integrate: every node sums its three self terms and, for each link d, the reactions its
///      neighbour's two planes holding that link put on it, then integrate_node(). In the
///      launch's first two steps every node is stepped (a dead or anchored node only copies its
///      state: both state buffers then agree for it); later only the alive ones.
struct NodePlan {
  const std::int32_t* alive = nullptr;  ///< indices of the alive nodes
  int alive_count = 0;
  float* terms = nullptr;
};

template <unsigned F, int P>
__device__ __forceinline__ void node_plane_terms(const LatticeView& lat, const ConstStateView& in,
                                                 const MaterialPalette& palette, int n,
                                                 float* terms) {
  const int nx = lat.dims.x, ny = lat.dims.y;
  const int i = n % nx, j = (n / nx) % ny, k = n / (nx * ny);
  const IndexedStencil st{lat, in, n, i, j, k};
  Vec3f self, reaction[4];
  plane_spring_terms<F, P>(st, lat.rest_length, palette, self, reaction);
  const std::int64_t count = lat.count;
  float* t = terms + static_cast<std::int64_t>(P) * 15 * count + n;
  t[0] = self.x;
  t[count] = self.y;
  t[2 * count] = self.z;
#pragma unroll
  for (int q = 0; q < 4; ++q) {
    t[(3 + 3 * q) * count] = reaction[q].x;
    t[(4 + 3 * q) * count] = reaction[q].y;
    t[(5 + 3 * q) * count] = reaction[q].z;
  }
}

/// Plane `plane`'s slot `slot` (0 self, 1 + q reaction q) of node n.
__device__ __forceinline__ Vec3f node_term(const float* terms, std::int64_t count, int plane,
                                           int slot, std::int64_t n) {
  const float* t = terms + (static_cast<std::int64_t>(plane) * 15 + 3 * slot) * count + n;
  return {t[0], t[count], t[2 * count]};
}

template <unsigned F>
__device__ __forceinline__ void node_integrate(const LatticeView& lat, const ConstStateView& in,
                                               const StateView& out, const StepParameters& p,
                                               Guard* guard, long long step, bool halted,
                                               const float* terms, const VolumeFold& fold,
                                               std::int64_t n) {
  const unsigned fl = lat.flags[n];
  const Vec3f u{in.u[0][n], in.u[1][n], in.u[2][n]};
  const Vec3f v{in.v[0][n], in.v[1][n], in.v[2][n]};
  const bool moving = (fl & (kAliveBit | kFixedBit)) == kAliveBit;
  if (halted || !moving) {  // halted: keep the state; not moving: u kept, v = 0 (integrate_node)
    out.u[0][n] = u.x, out.u[1][n] = u.y, out.u[2][n] = u.z;
    out.v[0][n] = halted ? v.x : 0.0f;
    out.v[1][n] = halted ? v.y : 0.0f;
    out.v[2][n] = halted ? v.z : 0.0f;
    return;
  }
  const std::int64_t count = lat.count;
  Vec3f f = node_term(terms, count, 0, 0, n) + node_term(terms, count, 1, 0, n) +
            node_term(terms, count, 2, 0, n);
  const std::int64_t stride[3] = {1, lat.stride_y, lat.stride_z};
#pragma unroll
  for (int d = 0; d < 6; ++d) {
    if (((fl >> d) & 1u) == 0) continue;
    const std::int64_t m = n + direction_sign(d) * stride[direction_axis(d)];
    const int e = opposite_direction(d);  // the neighbour's arm towards n
#pragma unroll
    for (int plane = 0; plane < 3; ++plane)
      if (plane != direction_axis(d))
        f += node_term(terms, count, plane, 1 + plane_arm_slot(plane, e), m);
  }
  Vec3f external{0.0f, 0.0f, 0.0f};
  if constexpr ((F & features::kExternalForces) != 0)
    external = {lat.external_force[0][n], lat.external_force[1][n], lat.external_force[2][n]};
  NodeStepResult r = integrate_node<F>(fl, u, v, lat.inv_mass[n], external, f, p);
  if (fold.on) {
    const Int3 c = node_coords(lat, n);
    kick_step_result(r, u, volume_force(lat, fold.term.terms, n, c.x, c.y, c.z), lat.inv_mass[n],
                     p);
  }
  store_node_step(out, n, r, guard, step);
}

template <unsigned F>
__global__ void __launch_bounds__(256, 3)
    node_step_kernel(LatticeView lat, StateView a, StateView b, StepParameters p, Guard* guard,
                     int steps, NodePlan plan, VolumeFold fold) {
  cooperative_groups::grid_group grid = cooperative_groups::this_grid();
  const long long base = guard->step_base;
  const int threads = gridDim.x * blockDim.x;
  const int tid = blockIdx.x * blockDim.x + threadIdx.x;
  // Phase 1 items: per group of 32 alive nodes, three plane-uniform warps; then, with the folded
  // volumetric term, the cube pass of every cube whose lower corner is alive (the others' terms
  // stay zero: launch_nodes clears them when the alive list changes).
  const int items = ((plan.alive_count + 31) / 32) * 96;
  const int all_items = items + (fold.on ? plan.alive_count : 0);
  for (int s = 0; s < steps; ++s) {
    const ConstStateView in = (s & 1) ? b : a;
    const StateView out = (s & 1) ? a : b;
    const long long step = base + s;
    const bool halted = halted_before(guard, step);
    if (!halted)
      for (int t = tid; t < all_items; t += threads) {
        if (t >= items) {
          const int n = plan.alive[t - items];
          const Int3 c = node_coords(lat, n);
          cube_volume_terms(lat, in, fold.term.parameters, n, c.x, c.y, c.z, fold.term.terms);
          continue;
        }
        const int index = (t / 96) * 32 + (t & 31);
        if (index >= plan.alive_count) continue;
        const int n = plan.alive[index];
        switch ((t >> 5) % 3) {  // uniform across the warp
          case 0:
            node_plane_terms<F, 0>(lat, in, p.palette, n, plan.terms);
            break;
          case 1:
            node_plane_terms<F, 1>(lat, in, p.palette, n, plan.terms);
            break;
          default:
            node_plane_terms<F, 2>(lat, in, p.palette, n, plan.terms);
            break;
        }
      }
    grid.sync();
    if (s < 2 || halted) {
      for (std::int64_t n = tid; n < lat.count; n += threads)
        node_integrate<F>(lat, in, out, p, guard, step, halted, plan.terms, fold, n);
    } else {
      for (int t = tid; t < plan.alive_count; t += threads)
        node_integrate<F>(lat, in, out, p, guard, step, halted, plan.terms, fold, plan.alive[t]);
    }
    grid.sync();
  }
}

#include "cuda_brick_step.cuh"

__global__ void advance_steps_kernel(Guard* guard, int steps) {
  guard->step_base += steps;
}

__global__ void scatter_state_kernel(StateView s, const std::int64_t* nodes, const float* values,
                                     int count) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count) return;
  const std::int64_t n = nodes[t];
  for (int a = 0; a < 3; ++a) {
    s.u[a][n] = values[6 * t + a];
    s.v[a][n] = values[6 * t + 3 + a];
  }
}

__global__ void scatter_flags_kernel(std::uint8_t* flags, const std::int64_t* nodes,
                                     const std::uint8_t* values, int count) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t < count) flags[nodes[t]] = values[t];
}

__global__ void scatter_vec3_kernel(float* x, float* y, float* z, const std::int64_t* nodes,
                                    const float* values, int count) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count) return;
  const std::int64_t n = nodes[t];
  x[n] = values[3 * t];
  y[n] = values[3 * t + 1];
  z[n] = values[3 * t + 2];
}

__global__ void positions_kernel(LatticeView lat, ConstStateView s, Vec3f origin, Vec3f spacing,
                                 float* xyz) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const int j = blockIdx.y * blockDim.y + threadIdx.y;
  const int k = blockIdx.z * blockDim.z + threadIdx.z;
  if (i >= lat.dims.x || j >= lat.dims.y || k >= lat.dims.z) return;
  const std::int64_t n = i + j * lat.stride_y + k * lat.stride_z;
  const Vec3f x = node_position(origin, spacing, i, j, k, {s.u[0][n], s.u[1][n], s.u[2][n]});
  xyz[3 * n + 0] = x.x;
  xyz[3 * n + 1] = x.y;
  xyz[3 * n + 2] = x.z;
}

/// Energy sums (kinetic, elastic, gravitational) and, with kVelocities, the stability monitor's
/// velocity signals (node_energy.h) of state `s` against `prev`, the state one step before: one
/// pass, block sums in double, one atomic per block and sum.
template <unsigned F, bool kVelocities>
__global__ void __launch_bounds__(256)
    signals_kernel(LatticeView lat, ConstStateView s, ConstStateView prev, StepParameters p,
                   double kinetic_damping, double* sums) {
  constexpr int kSums = kVelocities ? 9 : 3;
  __shared__ double partial[kSums][256];
  const int t = threadIdx.x + blockDim.x * (threadIdx.y + blockDim.y * threadIdx.z);
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const int j = blockIdx.y * blockDim.y + threadIdx.y;
  const int k = blockIdx.z * blockDim.z + threadIdx.z;
  NodeEnergy e;
  VelocitySignals v;
  if (i < lat.dims.x && j < lat.dims.y && k < lat.dims.z) {
    const std::int64_t n = i + j * lat.stride_y + k * lat.stride_z;
    const IndexedStencil st{lat, s, n, i, j, k};
    e = node_energy<F>(st, lat.rest_length, p);
    if constexpr (kVelocities) {
      const unsigned fl = lat.flags[n];
      const bool moving = (fl & (kAliveBit | kFixedBit)) == kAliveBit;
      const double m = moving ? 1.0 / static_cast<double>(lat.inv_mass[n]) : 0.0;
      add_velocity_signals(fl, m, Vec3d{prev.v[0][n], prev.v[1][n], prev.v[2][n]},
                           Vec3d{s.v[0][n], s.v[1][n], s.v[2][n]}, p.velocity_limit,
                           kinetic_damping, v);
    }
  }
  partial[0][t] = e.kinetic;
  partial[1][t] = e.elastic;
  partial[2][t] = e.gravitational;
  if constexpr (kVelocities) {
    partial[3][t] = v.moving;
    partial[4][t] = v.at_limit;
    partial[5][t] = v.drag_power;
    partial[6][t] = v.v0v1;
    partial[7][t] = v.v0v0;
    partial[8][t] = v.v1v1;
  }
  __syncthreads();
  for (int stride = 128; stride > 0; stride >>= 1) {
    if (t < stride)
      for (int q = 0; q < kSums; ++q) partial[q][t] += partial[q][t + stride];
    __syncthreads();
  }
  if (t == 0)
    for (int q = 0; q < kSums; ++q) atomicAdd(&sums[q], partial[q][0]);
}

template <unsigned F>
__global__ void __launch_bounds__(256)
    force_kernel(LatticeView lat, ConstStateView s, StepParameters p, float* xyz) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  const int j = blockIdx.y * blockDim.y + threadIdx.y;
  const int k = blockIdx.z * blockDim.z + threadIdx.z;
  if (i >= lat.dims.x || j >= lat.dims.y || k >= lat.dims.z) return;
  const std::int64_t n = i + j * lat.stride_y + k * lat.stride_z;
  Vec3f f{0.0f, 0.0f, 0.0f};
  if (lat.flags[n] & kAliveBit) {
    const IndexedStencil st{lat, s, n, i, j, k};
    f = spring_force<F>(st, lat.rest_length, p.palette);
  }
  xyz[3 * n + 0] = f.x;
  xyz[3 * n + 1] = f.y;
  xyz[3 * n + 2] = f.z;
}

class CudaBackend final : public SolverBackend {
 public:
  CudaBackend(const LatticeGeometry& g, const BackendOptions& options)
      : geometry_(g),
        count_(g.node_count()),
        steps_per_graph_(options.cuda_steps_per_graph),
        evaluation_(options.evaluation),
        tile_kernel_(options.cuda_tile_kernel),
        fold_volume_term_(options.cuda_fold_volume_term) {
    // Every resource is an RAII member (device_buffer.h): a throw below frees what was made.
    const auto n = static_cast<std::size_t>(count_);
    stream_ = make_stream();
    copy_stream_ = make_stream();
    staged_ = make_event();
    copied_ = make_event();
    for (auto& buffer : state_)
      for (auto& component : buffer) {
        component.resize(n);
        component.fill_zero(stream_.get());
      }
    flags_.resize(n);
    inv_mass_.resize(n);
    guard_.resize(1);
    guard_host_.resize(1);
    energy_host_.resize(9);
    energy_device_.resize(9);
    staging_.resize(3 * n);
    // Pinned snapshot buffers are allocated on the first request (most runs never ask).
    snapshots_ = std::make_unique<SnapshotBuffer>(nullptr, nullptr, count_);
    *guard_host_.data() = Guard{kNoNode, kNoStep, 0};
    guard_.upload(guard_host_.data(), 1, stream_.get());
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    cudaDeviceProp prop{};
    TSF_CUDA_CHECK(cudaGetDeviceProperties(&prop, 0));
    device_name_ = prop.name;
    int cooperative = 0;
    TSF_CUDA_CHECK(cudaDeviceGetAttribute(&cooperative, cudaDevAttrCooperativeLaunch, 0));
    plan_shared_launch(options, prop.multiProcessorCount, cooperative != 0);
    allow_staged_shared_memory(CompiledFeatureSets{});
  }

  ~CudaBackend() override {
    // Queued work may still read the buffers the members free next (errors are ignored: a
    // destructor must not throw).
    if (stream_) cudaStreamSynchronize(stream_.get());
    if (copy_stream_) cudaStreamSynchronize(copy_stream_.get());
  }
  CudaBackend(const CudaBackend&) = delete;
  CudaBackend& operator=(const CudaBackend&) = delete;

  std::string name() const override {
    return "cuda (" + device_name_ + ", shared tiles 32x" + std::to_string(tile_rows_) + "x" +
           std::to_string(planes_per_block_) +
           (bricks_       ? ", brick persistent launch"
            : nodes_      ? ", node-parallel persistent launch"
            : persistent_ ? ", " + std::to_string(persistent_blocks_) + " persistent blocks"
                          : ", graphs of " + std::to_string(steps_per_graph_) + " steps, " +
                                to_string(tile_kernel_) + " tile kernel") +
           ")";
  }

  void upload_lattice(const std::vector<std::uint8_t>& flags, const std::vector<float>& inv_mass,
                      const std::vector<MaterialBlend>& material) override {
    const auto n = static_cast<std::size_t>(count_);
    TSF_CUDA_CHECK(
        cudaMemcpyAsync(flags_.data(), flags.data(), n, cudaMemcpyHostToDevice, stream_.get()));
    host_flags_ = flags;
    count_moving_tiles();
    if ((nodes_ || bricks_) && launch_ == CudaLaunch::kAuto &&
        std::count_if(flags.begin(), flags.end(), [](std::uint8_t f) { return f & kAliveBit; }) >
            kNodesMaxAlive)
      nodes_ = bricks_ = false;  // many alive nodes: graphs of the tile kernel (kNodesMaxAlive)
    count_moving_bricks();
    upload_alive_list();
    TSF_CUDA_CHECK(cudaMemcpyAsync(inv_mass_.data(), inv_mass.data(), n * sizeof(float),
                                   cudaMemcpyHostToDevice, stream_.get()));
    if (!material.empty()) {
      if (material_index_.empty()) material_index_.resize(n);
      if (material_weight_.empty()) material_weight_.resize(n);
      host_material_ = material;
      upload_materials();
    }
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
  }

  void update_materials(const std::vector<std::int64_t>& nodes,
                        const std::vector<MaterialBlend>& blends) override {
    // Rare (animation triggers): the host copy is edited and the arrays re-sent whole.
    for (std::size_t i = 0; i < nodes.size(); ++i) host_material_[nodes[i]] = blends[i];
    upload_materials();
  }

  void update_flags(const std::vector<std::int64_t>& nodes,
                    const std::vector<std::uint8_t>& flags) override {
    if (nodes.empty()) return;
    queue_flags(nodes, flags);
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
  }
  void update_flags_and_write_nodes(const std::vector<std::int64_t>& flag_nodes,
                                    const std::vector<std::uint8_t>& flags,
                                    const std::vector<std::int64_t>& nodes,
                                    const std::vector<Vec3f>& u,
                                    const std::vector<Vec3f>& v) override {
    // The two scatters stage in separate slots (stage_scatter), so both are in flight before
    // the one wait.
    if (flag_nodes.empty() && nodes.empty()) return;
    if (!flag_nodes.empty()) queue_flags(flag_nodes, flags);
    if (!nodes.empty()) queue_nodes(nodes, u, v);
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
  }
  /// update_flags() without the wait: the scatter is queued on the stream.
  void queue_flags(const std::vector<std::int64_t>& nodes, const std::vector<std::uint8_t>& flags) {
    if (nodes.empty()) return;
    const int count = static_cast<int>(nodes.size());
    bool alive_changed = false;
    for (std::size_t t = 0; t < nodes.size(); ++t) {
      const std::int64_t n = nodes[t];
      alive_changed |= ((host_flags_[n] ^ flags[t]) & kAliveBit) != 0;
      const int was = moving(host_flags_[n]), now = moving(flags[t]);
      if (was != now) {
        int& m = tile_moving_[tile_of(n)];
        if ((m == 0) != (m + now - was == 0)) tile_plan_stale_ = true;
        m += now - was;
        if (bricks_) {
          int& b = brick_moving_[brick_of(n)];
          if ((b == 0) != (b + now - was == 0)) brick_plan_stale_ = true;
          b += now - was;
        }
      }
      host_flags_[n] = flags[t];
    }
    if (tile_plan_stale_) upload_tile_plan();
    if (brick_plan_stale_) upload_brick_plan();
    if (alive_changed) upload_alive_list();
    std::memcpy(stage_scatter(0, nodes, flags.size()), flags.data(), flags.size());
    scatter_flags_kernel<<<(count + 255) / 256, 256, 0, stream_.get()>>>(
        flags_.data(), scatter_[0].nodes.data(), scatter_[0].values.data(), count);
    TSF_CUDA_CHECK_LAUNCH();
  }

  void enable_external_forces() override {
    const auto n = static_cast<std::size_t>(count_);
    for (auto& c : external_force_)
      if (c.empty()) {
        c.resize(n);
        c.fill_zero(stream_.get());
      }
  }
  void set_external_forces(const std::vector<std::int64_t>& nodes,
                           const std::vector<Vec3f>& forces) override {
    if (nodes.empty()) return;
    const int count = static_cast<int>(nodes.size());
    std::memcpy(stage_scatter(1, nodes, forces.size() * sizeof(Vec3f)), forces.data(),
                forces.size() * sizeof(Vec3f));
    scatter_vec3_kernel<<<(count + 255) / 256, 256, 0, stream_.get()>>>(
        external_force_[0].data(), external_force_[1].data(), external_force_[2].data(),
        scatter_[1].nodes.data(), reinterpret_cast<const float*>(scatter_[1].values.data()), count);
    TSF_CUDA_CHECK_LAUNCH();
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
  }
  void clear_external_forces() override {
    for (auto& c : external_force_) c.fill_zero(stream_.get());
  }

  void write_nodes(const std::vector<std::int64_t>& nodes, const std::vector<Vec3f>& u,
                   const std::vector<Vec3f>& v) override {
    if (nodes.empty()) return;
    queue_nodes(nodes, u, v);
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
  }
  /// write_nodes() without the wait.
  void queue_nodes(const std::vector<std::int64_t>& nodes, const std::vector<Vec3f>& u,
                   const std::vector<Vec3f>& v) {
    if (nodes.empty()) return;
    const int count = static_cast<int>(nodes.size());
    auto* values =
        reinterpret_cast<float*>(stage_scatter(1, nodes, 6 * nodes.size() * sizeof(float)));
    for (std::size_t t = 0; t < nodes.size(); ++t)
      for (int a = 0; a < 3; ++a) {
        values[6 * t + a] = u[t][a];
        values[6 * t + 3 + a] = v[t][a];
      }
    scatter_state_kernel<<<(count + 255) / 256, 256, 0, stream_.get()>>>(
        state_view(), scatter_[1].nodes.data(),
        reinterpret_cast<const float*>(scatter_[1].values.data()), count);
    TSF_CUDA_CHECK_LAUNCH();
  }

  void write_state(const std::vector<Vec3f>& u, const std::vector<Vec3f>& v) override {
    const auto n = static_cast<std::size_t>(count_);
    std::vector<float> component(n);
    for (int q = 0; q < 6; ++q) {
      for (std::size_t m = 0; m < n; ++m) component[m] = q < 3 ? u[m][q] : v[m][q - 3];
      TSF_CUDA_CHECK(cudaMemcpyAsync(state_[current_][q].data(), component.data(),
                                     n * sizeof(float), cudaMemcpyHostToDevice, stream_.get()));
      TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    }
  }

  void read_state(std::vector<Vec3f>* u, std::vector<Vec3f>* v) override {
    const auto n = static_cast<std::size_t>(count_);
    std::vector<float> component(n);
    if (u) u->resize(n);
    if (v) v->resize(n);
    for (int q = 0; q < 6; ++q) {
      std::vector<Vec3f>* dst = q < 3 ? u : v;
      if (!dst) continue;
      TSF_CUDA_CHECK(cudaMemcpyAsync(component.data(), state_[current_][q].data(),
                                     n * sizeof(float), cudaMemcpyDeviceToHost, stream_.get()));
      TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
      for (std::size_t m = 0; m < n; ++m) (*dst)[m][q % 3] = component[m];
    }
  }

  bool folds_volume_term(unsigned features) const override {
    return fold_volume_term_ && (bricks_ || nodes_) && cooperative_step(features);
  }

  void step_folded(int n, const StepParameters& p, unsigned features,
                   const FoldedVolumeTerm& volume) override {
    require(folds_volume_term(features), "step_folded: this launch does not fold the term");
    require(bricks_ || volume.terms[0] != nullptr, "step_folded: no cube-pass arrays");
    require_compiled_feature_set(features);
    VolumeFold fold;
    fold.on = true;
    fold.term = volume;
    if (n > 0) step_cooperative(n, p, features, fold);
  }

  void step(int n, const StepParameters& p, unsigned features) override {
    require_compiled_feature_set(features);
    const LatticeView lat = lattice_view();
    if ((bricks_ || nodes_ || persistent_) && n > 0 && cooperative_step(features)) {
      step_cooperative(n, p, features, VolumeFold{});
      return;
    }
    int done = 0;
    while (n - done >= steps_per_graph_) {
      TSF_CUDA_CHECK(cudaGraphLaunch(graph_for(p, features, lat), stream_.get()));
      done += steps_per_graph_;
    }
    const int rest = n - done;
    if (rest > 0) {
      dispatch_features(features, [&](auto f) {
        for (int s = 0; s < rest; ++s) launch_step<decltype(f)::value>(lat, p, s);
      });
      advance_steps_kernel<<<1, 1, 0, stream_.get()>>>(guard_.data(),
                                                       rest);  // launch_step swapped buffers
      TSF_CUDA_CHECK_LAUNCH();
    }
    steps_started_ += n;
  }

  /// The cooperative launches (bricks, node-parallel, persistent tiles) run the symmetric shared
  /// evaluation only.
  bool cooperative_step(unsigned features) const {
    return (features & features::kSymmetricReactions) != 0 &&
           evaluation_ == ForceEvaluation::kShared;
  }

  /// Every step of the call in one cooperative launch (the folded term: bricks and nodes only).
  void step_cooperative(int n, const StepParameters& p, unsigned features, const VolumeFold& fold) {
    const LatticeView lat = lattice_view();
    dispatch_features(features, [&](auto f) {
      if constexpr ((decltype(f)::value & features::kSymmetricReactions) != 0) {
        if (bricks_)
          launch_bricks<decltype(f)::value>(lat, p, n, fold);
        else if (nodes_)
          launch_nodes<decltype(f)::value>(lat, p, n, fold);
        else
          launch_persistent<decltype(f)::value>(lat, p, n);
      }
    });
    advance_steps_kernel<<<1, 1, 0, stream_.get()>>>(guard_.data(), n);
    TSF_CUDA_CHECK_LAUNCH();
    steps_started_ += n;
  }

  std::optional<GuardHit> synchronize() override {
    TSF_CUDA_CHECK(cudaMemcpyAsync(guard_host_.data(), guard_.data(), sizeof(Guard),
                                   cudaMemcpyDeviceToHost, stream_.get()));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    if (guard_host_.data()->bad_step == kNoStep) return std::nullopt;
    return GuardHit{static_cast<std::int64_t>(guard_host_.data()->bad_node),
                    guard_host_.data()->bad_step};
  }

  void reset_guard() override {
    TSF_CUDA_CHECK(cudaMemcpyAsync(guard_host_.data(), guard_.data(), sizeof(Guard),
                                   cudaMemcpyDeviceToHost, stream_.get()));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    guard_host_.data()->bad_node = kNoNode;
    guard_host_.data()->bad_step = kNoStep;
    TSF_CUDA_CHECK(cudaMemcpyAsync(guard_.data(), guard_host_.data(), sizeof(Guard),
                                   cudaMemcpyHostToDevice, stream_.get()));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
  }

  EnergySums energy(const StepParameters& p, unsigned features) override {
    VelocitySignals unused;
    return measure(p, features, false, 0.0, unused);
  }

  bool step_signals(const StepParameters& p, unsigned features, bool velocities,
                    double kinetic_damping, EnergySums& energy, VelocitySignals& v,
                    std::optional<GuardHit>* guard) override {
    if (guard)  // queued before the sums: both copies land in the one wait of measure()
      TSF_CUDA_CHECK(cudaMemcpyAsync(guard_host_.data(), guard_.data(), sizeof(Guard),
                                     cudaMemcpyDeviceToHost, stream_.get()));
    energy = measure(p, features, velocities, kinetic_damping, v);
    if (guard) {
      if (guard_host_.data()->bad_step == kNoStep)
        guard->reset();
      else
        *guard = GuardHit{static_cast<std::int64_t>(guard_host_.data()->bad_node),
                          guard_host_.data()->bad_step};
    }
    return true;
  }
  bool has_step_signals() const override { return true; }

  void spring_forces(const StepParameters& p, unsigned features,
                     std::vector<Vec3f>& forces) override {
    // The snapshot staging buffer (3 floats per node) is free while no copy is in flight.
    poll_snapshot();
    if (copy_in_flight_) TSF_CUDA_CHECK(cudaStreamSynchronize(copy_stream_.get()));
    poll_snapshot();
    const LatticeView lat = lattice_view();
    dispatch_features(features, [&](auto f) {
      force_kernel<decltype(f)::value>
          <<<grid(), kBlock, 0, stream_.get()>>>(lat, state_view(), p, staging_.data());
    });
    TSF_CUDA_CHECK_LAUNCH();
    forces.resize(static_cast<std::size_t>(count_));
    TSF_CUDA_CHECK(cudaMemcpyAsync(forces.data(), staging_.data(), 3 * count_ * sizeof(float),
                                   cudaMemcpyDeviceToHost, stream_.get()));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
  }

  LatticeView lattice_view() const override {
    LatticeView l;
    l.dims = geometry_.dims;
    l.count = count_;
    l.stride_y = geometry_.dims.x;
    l.stride_z = static_cast<std::int64_t>(geometry_.dims.x) * geometry_.dims.y;
    for (int a = 0; a < 3; ++a) l.rest_length[a] = static_cast<float>(geometry_.spacing[a]);
    l.flags = flags_.data();
    l.inv_mass = inv_mass_.data();
    l.material_index = material_index_.data();
    l.material_weight = material_weight_.data();
    for (int a = 0; a < 3; ++a) l.external_force[a] = external_force_[a].data();
    return l;
  }
  StateView state_view() const override { return buffer_view(current_); }

  void request_snapshot(std::int64_t step) override {
    poll_snapshot();
    if (copy_in_flight_) {
      snapshots_->count_dropped();
      return;
    }
    if (!snapshots_->attached()) {
      for (auto& p : pinned_snapshot_) p.resize(3 * static_cast<std::size_t>(count_));
      snapshots_->attach(pinned_snapshot_[0].data(), pinned_snapshot_[1].data());
    }
    const Vec3f origin = to_float(geometry_.origin), spacing = to_float(geometry_.spacing);
    positions_kernel<<<grid(), kBlock, 0, stream_.get()>>>(lattice_view(), state_view(), origin,
                                                           spacing, staging_.data());
    TSF_CUDA_CHECK_LAUNCH();
    TSF_CUDA_CHECK(cudaEventRecord(staged_.get(), stream_.get()));
    TSF_CUDA_CHECK(cudaStreamWaitEvent(copy_stream_.get(), staged_.get(), 0));
    TSF_CUDA_CHECK(cudaMemcpyAsync(snapshots_->back(), staging_.data(), 3 * count_ * sizeof(float),
                                   cudaMemcpyDeviceToHost, copy_stream_.get()));
    TSF_CUDA_CHECK(cudaEventRecord(copied_.get(), copy_stream_.get()));
    copy_in_flight_ = true;
    in_flight_step_ = step;
  }

  void poll_snapshot() override {
    if (!copy_in_flight_) return;
    const cudaError_t state = cudaEventQuery(copied_.get());
    if (state == cudaErrorNotReady) return;
    TSF_CUDA_CHECK(state);
    snapshots_->publish(in_flight_step_);
    copy_in_flight_ = false;
  }
  const SnapshotBuffer& snapshots() const override { return *snapshots_; }

  void* native_stream() const override { return stream_.get(); }

  double bytes_per_node() const override {
    double b = 2 * 6 * sizeof(float) + sizeof(std::uint8_t) + sizeof(float);
    if (material_index_.data()) b += 2 * sizeof(std::uint32_t);
    if (external_force_[0].data()) b += 3 * sizeof(float);
    return b;
  }

 private:
  struct CachedGraph {
    StepParameters parameters;
    unsigned features = 0;
    int parity = 0;
    UniqueGraphExec exec;
  };

  /// One signals_kernel pass and its read-back (9 doubles at most).
  EnergySums measure(const StepParameters& p, unsigned features, bool velocities,
                     double kinetic_damping, VelocitySignals& v) {
    const int sums = velocities ? 9 : 3;
    TSF_CUDA_CHECK(cudaMemsetAsync(energy_device_.data(), 0, sums * sizeof(double), stream_.get()));
    const LatticeView lat = lattice_view();
    const ConstStateView now = state_view(), before = buffer_view(1 - current_);
    dispatch_features(features, [&](auto f) {
      if (velocities)
        signals_kernel<decltype(f)::value, true><<<grid(), kBlock, 0, stream_.get()>>>(
            lat, now, before, p, kinetic_damping, energy_device_.data());
      else
        signals_kernel<decltype(f)::value, false><<<grid(), kBlock, 0, stream_.get()>>>(
            lat, now, before, p, kinetic_damping, energy_device_.data());
    });
    TSF_CUDA_CHECK_LAUNCH();
    TSF_CUDA_CHECK(cudaMemcpyAsync(energy_host_.data(), energy_device_.data(),
                                   sums * sizeof(double), cudaMemcpyDeviceToHost, stream_.get()));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    const double* h = energy_host_.data();
    if (velocities) {
      v.moving = h[3];
      v.at_limit = h[4];
      v.drag_power = h[5];
      v.v0v1 = h[6];
      v.v0v0 = h[7];
      v.v1v1 = h[8];
    }
    return EnergySums{h[0], h[1], h[2]};
  }

  dim3 grid() const {
    return dim3((geometry_.dims.x + kBlock.x - 1) / kBlock.x,
                (geometry_.dims.y + kBlock.y - 1) / kBlock.y,
                (geometry_.dims.z + kBlock.z - 1) / kBlock.z);
  }

  StateView buffer_view(int which) const {
    StateView v;
    for (int a = 0; a < 3; ++a) {
      v.u[a] = state_[which][a].data();
      v.v[a] = state_[which][3 + a].data();
    }
    return v;
  }

  /// Tile rows and planes per block of the shared kernel, and whether steps run as one persistent
  /// launch. Graphs of launches (large lattices): rows 8 for large lattices (fewer halo nodes per
  /// node), 4 for small ones (more blocks); planes so that the grid has about eight blocks per
  /// multiprocessor (the halo planes cost 2/3 of a plane per block). Persistent (small lattices,
  /// where a step's arithmetic is shorter than a launch): rows 4 and planes so that every resident
  /// block has about one tile, so a step takes one tile's time plus a grid barrier.
  void plan_shared_launch(const BackendOptions& options, int multiprocessors, bool cooperative) {
    const int nx = geometry_.dims.x, ny = geometry_.dims.y, nz = geometry_.dims.z;
    launch_ = options.cuda_launch;
    persistent_ = cooperative && options.cuda_launch == CudaLaunch::kPersistent;
    const bool automatic = options.cuda_launch == CudaLaunch::kAuto && count_ <= kNodesMaxNodes;
    bricks_ = cooperative && (options.cuda_launch == CudaLaunch::kBricks || automatic);
    nodes_ = cooperative && count_ < (std::int64_t{1} << 31) &&  // 32-bit node lists
             (options.cuda_launch == CudaLaunch::kNodes || automatic);
    if (bricks_) {
      int per_sm = 0;
      brick_kernel_attributes<features::kSymmetricReactions>();
      TSF_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(
          &per_sm, brick_step_kernel<features::kSymmetricReactions>, Brick::kThreads,
          Brick::kFoldedSharedBytes));  // the larger launch: its blocks are resident too
      brick_resident_blocks_ = per_sm * multiprocessors;
      if (brick_resident_blocks_ < 1) bricks_ = false;
      bricks_x_ = (nx + Brick::kX - 1) / Brick::kX;
      bricks_y_ = (ny + Brick::kY - 1) / Brick::kY;
      bricks_z_ = (nz + Brick::kZ - 1) / Brick::kZ;
      brick_moving_.assign(static_cast<std::size_t>(bricks_x_) * bricks_y_ * bricks_z_, 0);
      // Automatic: bricks where every brick has a resident block (one round of bricks a step),
      // else the node-parallel launch, which measured faster there (docs/crms.md "Small
      // lattices").
      if (automatic && static_cast<std::int64_t>(brick_moving_.size()) > brick_resident_blocks_)
        bricks_ = false;
    }
    if (bricks_) nodes_ = false;
    if (nodes_) {
      int per_sm = 0;
      TSF_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(
          &per_sm, node_step_kernel<features::kSymmetricReactions>, 256, 0));
      node_resident_blocks_ = per_sm * multiprocessors;
      if (node_resident_blocks_ < 1) nodes_ = false;
    }
    tile_rows_ = options.cuda_tile_rows;
    if (tile_rows_ == 0) tile_rows_ = !persistent_ && count_ >= (std::int64_t{1} << 20) ? 8 : 4;
    int resident = 0;
    if (persistent_) {
      int per_sm = 0;
      if (tile_rows_ == 8)
        TSF_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(
            &per_sm, persistent_step_kernel<features::kSymmetricReactions, 8>, kTileX * 8, 0));
      else
        TSF_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(
            &per_sm, persistent_step_kernel<features::kSymmetricReactions, 4>, kTileX * 4, 0));
      resident = per_sm * multiprocessors;
      if (resident < 1) persistent_ = false;
    }
    const std::int64_t columns = static_cast<std::int64_t>((nx + kTileX - 1) / kTileX) *
                                 ((ny + tile_rows_ - 1) / tile_rows_);
    planes_per_block_ = options.cuda_planes_per_block;
    if (planes_per_block_ == 0) {
      const std::int64_t wanted_blocks =
          persistent_ ? resident : 8 * static_cast<std::int64_t>(multiprocessors);
      const std::int64_t chunks =
          std::clamp<std::int64_t>((wanted_blocks + columns - 1) / columns, 1, nz);
      planes_per_block_ = static_cast<int>((nz + chunks - 1) / chunks);
    }
    planes_per_block_ = std::clamp(planes_per_block_, 1, std::max(1, nz));
    tiles_x_ = (nx + kTileX - 1) / kTileX;
    tiles_y_ = (ny + tile_rows_ - 1) / tile_rows_;
    tiles_z_ = (nz + planes_per_block_ - 1) / planes_per_block_;
    const int tiles = tiles_x_ * tiles_y_ * tiles_z_;
    persistent_blocks_ = persistent_ ? std::min(tiles, resident) : 0;
    tile_moving_.assign(static_cast<std::size_t>(tiles), 0);
    tile_list_.resize(static_cast<std::size_t>(tiles));
    tile_active_.resize(1);
  }

  static int moving(std::uint8_t flags) { return (flags & (kAliveBit | kFixedBit)) == kAliveBit; }
  int tile_of(std::int64_t n) const {
    const Int3 c = geometry_.coordinates(n);
    return c.x / kTileX + tiles_x_ * (c.y / tile_rows_ + tiles_y_ * (c.z / planes_per_block_));
  }
  /// Moving nodes per tile from the host copy of the flags, and the plan's tile list.
  void count_moving_tiles() {
    std::fill(tile_moving_.begin(), tile_moving_.end(), 0);
    for (std::int64_t n = 0; n < count_; ++n)
      if (moving(host_flags_[static_cast<std::size_t>(n)])) ++tile_moving_[tile_of(n)];
    upload_tile_plan();
  }
  void upload_tile_plan() {
    std::vector<int> list;
    list.reserve(tile_moving_.size());
    for (std::size_t t = 0; t < tile_moving_.size(); ++t)
      if (tile_moving_[t] > 0) list.push_back(static_cast<int>(t));
    const int active = static_cast<int>(list.size());
    for (std::size_t t = 0; t < tile_moving_.size(); ++t)
      if (tile_moving_[t] == 0) list.push_back(static_cast<int>(t));
    // The kernels read the list while queued steps run: replace it in stream order.
    plan_staging_.resize(list.size() + 1);
    std::copy(list.begin(), list.end(), plan_staging_.data());
    plan_staging_.data()[list.size()] = active;
    TSF_CUDA_CHECK(cudaMemcpyAsync(tile_list_.data(), plan_staging_.data(),
                                   list.size() * sizeof(int), cudaMemcpyHostToDevice,
                                   stream_.get()));
    TSF_CUDA_CHECK(cudaMemcpyAsync(tile_active_.data(), plan_staging_.data() + list.size(),
                                   sizeof(int), cudaMemcpyHostToDevice, stream_.get()));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));  // the staging buffer is reused
    active_tiles_ = active;
    tile_plan_stale_ = false;
  }
  TilePlan tile_plan() const {
    TilePlan plan;
    plan.tiles_x = tiles_x_;
    plan.tiles_y = tiles_y_;
    plan.tiles_z = tiles_z_;
    plan.planes = planes_per_block_;
    plan.count = tiles_x_ * tiles_y_ * tiles_z_;
    plan.list = tile_list_.data();
    plan.active = tile_active_.data();
    return plan;
  }

  int brick_of(std::int64_t n) const {
    const Int3 c = geometry_.coordinates(n);
    return c.x / Brick::kX + bricks_x_ * (c.y / Brick::kY + bricks_y_ * (c.z / Brick::kZ));
  }
  /// Moving nodes per brick from the host copy of the flags, and the brick list (brick launch).
  void count_moving_bricks() {
    if (!bricks_) return;
    std::fill(brick_moving_.begin(), brick_moving_.end(), 0);
    for (std::int64_t n = 0; n < count_; ++n)
      if (moving(host_flags_[static_cast<std::size_t>(n)])) ++brick_moving_[brick_of(n)];
    upload_brick_plan();
  }
  void upload_brick_plan() {
    std::vector<int> list;
    list.reserve(brick_moving_.size());
    for (std::size_t b = 0; b < brick_moving_.size(); ++b)
      if (brick_moving_[b] > 0) list.push_back(static_cast<int>(b));
    const int active = static_cast<int>(list.size());
    for (std::size_t b = 0; b < brick_moving_.size(); ++b)
      if (brick_moving_[b] == 0) list.push_back(static_cast<int>(b));
    if (brick_list_.size() < list.size()) brick_list_.resize(list.size());
    // The kernels read the list while queued steps run: replace it in stream order.
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    TSF_CUDA_CHECK(cudaMemcpyAsync(brick_list_.data(), list.data(), list.size() * sizeof(int),
                                   cudaMemcpyHostToDevice, stream_.get()));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));  // `list` goes out of scope
    active_bricks_ = active;
    brick_plan_stale_ = false;
  }
  /// The brick kernel's shared memory may exceed the default 48 KB a block may ask for.
  template <unsigned F>
  static void brick_kernel_attributes() {
    static const bool done = [] {
      TSF_CUDA_CHECK(cudaFuncSetAttribute(reinterpret_cast<const void*>(&brick_step_kernel<F>),
                                          cudaFuncAttributeMaxDynamicSharedMemorySize,
                                          static_cast<int>(Brick::kFoldedSharedBytes)));
      return true;
    }();
    (void)done;
  }
  template <unsigned F>
  void launch_bricks(const LatticeView& lat, const StepParameters& p, int n,
                     const VolumeFold& fold) {
    brick_kernel_attributes<F>();
    StateView a = buffer_view(current_), b = buffer_view(1 - current_);
    StepParameters parameters = p;
    Guard* guard = guard_.data();
    BrickPlan plan;
    plan.bricks_x = bricks_x_;
    plan.bricks_y = bricks_y_;
    plan.bricks_z = bricks_z_;
    plan.list = brick_list_.data();
    plan.active = active_bricks_;
    plan.count = static_cast<int>(brick_moving_.size());
    const int blocks = std::max(1, std::min(plan.count, brick_resident_blocks_));
    VolumeFold folded = fold;
    void* args[] = {
        const_cast<LatticeView*>(&lat), &a, &b, &parameters, &guard, &n, &plan, &folded};
    TSF_CUDA_CHECK(cudaLaunchCooperativeKernel(
        reinterpret_cast<const void*>(&brick_step_kernel<F>), dim3(blocks), dim3(Brick::kThreads),
        args, fold.on ? Brick::kFoldedSharedBytes : Brick::kSharedBytes, stream_.get()));
    if (n & 1) current_ = 1 - current_;
  }

  /// The alive list of the node-parallel kernel, from the host copy of the flags.
  void upload_alive_list() {
    if (!nodes_) return;
    std::vector<std::int32_t> alive;
    alive.reserve(static_cast<std::size_t>(count_));
    for (std::int64_t n = 0; n < count_; ++n)
      if (host_flags_[static_cast<std::size_t>(n)] & kAliveBit)
        alive.push_back(static_cast<std::int32_t>(n));
    if (alive_list_.size() < alive.size() || alive_list_.empty())
      alive_list_.resize(std::max<std::size_t>(alive.size(), 1));
    if (!alive.empty())
      TSF_CUDA_CHECK(cudaMemcpyAsync(alive_list_.data(), alive.data(),
                                     alive.size() * sizeof(std::int32_t), cudaMemcpyHostToDevice,
                                     stream_.get()));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));  // `alive` goes out of scope
    alive_count_ = static_cast<int>(alive.size());
    fold_terms_cleared_ = nullptr;  // cubes whose lower corner died keep their last terms
    if (node_terms_.empty()) node_terms_.resize(static_cast<std::size_t>(45 * count_));
  }

  template <unsigned F>
  void launch_nodes(const LatticeView& lat, const StepParameters& p, int n,
                    const VolumeFold& fold) {
    if (fold.on && fold_terms_cleared_ != fold.term.terms[0]) {
      // The kernel runs the cube pass of the cubes with an alive lower corner only: the others'
      // terms must read zero (as the cube pass leaves a cube that is not intact).
      for (float* t : fold.term.terms)
        TSF_CUDA_CHECK(
            cudaMemsetAsync(t, 0, static_cast<std::size_t>(count_) * sizeof(float), stream_.get()));
      fold_terms_cleared_ = fold.term.terms[0];
    }
    StateView a = buffer_view(current_), b = buffer_view(1 - current_);
    StepParameters parameters = p;
    Guard* guard = guard_.data();
    NodePlan plan;
    plan.alive = alive_list_.data();
    plan.alive_count = alive_count_;
    plan.terms = node_terms_.data();
    const std::int64_t items =
        (static_cast<std::int64_t>(alive_count_) + 31) / 32 * 96 + (fold.on ? alive_count_ : 0);
    const std::int64_t wanted = (std::max<std::int64_t>(items, count_) + 255) / 256;
    const int blocks = static_cast<int>(std::min<std::int64_t>(wanted, node_resident_blocks_));
    VolumeFold folded = fold;
    void* args[] = {
        const_cast<LatticeView*>(&lat), &a, &b, &parameters, &guard, &n, &plan, &folded};
    TSF_CUDA_CHECK(cudaLaunchCooperativeKernel(reinterpret_cast<const void*>(&node_step_kernel<F>),
                                               dim3(std::max(blocks, 1)), dim3(256), args, 0,
                                               stream_.get()));
    if (n & 1) current_ = 1 - current_;
  }

  template <unsigned F>
  void launch_persistent(const LatticeView& lat, const StepParameters& p, int n) {
    StateView a = buffer_view(current_), b = buffer_view(1 - current_);
    StepParameters parameters = p;
    Guard* guard = guard_.data();
    TilePlan plan = tile_plan();
    void* args[] = {const_cast<LatticeView*>(&lat), &a, &b, &parameters, &guard, &n, &plan};
    if (tile_rows_ == 8)
      TSF_CUDA_CHECK(cudaLaunchCooperativeKernel(
          reinterpret_cast<const void*>(&persistent_step_kernel<F, 8>), dim3(persistent_blocks_),
          dim3(kTileX, 8), args, 0, stream_.get()));
    else
      TSF_CUDA_CHECK(cudaLaunchCooperativeKernel(
          reinterpret_cast<const void*>(&persistent_step_kernel<F, 4>), dim3(persistent_blocks_),
          dim3(kTileX, 4), args, 0, stream_.get()));
    if (n & 1) current_ = 1 - current_;
  }

  template <unsigned F>
  void launch_step(const LatticeView& lat, const StepParameters& p, int local_step) {
    const ConstStateView in = buffer_view(current_);
    const StateView out = buffer_view(1 - current_);
    if constexpr ((F & features::kSymmetricReactions) != 0) {
      if (evaluation_ == ForceEvaluation::kShared && tile_kernel_ == CudaTileKernel::kStaged) {
        const TilePlan plan = tile_plan();
        if (tile_rows_ == 8)
          staged_step_kernel<F, 8>
              <<<plan.count, dim3(kTileX, 8), StagedTile<8>::kBytes, stream_.get()>>>(
                  lat, in, out, p, guard_.data(), local_step, plan);
        else
          staged_step_kernel<F, 4>
              <<<plan.count, dim3(kTileX, 4), StagedTile<4>::kBytes, stream_.get()>>>(
                  lat, in, out, p, guard_.data(), local_step, plan);
        TSF_CUDA_CHECK_LAUNCH();
        current_ = 1 - current_;
        return;
      }
      if (evaluation_ == ForceEvaluation::kShared) {
        const TilePlan plan = tile_plan();
        if (tile_rows_ == 8)
          shared_step_kernel<F, 8><<<plan.count, dim3(kTileX, 8), 0, stream_.get()>>>(
              lat, in, out, p, guard_.data(), local_step, plan);
        else
          shared_step_kernel<F, 4><<<plan.count, dim3(kTileX, 4), 0, stream_.get()>>>(
              lat, in, out, p, guard_.data(), local_step, plan);
        TSF_CUDA_CHECK_LAUNCH();
        current_ = 1 - current_;
        return;
      }
    }
    step_kernel<F>
        <<<grid(), kBlock, 0, stream_.get()>>>(lat, in, out, p, guard_.data(), local_step);
    TSF_CUDA_CHECK_LAUNCH();
    current_ = 1 - current_;
  }

  /// The graph of steps_per_graph_ steps for these parameters, starting from the current buffer
  /// (captured on first use; a handful are cached: one per parity and parameter set in use).
  cudaGraphExec_t graph_for(const StepParameters& p, unsigned features, const LatticeView& lat) {
    for (const CachedGraph& g : graphs_)
      if (g.features == features && g.parity == current_ &&
          std::memcmp(&g.parameters, &p, sizeof(StepParameters)) == 0)
        return g.exec.get();
    if (graphs_.size() >= 8) graphs_.erase(graphs_.begin());
    const int parity = current_;
    TSF_CUDA_CHECK(cudaStreamBeginCapture(stream_.get(), cudaStreamCaptureModeThreadLocal));
    dispatch_features(features, [&](auto f) {
      for (int s = 0; s < steps_per_graph_; ++s) launch_step<decltype(f)::value>(lat, p, s);
    });
    advance_steps_kernel<<<1, 1, 0, stream_.get()>>>(guard_.data(), steps_per_graph_);
    cudaGraph_t captured = nullptr;
    TSF_CUDA_CHECK(cudaStreamEndCapture(stream_.get(), &captured));
    const UniqueGraph graph(captured);
    CachedGraph cached;
    cached.parameters = p;
    cached.features = features;
    cached.parity = parity;
    cudaGraphExec_t exec = nullptr;
    TSF_CUDA_CHECK(cudaGraphInstantiate(&exec, graph.get(), 0));
    cached.exec.reset(exec);
    graphs_.push_back(std::move(cached));
    return graphs_.back().exec.get();
  }

  /// Stages a scatter's node ids in page-locked host memory and returns room there for its
  /// `value_bytes` of values, which the caller fills; the scatter kernels read both directly
  /// (mapped: the same address on both sides under unified addressing), so an edit of a few
  /// nodes is its kernel launches and one wait, with no copies queued. Slot 0 holds the flags,
  /// slot 1 the states or forces: both can be in flight before the one wait of
  /// update_flags_and_write_nodes(). Every scatter waits for its kernels before it returns, so
  /// the next one may overwrite a slot.
  std::uint8_t* stage_scatter(int slot, const std::vector<std::int64_t>& nodes,
                              std::size_t value_bytes) {
    ScatterStage& st = scatter_[slot];
    if (nodes.size() > st.nodes.capacity() || value_bytes > st.values.capacity()) {
      TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
      st.nodes.grow_to(nodes.size());
      st.values.grow_to(value_bytes);
    }
    st.nodes.resize(nodes.size());
    st.values.resize(value_bytes);
    std::copy(nodes.begin(), nodes.end(), st.nodes.data());
    return st.values.data();
  }

  LatticeGeometry geometry_;
  std::int64_t count_;
  int steps_per_graph_;
  ForceEvaluation evaluation_;
  CudaTileKernel tile_kernel_;
  bool fold_volume_term_;  // BackendOptions::cuda_fold_volume_term
  int tile_rows_ = 4;
  int planes_per_block_ = 1;
  int tiles_x_ = 1, tiles_y_ = 1, tiles_z_ = 1;
  bool persistent_ = false;
  int persistent_blocks_ = 0;
  bool nodes_ = false;
  bool bricks_ = false;
  const float* fold_terms_cleared_ = nullptr;  // node launch: the term arrays last cleared
  int brick_resident_blocks_ = 0;
  int bricks_x_ = 1, bricks_y_ = 1, bricks_z_ = 1;
  std::vector<int> brick_moving_;  // moving nodes per brick (brick launch)
  int active_bricks_ = 0;
  bool brick_plan_stale_ = false;
  CudaLaunch launch_ = CudaLaunch::kAuto;
  int node_resident_blocks_ = 0;
  int alive_count_ = 0;
  std::vector<std::uint8_t> host_flags_;  // the flags as last uploaded: which tiles move
  std::vector<int> tile_moving_;          // moving nodes per tile
  int active_tiles_ = 0;
  bool tile_plan_stale_ = false;
  std::string device_name_;
  // Streams and events first: they outlive the buffers (the destructor waits on the streams).
  UniqueStream stream_, copy_stream_;
  UniqueEvent staged_, copied_;
  DeviceBuffer<float> state_[2][6];  // [buffer][ux,uy,uz,vx,vy,vz]
  int current_ = 0;
  DeviceBuffer<std::uint8_t> flags_;
  DeviceBuffer<float> inv_mass_;
  void upload_materials() {
    const std::size_t n = host_material_.size();
    std::vector<std::uint32_t> index(n), weight(n);
    for (std::size_t m = 0; m < n; ++m) {
      index[m] = host_material_[m].index;
      weight[m] = host_material_[m].weight;
    }
    TSF_CUDA_CHECK(cudaMemcpyAsync(material_index_.data(), index.data(), n * sizeof(std::uint32_t),
                                   cudaMemcpyHostToDevice, stream_.get()));
    TSF_CUDA_CHECK(cudaMemcpyAsync(material_weight_.data(), weight.data(),
                                   n * sizeof(std::uint32_t), cudaMemcpyHostToDevice,
                                   stream_.get()));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));  // the staging vectors go out of scope
  }

  std::vector<MaterialBlend> host_material_;
  DeviceBuffer<std::uint32_t> material_index_, material_weight_;
  DeviceBuffer<float> external_force_[3];
  DeviceBuffer<Guard> guard_;
  PinnedBuffer<Guard> guard_host_;
  DeviceBuffer<double> energy_device_;
  PinnedBuffer<double> energy_host_;
  DeviceBuffer<float> staging_;  // positions for snapshots, spring forces for queries
  PinnedBuffer<float> pinned_snapshot_[2];
  std::unique_ptr<SnapshotBuffer> snapshots_;
  bool copy_in_flight_ = false;
  std::int64_t in_flight_step_ = 0;
  std::int64_t steps_started_ = 0;
  std::vector<CachedGraph> graphs_;
  DeviceBuffer<int> tile_list_, tile_active_;
  DeviceBuffer<std::int32_t> alive_list_;
  DeviceBuffer<int> brick_list_;    // brick launch: the bricks that hold a moving node
  DeviceBuffer<float> node_terms_;  // node-parallel kernel: 15 vec3 terms per node
  PinnedBuffer<int> plan_staging_;
  struct ScatterStage {
    PinnedBuffer<std::int64_t> nodes;
    PinnedBuffer<std::uint8_t> values;
  };
  ScatterStage scatter_[2];  // stage_scatter(): 0 the flags, 1 the states or forces
};

}  // namespace

std::unique_ptr<SolverBackend> make_cuda_backend(const LatticeGeometry& geometry,
                                                 const BackendOptions& options) {
  require(cuda_status().available, "the CUDA backend cannot run here: " + cuda_status().reason);
  return std::make_unique<CudaBackend>(geometry, options);
}

double measure_device_copy_bandwidth(std::size_t buffer_bytes, int repetitions) {
  require(cuda_status().available, "cannot measure device bandwidth: " + cuda_status().reason);
  require(buffer_bytes > 0 && repetitions > 0, "bandwidth measurement needs bytes and repeats");
  DeviceBuffer<std::uint8_t> a(buffer_bytes), b(buffer_bytes);
  const UniqueEvent start = make_event(cudaEventDefault), stop = make_event(cudaEventDefault);
  TSF_CUDA_CHECK(cudaMemset(a.data(), 1, buffer_bytes));
  TSF_CUDA_CHECK(
      cudaMemcpy(b.data(), a.data(), buffer_bytes, cudaMemcpyDeviceToDevice));  // warm-up
  TSF_CUDA_CHECK(cudaEventRecord(start.get()));
  for (int r = 0; r < repetitions; ++r)
    TSF_CUDA_CHECK(cudaMemcpyAsync(b.data(), a.data(), buffer_bytes, cudaMemcpyDeviceToDevice));
  TSF_CUDA_CHECK(cudaEventRecord(stop.get()));
  TSF_CUDA_CHECK(cudaEventSynchronize(stop.get()));
  float ms = 0.0f;
  TSF_CUDA_CHECK(cudaEventElapsedTime(&ms, start.get(), stop.get()));
  return 2.0 * static_cast<double>(buffer_bytes) * repetitions / (ms * 1e-3);
}

}  // namespace tsf::crms
