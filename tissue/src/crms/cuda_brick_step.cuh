// The brick launch (CudaLaunch::kBricks) of the CUDA backend: a call's steps in one cooperative
// launch with ONE grid barrier per step. Included by cuda_backend.cu inside its anonymous
// namespace (it uses the backend's Guard, halted_before() and store_node_step()).
//
// A small lattice's step is bounded by latency, not arithmetic (docs/crms.md "Small lattices"):
// by the grid barriers between its phases (~1 µs each on an H200, bench_grid_barrier) and by the
// longest chain of dependent instructions and memory round trips one thread executes. The
// node-parallel kernel needs two barriers a step, because the reactions a node receives are
// computed by its neighbours. Here the lattice is cut into bricks (4 × 4 × 4 nodes), one brick per
// thread block at a time, and a block computes every term its brick's nodes need itself:
//   1. load the brick and one layer of nodes around it (6 × 6 × 6 nodes: u, v, flags, blends)
//      from global memory into shared memory, all loads issued at once (one round trip);
//   2. terms, one item per thread (288 threads), warp-uniform: every brick node's three angle
//      planes (plane_spring_terms: self + the 4 in-plane reactions, node_force_planes.h), and for
//      each of the 96 nodes on the six faces of the layer around the brick its reaction towards
//      the brick (reaction_towards: the 4 angles at it with an arm into the brick) — the layer's
//      share of the angles is recomputed rather than exchanged;
//   3. each brick node sums its self terms and the reactions of its linked neighbours in a
//      fixed order (deterministic, no atomics) and integrates (integrate_node), writing its new
//      state to global memory;
//   4. one grid barrier, then the next step reads the other ping-pong buffer.
// With the volumetric term folded in (VolumeFold), step 2 also runs the cube pass of the 5 × 5 × 5
// cubes that have a brick node as a corner (cube_volume_faces on the shared extended brick, into
// shared memory: a cube on a brick's border is computed by each brick it touches instead of
// exchanged), and step 3 kicks each
// moving node by its cubes' forces (volume_force_from, kick_after_step): still one barrier a step.
// Every piece of physics is the one copy in node_force.h / node_force_planes.h / node_update.h,
// read through a shared-memory stencil accessor. Bricks with no moving node are not stepped: they
// are copied in the launch's first two steps (u kept, v = 0), so that both ping-pong buffers hold
// them, alongside the other bricks' steps (disjoint nodes, no extra barrier).
#pragma once

/// A brick of BX × BY × BZ nodes and the layer around it: sizes, the thread count (three plane
/// items per brick node, one item per face-halo node, in whole warps), shared memory.
template <int BX, int BY, int BZ>
struct BrickShape {
  static constexpr int kX = BX, kY = BY, kZ = BZ;
  static constexpr int kNodes = BX * BY * BZ;
  static constexpr int kExtX = BX + 2, kExtY = BY + 2, kExtZ = BZ + 2;
  static constexpr int kExtNodes = kExtX * kExtY * kExtZ;
  static constexpr int kFaceX = BY * BZ, kFaceY = BX * BZ, kFaceZ = BX * BY;
  /// Nodes on the six faces of the layer around the brick (edges and corners excluded).
  static constexpr int kHalo = 2 * (kFaceX + kFaceY + kFaceZ);
  static constexpr int kThreads = (3 * kNodes + kHalo + 31) / 32 * 32;
  static_assert(kNodes % 32 == 0, "plane items must fill whole warps (warp-uniform planes)");

  /// Offset of a stencil slot in the extended brick (x fastest).
  static __device__ __forceinline__ int slot_offset_ext(int slot) {
    return slot_offset(slot, 0) + slot_offset(slot, 1) * kExtX +
           slot_offset(slot, 2) * kExtX * kExtY;
  }
  /// Extended-brick index of brick node b (x fastest).
  static __device__ __forceinline__ int node_ext(int b) {
    const int x = b % BX, y = (b / BX) % BY, z = b / (BX * BY);
    return (x + 1) + kExtX * ((y + 1) + kExtY * (z + 1));
  }
  /// Extended-brick index of face-halo node h and the direction from it towards the brick.
  static __device__ __forceinline__ int halo_ext(int h, int& toward) {
    int x, y, z;
    if (h < 2 * kFaceX) {  // the layers at x = −1 and x = BX
      const int side = h / kFaceX, r = h % kFaceX;
      x = side ? BX : -1, y = r % BY, z = r / BY;
      toward = make_direction(0, side ? -1 : 1);
    } else if (h < 2 * kFaceX + 2 * kFaceY) {
      const int g = h - 2 * kFaceX, side = g / kFaceY, r = g % kFaceY;
      y = side ? BY : -1, x = r % BX, z = r / BX;
      toward = make_direction(1, side ? -1 : 1);
    } else {
      const int g = h - 2 * kFaceX - 2 * kFaceY, side = g / kFaceZ, r = g % kFaceZ;
      z = side ? BZ : -1, x = r % BX, y = r / BX;
      toward = make_direction(2, side ? -1 : 1);
    }
    return (x + 1) + kExtX * ((y + 1) + kExtY * (z + 1));
  }
  /// The face-halo index of the node next to brick node (x, y, z) in direction d (outside).
  static __device__ __forceinline__ int halo_index(int x, int y, int z, int d) {
    const int side = d & 1;  // + direction: the far layer
    switch (direction_axis(d)) {
      case 0:
        return side * kFaceX + y + BY * z;
      case 1:
        return 2 * kFaceX + side * kFaceY + x + BX * z;
      default:
        return 2 * kFaceX + 2 * kFaceY + side * kFaceZ + x + BX * y;
    }
  }

  /// The brick and its layer in shared memory, plus their terms.
  struct Shared {
    float u[3][kExtNodes];
    float v[3][kExtNodes];
    /// [plane][slot: 0 self, 1 + q reaction towards arm q][component][brick node]
    float terms[3][5][3][kNodes];
    /// The reaction of face-halo node h towards its brick neighbour.
    float halo[3][kHalo];
    std::uint32_t material_index[kExtNodes];
    std::uint32_t material_weight[kExtNodes];
    /// The brick nodes' 1/m and external forces, loaded with the state (no round trip later).
    float inv_mass[kNodes];
    float external[3][kNodes];
    std::uint8_t flags[kExtNodes];
  };

  /// The cubes with a brick node as a corner (lower corners −1 … BX − 1 from the brick's first
  /// node, likewise y and z) and, with the folded volumetric term, their cube-pass terms, kept in
  /// shared memory after Shared.
  static constexpr int kCubesX = BX + 1, kCubesY = BY + 1, kCubesZ = BZ + 1;
  static constexpr int kCubes = kCubesX * kCubesY * kCubesZ;
  static_assert(kCubes <= kThreads, "one cube per thread");
  struct CubeShared {
    float face[3][3][kCubes];  ///< [face a][component][cube]
  };
  /// Dynamic shared memory of a launch with and without the folded volumetric term.
  static constexpr std::size_t kSharedBytes = sizeof(Shared);
  static constexpr std::size_t kFoldedSharedBytes = sizeof(Shared) + sizeof(CubeShared);
};
/// The brick of the default launch: 4 × 4 × 4 nodes, 288 threads (measured against 8 × 8 × 4 on
/// an H200: a step's time is one brick's chain, so smaller bricks spread a lattice over more of
/// the GPU; docs/crms.md "Small lattices").
using Brick = BrickShape<4, 4, 4>;

/// Every brick by index (bx + bricks_x·(by + bricks_y·bz)), those that hold a moving node first.
struct BrickPlan {
  int bricks_x = 1, bricks_y = 1, bricks_z = 1;
  const int* list = nullptr;
  int active = 0;  ///< bricks with a moving node (the first `active` of the list)
  int count = 0;   ///< bricks in all
};

/// The stencil accessor of node_force.h over the shared-memory brick (index e of the extended
/// brick). Every slot the brick kernel asks for lies inside the extended brick.
template <class B>
struct BrickStencil {
  using Scalar = float;
  const typename B::Shared& s;
  int e;
  __device__ __forceinline__ Vec3f u(int slot) const {
    const int m = e + B::slot_offset_ext(slot);
    return {s.u[0][m], s.u[1][m], s.u[2][m]};
  }
  __device__ __forceinline__ Vec3f v(int slot) const {
    const int m = e + B::slot_offset_ext(slot);
    return {s.v[0][m], s.v[1][m], s.v[2][m]};
  }
  __device__ __forceinline__ unsigned flags(int slot) const {
    return s.flags[e + B::slot_offset_ext(slot)];
  }
  __device__ __forceinline__ MaterialBlend material(int slot) const {
    const int m = e + B::slot_offset_ext(slot);
    MaterialBlend b;
    b.index = s.material_index[m];
    b.weight = s.material_weight[m];
    return b;
  }
};

/// The folded cube terms as volume_force_from's source: the cube with lower corner (ci, cj, ck) of
/// the brick whose extended box starts at (x0, y0, z0).
template <class B>
struct BrickCubeTerms {
  const typename B::CubeShared& s;
  int x0, y0, z0;
  TSF_HD_INLINE CubeTerms operator()(std::int64_t, int ci, int cj, int ck) const {
    const int q = (ci - x0) + B::kCubesX * ((cj - y0) + B::kCubesY * (ck - z0));
    CubeTerms t;
    for (int a = 0; a < 3; ++a) t.face[a] = {s.face[a][0][q], s.face[a][1][q], s.face[a][2][q]};
    return t;
  }
};

/// Cube q of the brick: its cube pass (cube_volume_faces), into `cubes`. The cube's corners lie in
/// the extended brick, so the pass reads the shared copy through a lattice and state view of the
/// extended brick (its own dims and strides; nodes outside the lattice were loaded unlinked, so a
/// cube that leaves the lattice is not intact there either).
template <unsigned F, class B>
__device__ __forceinline__ void brick_cube_terms(const LatticeView& lat,
                                                 const typename B::Shared& s,
                                                 const VolumeParameters& volume, int q,
                                                 typename B::CubeShared& cubes) {
  LatticeView ext;
  ext.dims = {B::kExtX, B::kExtY, B::kExtZ};
  ext.count = B::kExtNodes;
  ext.stride_y = B::kExtX;
  ext.stride_z = B::kExtX * B::kExtY;
  for (int a = 0; a < 3; ++a) ext.rest_length[a] = lat.rest_length[a];
  ext.flags = s.flags;
  if constexpr ((F & features::kHeterogeneous) != 0) {
    ext.material_index = s.material_index;
    ext.material_weight = s.material_weight;
  }
  ConstStateView state;
  for (int a = 0; a < 3; ++a) {
    state.u[a] = s.u[a];
    state.v[a] = s.v[a];
  }
  const int i = q % B::kCubesX, j = (q / B::kCubesX) % B::kCubesY,
            k = q / (B::kCubesX * B::kCubesY);
  const CubeTerms t =
      cube_volume_faces(ext, state, volume, i + j * ext.stride_y + k * ext.stride_z, i, j, k);
#pragma unroll
  for (int a = 0; a < 3; ++a)
#pragma unroll
    for (int comp = 0; comp < 3; ++comp) cubes.face[a][comp][q] = t.face[a][comp];
}

/// Plane P's terms of brick node b into the shared terms (nothing for a node that is not alive:
/// no linked neighbour reads them, and integrate_node ignores a non-moving node's force).
template <unsigned F, int P, class B>
__device__ __forceinline__ void brick_plane_terms(typename B::Shared& s, int b,
                                                  const float rest_length[3],
                                                  const MaterialPalette& palette) {
  const int e = B::node_ext(b);
  if ((s.flags[e] & kAliveBit) == 0) return;
  const BrickStencil<B> st{s, e};
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

/// Face-halo node h's reaction towards its brick neighbour (0 when they are not linked).
template <unsigned F, class B>
__device__ __forceinline__ void brick_halo_terms(typename B::Shared& s, int h,
                                                 const float rest_length[3],
                                                 const MaterialPalette& palette) {
  int toward = 0;
  const int e = B::halo_ext(h, toward);
  Vec3f r{0.0f, 0.0f, 0.0f};
  if ((s.flags[e] >> toward) & 1u) {
    const BrickStencil<B> st{s, e};
    r = reaction_towards<F>(st, toward, rest_length, palette);
  }
  s.halo[0][h] = r.x;
  s.halo[1][h] = r.y;
  s.halo[2][h] = r.z;
}

/// One step of brick (bx, by, bz): load, terms, sum and integrate (see header).
template <unsigned F, class B>
__device__ void brick_step(const LatticeView& lat, const ConstStateView& in, const StateView& out,
                           const StepParameters& p, Guard* guard, long long step, int bx, int by,
                           int bz, typename B::Shared& s, const VolumeFold& fold,
                           typename B::CubeShared& cubes) {
  constexpr bool kHetero = (F & features::kHeterogeneous) != 0;
  const int t = threadIdx.x;
  const int x0 = bx * B::kX - 1, y0 = by * B::kY - 1, z0 = bz * B::kZ - 1;
  // 1. The extended brick; nodes outside the lattice read as unlinked and at rest.
  for (int e = t; e < B::kExtNodes; e += B::kThreads) {
    const int x = x0 + e % B::kExtX, y = y0 + (e / B::kExtX) % B::kExtY,
              z = z0 + e / (B::kExtX * B::kExtY);
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
    const int bxi = x - x0 - 1, byi = y - y0 - 1, bzi = z - z0 - 1;
    if (inside && bxi >= 0 && bxi < B::kX && byi >= 0 && byi < B::kY && bzi >= 0 &&
        bzi < B::kZ) {  // a brick node
      const int bn = bxi + B::kX * (byi + B::kY * bzi);
      s.inv_mass[bn] = lat.inv_mass[n];
      if constexpr ((F & features::kExternalForces) != 0)
        for (int a = 0; a < 3; ++a) s.external[a][bn] = lat.external_force[a][n];
    }
  }
  __syncthreads();
  // 2. Terms, one item per thread, warp-uniform: plane t / kNodes of brick node t % kNodes, then
  // the face-halo nodes.
  if (t < B::kNodes)
    brick_plane_terms<F, 0, B>(s, t, lat.rest_length, p.palette);
  else if (t < 2 * B::kNodes)
    brick_plane_terms<F, 1, B>(s, t - B::kNodes, lat.rest_length, p.palette);
  else if (t < 3 * B::kNodes)
    brick_plane_terms<F, 2, B>(s, t - 2 * B::kNodes, lat.rest_length, p.palette);
  else if (t < 3 * B::kNodes + B::kHalo)
    brick_halo_terms<F, B>(s, t - 3 * B::kNodes, lat.rest_length, p.palette);
  // The folded volumetric term's cubes, on the last kCubes threads (the lighter halo items).
  if (fold.on && t >= B::kThreads - B::kCubes)
    brick_cube_terms<F, B>(lat, s, fold.term.parameters, t - (B::kThreads - B::kCubes), cubes);
  __syncthreads();
  // 3. Sum in a fixed order and integrate, one thread per brick node.
  if (t < B::kNodes) {
    const int c[3] = {t % B::kX, (t / B::kX) % B::kY, t / (B::kX * B::kY)};
    const int x = x0 + 1 + c[0], y = y0 + 1 + c[1], z = z0 + 1 + c[2];
    if (x < lat.dims.x && y < lat.dims.y && z < lat.dims.z) {
      const int e = B::node_ext(t);
      const unsigned fl = s.flags[e];
      const std::int64_t n = x + y * lat.stride_y + static_cast<std::int64_t>(z) * lat.stride_z;
      const Vec3f u{s.u[0][e], s.u[1][e], s.u[2][e]};
      const Vec3f v{s.v[0][e], s.v[1][e], s.v[2][e]};
      NodeStepResult r{u, Vec3f{0.0f, 0.0f, 0.0f}, true};  // not moving: u kept, v = 0
      if ((fl & (kAliveBit | kFixedBit)) == kAliveBit) {
        Vec3f f{0.0f, 0.0f, 0.0f};
#pragma unroll
        for (int plane = 0; plane < 3; ++plane)
          f += Vec3f{s.terms[plane][0][0][t], s.terms[plane][0][1][t], s.terms[plane][0][2][t]};
        constexpr int kExtent[3] = {B::kX, B::kY, B::kZ};
        constexpr int kStride[3] = {1, B::kX, B::kX * B::kY};
#pragma unroll
        for (int d = 0; d < 6; ++d) {
          if (((fl >> d) & 1u) == 0) continue;
          const int axis = direction_axis(d);
          const int next = c[axis] + direction_sign(d);
          if (next >= 0 && next < kExtent[axis]) {  // a brick node: its two planes' reactions
            const int m = t + direction_sign(d) * kStride[axis];
            const int back = opposite_direction(d);
#pragma unroll
            for (int plane = 0; plane < 3; ++plane)
              if (plane != axis) {
                const int slot = 1 + plane_arm_slot(plane, back);
                f += Vec3f{s.terms[plane][slot][0][m], s.terms[plane][slot][1][m],
                           s.terms[plane][slot][2][m]};
              }
          } else {  // a node of the layer around: its reaction towards this node
            const int h = B::halo_index(c[0], c[1], c[2], d);
            f += Vec3f{s.halo[0][h], s.halo[1][h], s.halo[2][h]};
          }
        }
        Vec3f external{0.0f, 0.0f, 0.0f};
        if constexpr ((F & features::kExternalForces) != 0)
          external = {s.external[0][t], s.external[1][t], s.external[2][t]};
        r = integrate_node<F>(fl, u, v, s.inv_mass[t], external, f, p);
        if (fold.on)
          kick_step_result(r, u,
                           volume_force_from(lat, n, x, y, z, BrickCubeTerms<B>{cubes, x0, y0, z0}),
                           s.inv_mass[t], p);
      }
      store_node_step(out, n, r, guard, step);
    }
  }
}

/// The nodes of a brick that no node of moves (or of any brick in a halted step): u kept, v kept
/// when halted, else 0 (what integrate_node gives a node that does not move).
template <class B>
__device__ void brick_copy(const LatticeView& lat, const ConstStateView& in, const StateView& out,
                           int bx, int by, int bz, bool halted) {
  for (int b = threadIdx.x; b < B::kNodes; b += B::kThreads) {
    const int x = bx * B::kX + b % B::kX, y = by * B::kY + (b / B::kX) % B::kY,
              z = bz * B::kZ + b / (B::kX * B::kY);
    if (x >= lat.dims.x || y >= lat.dims.y || z >= lat.dims.z) continue;
    const std::int64_t n = x + y * lat.stride_y + static_cast<std::int64_t>(z) * lat.stride_z;
    for (int c = 0; c < 3; ++c) {
      out.u[c][n] = in.u[c][n];
      out.v[c][n] = halted ? in.v[c][n] : 0.0f;
    }
  }
}

/// `steps` steps in one cooperative launch, one grid barrier a step. Bricks with a moving node
/// step; the others are copied in the launch's first two steps only (both state buffers then
/// hold them); a halted step copies every brick.
template <unsigned F, class B = Brick>
__global__ void __launch_bounds__(B::kThreads, 2)
    brick_step_kernel(LatticeView lat, StateView a, StateView b, StepParameters p, Guard* guard,
                      int steps, BrickPlan plan, VolumeFold fold) {
  extern __shared__ __align__(16) unsigned char brick_smem[];
  typename B::Shared& s = *reinterpret_cast<typename B::Shared*>(brick_smem);
  // Only a folded launch allocates the cubes (B::kFoldedSharedBytes).
  typename B::CubeShared& cubes =
      *reinterpret_cast<typename B::CubeShared*>(brick_smem + sizeof(typename B::Shared));
  cooperative_groups::grid_group grid = cooperative_groups::this_grid();
  const long long base = guard->step_base;
  for (int st = 0; st < steps; ++st) {
    const ConstStateView in = (st & 1) ? b : a;
    const StateView out = (st & 1) ? a : b;
    const long long step = base + st;
    const bool halted = halted_before(guard, step);
    const int stepped = halted ? 0 : plan.active;
    const int copied = halted || st < 2 ? plan.count : plan.active;
    for (int q = blockIdx.x; q < copied; q += gridDim.x) {
      const int brick = plan.list[q];
      const int bx = brick % plan.bricks_x, by = (brick / plan.bricks_x) % plan.bricks_y,
                bz = brick / (plan.bricks_x * plan.bricks_y);
      if (q < stepped) {
        brick_step<F, B>(lat, in, out, p, guard, step, bx, by, bz, s, fold, cubes);
        __syncthreads();  // the shared brick is reused by the block's next brick
      } else if (q >= plan.active || halted) {
        brick_copy<B>(lat, in, out, bx, by, bz, halted);
      }
    }
    grid.sync();
  }
}
