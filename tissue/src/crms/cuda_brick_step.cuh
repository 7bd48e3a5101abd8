// The brick launch (CudaLaunch::kBricks) of the CUDA backend: a call's steps in one cooperative
// launch with ONE grid barrier per step. Included by cuda_backend.cu inside its anonymous
// namespace (it uses the backend's Guard and halted_before()).
//
// A small lattice's step is bounded by latency, not arithmetic (docs/crms.md "Small lattices"):
// by the grid barriers between its phases (~1 µs each on an H200, bench_grid_barrier) and by the
// longest chain of dependent instructions and memory round trips one thread executes. The
// node-parallel kernel needs two barriers a step, because the reactions a node receives are
// computed by its neighbours. Here the lattice is cut into bricks of 8 × 8 × 4 nodes, one brick
// per thread block at a time, and a block computes every term its brick's nodes need itself:
//   1. load the brick and one layer of nodes around it (10 × 10 × 6 nodes: u, v, flags, blends)
//      from global memory into shared memory, all loads issued at once (one round trip);
//   2. terms, 512 threads, two items each, warp-uniform: every brick node's three angle planes
//      (plane_spring_terms: self + the 4 in-plane reactions, node_force_planes.h), and for each
//      of the 256 nodes on the six faces of the layer around the brick its reaction towards the
//      brick (reaction_towards: the 4 angles at it with an arm into the brick) — the halo's
//      share of the angles is recomputed rather than exchanged;
//   3. each brick node sums its self terms and the reactions of its linked neighbours in a
//      fixed order (deterministic, no atomics) and integrates (integrate_node), writing its new
//      state to global memory;
//   4. one grid barrier, then the next step reads the other ping-pong buffer.
// Every piece of physics is the one copy in node_force.h / node_force_planes.h / node_update.h,
// read through a shared-memory stencil accessor. Bricks with no moving node are not in the plan;
// like the node-parallel kernel, the launch's first two steps copy every node's state (a
// non-moving node: u kept, v = 0) so that both buffers hold the nodes no brick steps.
#pragma once

constexpr int kBrickX = 8, kBrickY = 8, kBrickZ = 4;
constexpr int kBrickNodes = kBrickX * kBrickY * kBrickZ;  // 256
constexpr int kBrickExtX = kBrickX + 2, kBrickExtY = kBrickY + 2, kBrickExtZ = kBrickZ + 2;
constexpr int kBrickExtNodes = kBrickExtX * kBrickExtY * kBrickExtZ;  // 600
/// Nodes on the six faces of the layer around a brick (edges and corners excluded).
constexpr int kBrickHalo = 2 * (kBrickY * kBrickZ + kBrickX * kBrickZ + kBrickX * kBrickY);
constexpr int kBrickThreads = 512;
static_assert(kBrickNodes == 256 && kBrickHalo == 256 && kBrickThreads == 2 * kBrickNodes,
              "the item split below assumes 256 brick nodes, 256 halo nodes, 512 threads");

/// The bricks that hold a moving node, listed by index (bx + bricks_x·(by + bricks_y·bz)).
struct BrickPlan {
  int bricks_x = 1, bricks_y = 1, bricks_z = 1;
  const int* list = nullptr;
  int active = 0;
};

/// A brick and the layer around it in shared memory, plus its terms.
struct BrickShared {
  float u[3][kBrickExtNodes];
  float v[3][kBrickExtNodes];
  /// [plane][slot: 0 self, 1 + q reaction towards arm q][component][brick node]
  float terms[3][5][3][kBrickNodes];
  /// The reaction of face-halo node h towards its brick neighbour.
  float halo[3][kBrickHalo];
  std::uint32_t material_index[kBrickExtNodes];
  std::uint32_t material_weight[kBrickExtNodes];
  std::uint8_t flags[kBrickExtNodes];
};

/// Offset of a stencil slot in the extended brick (10 × 10 × 6, x fastest).
__device__ __forceinline__ int brick_slot_offset(int slot) {
  return slot_offset(slot, 0) + slot_offset(slot, 1) * kBrickExtX +
         slot_offset(slot, 2) * kBrickExtX * kBrickExtY;
}

/// The stencil accessor of node_force.h over the shared-memory brick (index e of the extended
/// brick). Every slot the brick kernel asks for lies inside the extended brick.
struct BrickStencil {
  using Scalar = float;
  const BrickShared& s;
  int e;
  __device__ __forceinline__ Vec3f u(int slot) const {
    const int m = e + brick_slot_offset(slot);
    return {s.u[0][m], s.u[1][m], s.u[2][m]};
  }
  __device__ __forceinline__ Vec3f v(int slot) const {
    const int m = e + brick_slot_offset(slot);
    return {s.v[0][m], s.v[1][m], s.v[2][m]};
  }
  __device__ __forceinline__ unsigned flags(int slot) const {
    return s.flags[e + brick_slot_offset(slot)];
  }
  __device__ __forceinline__ MaterialBlend material(int slot) const {
    const int m = e + brick_slot_offset(slot);
    MaterialBlend b;
    b.index = s.material_index[m];
    b.weight = s.material_weight[m];
    return b;
  }
};

/// Extended-brick index of brick node b (x fastest) and of face-halo node h, with the direction
/// from the halo node towards its brick neighbour.
__device__ __forceinline__ int brick_node_ext(int b) {
  const int x = b % kBrickX, y = (b / kBrickX) % kBrickY, z = b / (kBrickX * kBrickY);
  return (x + 1) + kBrickExtX * ((y + 1) + kBrickExtY * (z + 1));
}
__device__ __forceinline__ int brick_halo_ext(int h, int& toward) {
  constexpr int kFaceX = kBrickY * kBrickZ, kFaceY = kBrickX * kBrickZ, kFaceZ = kBrickX * kBrickY;
  int x, y, z;
  if (h < 2 * kFaceX) {  // the layers at x = −1 and x = kBrickX
    const int side = h / kFaceX, r = h % kFaceX;
    x = side ? kBrickX : -1, y = r % kBrickY, z = r / kBrickY;
    toward = make_direction(0, side ? -1 : 1);
  } else if (h < 2 * kFaceX + 2 * kFaceY) {
    const int g = h - 2 * kFaceX, side = g / kFaceY, r = g % kFaceY;
    y = side ? kBrickY : -1, x = r % kBrickX, z = r / kBrickX;
    toward = make_direction(1, side ? -1 : 1);
  } else {
    const int g = h - 2 * kFaceX - 2 * kFaceY, side = g / kFaceZ, r = g % kFaceZ;
    z = side ? kBrickZ : -1, x = r % kBrickX, y = r / kBrickX;
    toward = make_direction(2, side ? -1 : 1);
  }
  return (x + 1) + kBrickExtX * ((y + 1) + kBrickExtY * (z + 1));
}
/// The face-halo index of the extended-brick node next to brick node (x, y, z) in direction d.
__device__ __forceinline__ int brick_halo_index(int x, int y, int z, int d) {
  constexpr int kFaceX = kBrickY * kBrickZ, kFaceY = kBrickX * kBrickZ, kFaceZ = kBrickX * kBrickY;
  const int side = d & 1;  // + direction: the far layer
  switch (direction_axis(d)) {
    case 0:
      return side * kFaceX + y + kBrickY * z;
    case 1:
      return 2 * kFaceX + side * kFaceY + x + kBrickX * z;
    default:
      return 2 * kFaceX + 2 * kFaceY + side * kFaceZ + x + kBrickX * y;
  }
}

/// Plane P's terms of brick node b into the shared terms (nothing for a node that is not alive:
/// no linked neighbour reads them, and integrate_node ignores a non-moving node's force).
template <unsigned F, int P>
__device__ __forceinline__ void brick_plane_terms(BrickShared& s, int b, const float rest_length[3],
                                                  const MaterialPalette& palette) {
  const int e = brick_node_ext(b);
  if ((s.flags[e] & kAliveBit) == 0) return;
  const BrickStencil st{s, e};
  Vec3f self, reaction[4];
  plane_spring_terms<F, P>(st, rest_length, palette, self, reaction);
  s.terms[P][0][0][b] = self.x;
  s.terms[P][0][1][b] = self.y;
  s.terms[P][0][2][b] = self.z;
#pragma unroll
  for (int q = 0; q < 4; ++q) {
    s.terms[P][1 + q][0][b] = reaction[q].x;
    s.terms[P][1 + q][1][b] = reaction[q].y;
    s.terms[P][1 + q][2][b] = reaction[q].z;
  }
}

template <unsigned F>
__device__ __forceinline__ void brick_halo_terms(BrickShared& s, int h, const float rest_length[3],
                                                 const MaterialPalette& palette) {
  int toward = 0;
  const int e = brick_halo_ext(h, toward);
  Vec3f r{0.0f, 0.0f, 0.0f};
  if ((s.flags[e] >> toward) & 1u) {  // linked to its brick neighbour (so alive)
    const BrickStencil st{s, e};
    r = reaction_towards<F>(st, toward, rest_length, palette);
  }
  s.halo[0][h] = r.x;
  s.halo[1][h] = r.y;
  s.halo[2][h] = r.z;
}

/// One step of brick (bx, by, bz): load, terms, sum and integrate (see header).
template <unsigned F>
__device__ void brick_step(const LatticeView& lat, const ConstStateView& in, const StateView& out,
                           const StepParameters& p, Guard* guard, long long step, int bx, int by,
                           int bz, BrickShared& s) {
  constexpr bool kHetero = (F & features::kHeterogeneous) != 0;
  const int t = threadIdx.x;
  const int x0 = bx * kBrickX - 1, y0 = by * kBrickY - 1, z0 = bz * kBrickZ - 1;
  // 1. The extended brick; nodes outside the lattice read as unlinked and at rest.
  for (int e = t; e < kBrickExtNodes; e += kBrickThreads) {
    const int x = x0 + e % kBrickExtX, y = y0 + (e / kBrickExtX) % kBrickExtY,
              z = z0 + e / (kBrickExtX * kBrickExtY);
    const bool inside = static_cast<unsigned>(x) < static_cast<unsigned>(lat.dims.x) &&
                        static_cast<unsigned>(y) < static_cast<unsigned>(lat.dims.y) &&
                        static_cast<unsigned>(z) < static_cast<unsigned>(lat.dims.z);
    const std::int64_t n = x + y * lat.stride_y + static_cast<std::int64_t>(z) * lat.stride_z;
#pragma unroll
    for (int a = 0; a < 3; ++a) {
      s.u[a][e] = inside ? in.u[a][n] : 0.0f;
      s.v[a][e] = inside ? in.v[a][n] : 0.0f;
    }
    s.flags[e] = inside ? lat.flags[n] : 0;
    if constexpr (kHetero) {
      s.material_index[e] = inside ? lat.material_index[n] : 0u;
      s.material_weight[e] = inside ? lat.material_weight[n] : 0u;
    }
  }
  __syncthreads();
  // 2. Terms: threads 0–255 planes 0 and 2 of brick node t, threads 256–511 plane 1 of brick
  // node t − 256 and face-halo node t − 256 (warp-uniform).
  if (t < kBrickNodes) {
    brick_plane_terms<F, 0>(s, t, lat.rest_length, p.palette);
    brick_plane_terms<F, 2>(s, t, lat.rest_length, p.palette);
  } else {
    brick_plane_terms<F, 1>(s, t - kBrickNodes, lat.rest_length, p.palette);
    brick_halo_terms<F>(s, t - kBrickNodes, lat.rest_length, p.palette);
  }
  __syncthreads();
  // 3. Sum and integrate, one thread per brick node.
  if (t < kBrickNodes) {
    const int bxi = t % kBrickX, byi = (t / kBrickX) % kBrickY, bzi = t / (kBrickX * kBrickY);
    const int x = x0 + 1 + bxi, y = y0 + 1 + byi, z = z0 + 1 + bzi;
    if (x < lat.dims.x && y < lat.dims.y && z < lat.dims.z) {
      const int e = brick_node_ext(t);
      const unsigned fl = s.flags[e];
      const std::int64_t n = x + y * lat.stride_y + static_cast<std::int64_t>(z) * lat.stride_z;
      const Vec3f u{s.u[0][e], s.u[1][e], s.u[2][e]};
      const Vec3f v{s.v[0][e], s.v[1][e], s.v[2][e]};
      NodeStepResult r{u, Vec3f{0.0f, 0.0f, 0.0f}, true};
      if ((fl & (kAliveBit | kFixedBit)) == kAliveBit) {
        Vec3f f{0.0f, 0.0f, 0.0f};
#pragma unroll
        for (int plane = 0; plane < 3; ++plane)
          f += Vec3f{s.terms[plane][0][0][t], s.terms[plane][0][1][t], s.terms[plane][0][2][t]};
        const int c[3] = {bxi, byi, bzi};
        const int brick_extent[3] = {kBrickX, kBrickY, kBrickZ};
        const int brick_stride[3] = {1, kBrickX, kBrickX * kBrickY};
#pragma unroll
        for (int d = 0; d < 6; ++d) {
          if (((fl >> d) & 1u) == 0) continue;
          const int axis = direction_axis(d);
          const int next = c[axis] + direction_sign(d);
          if (next >= 0 && next < brick_extent[axis]) {  // a brick node: its two planes' terms
            const int m = t + direction_sign(d) * brick_stride[axis];
            const int back = opposite_direction(d);
#pragma unroll
            for (int plane = 0; plane < 3; ++plane)
              if (plane != axis) {
                const int slot = 1 + plane_arm_slot(plane, back);
                f += Vec3f{s.terms[plane][slot][0][m], s.terms[plane][slot][1][m],
                           s.terms[plane][slot][2][m]};
              }
          } else {  // a halo node: its reaction towards this node
            const int h = brick_halo_index(bxi, byi, bzi, d);
            f += Vec3f{s.halo[0][h], s.halo[1][h], s.halo[2][h]};
          }
        }
        Vec3f external{0.0f, 0.0f, 0.0f};
        if constexpr ((F & features::kExternalForces) != 0)
          external = {lat.external_force[0][n], lat.external_force[1][n], lat.external_force[2][n]};
        r = integrate_node<F>(fl, u, v, lat.inv_mass[n], external, f, p);
      }
      out.u[0][n] = r.u.x, out.u[1][n] = r.u.y, out.u[2][n] = r.u.z;
      out.v[0][n] = r.v.x, out.v[1][n] = r.v.y, out.v[2][n] = r.v.z;
      if (!r.finite) {
        guard->bad_step = step;
        atomicMin(&guard->bad_node, static_cast<unsigned long long>(n));
      }
    }
  }
}

/// `steps` steps in one cooperative launch, one grid barrier a step (two more in the launch's
/// first two steps, and in halted steps, for the copy of every node).
template <unsigned F>
__global__ void __launch_bounds__(kBrickThreads, 1)
    brick_step_kernel(LatticeView lat, StateView a, StateView b, StepParameters p, Guard* guard,
                      int steps, BrickPlan plan) {
  extern __shared__ __align__(16) unsigned char brick_smem[];
  BrickShared& s = *reinterpret_cast<BrickShared*>(brick_smem);
  cooperative_groups::grid_group grid = cooperative_groups::this_grid();
  const long long base = guard->step_base;
  const std::int64_t threads = static_cast<std::int64_t>(gridDim.x) * blockDim.x;
  const std::int64_t tid = static_cast<std::int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  for (int st = 0; st < steps; ++st) {
    const ConstStateView in = (st & 1) ? b : a;
    const StateView out = (st & 1) ? a : b;
    const long long step = base + st;
    const bool halted = halted_before(guard, step);
    if (st < 2 || halted) {  // every node: halted keeps its state, a non-moving one u and v = 0
      for (std::int64_t n = tid; n < lat.count; n += threads) {
        const bool moving = (lat.flags[n] & (kAliveBit | kFixedBit)) == kAliveBit;
        for (int c = 0; c < 3; ++c) {
          out.u[c][n] = in.u[c][n];
          out.v[c][n] = halted || moving ? in.v[c][n] : 0.0f;
        }
      }
      grid.sync();
    }
    if (!halted)
      for (int q = blockIdx.x; q < plan.active; q += gridDim.x) {
        const int brick = plan.list[q];
        const int bx = brick % plan.bricks_x, by = (brick / plan.bricks_x) % plan.bricks_y,
                  bz = brick / (plan.bricks_x * plan.bricks_y);
        brick_step<F>(lat, in, out, p, guard, step, bx, by, bz, s);
        __syncthreads();  // the shared brick is reused by the block's next brick
      }
    grid.sync();
  }
}
