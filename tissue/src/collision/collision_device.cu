// Collision queries on the GPU (collision_device.h). The gather kernel runs node_in_tool() — the
// same TSF_HD test the CPU path runs on its broad-phase candidates — on every alive node inside
// the query box and appends hits with an atomic counter, straight into mapped page-locked host
// memory; the host sorts them by node so both backends return the same order. The force kernel
// calls crms::spring_force<F> on listed nodes, reading the ids from and writing the forces to
// mapped host memory. Each query is one launch and one wait (docs/deform-cut.md, "The device
// round trips of a pass").
#include <cuda_runtime.h>

#include <algorithm>
#include <numeric>
#include <string>
#include <vector>

#include "collision_device.h"
#include "tsf/common/cuda_check.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/device_buffer.h"
#include "tsf/common/error.h"
#include "tsf/crms/effects.h"
#include "tsf/crms/node_force.h"
#include "tsf/crms/stencil.h"

namespace tsf::collision {
namespace {

struct GatherHit {
  long long node;
  Vec3f u;
  Vec3f target;
  Vec3f normal;
  int inside;
};

/// Tests every alive node against the box and the tool and appends the hits to `hits` (mapped
/// host memory) through `counter`. The last block to finish writes the count to `found_host`
/// (mapped host memory too) and sets `counter` and `blocks_done` back to zero for the next
/// launch, so that a gather is one launch and one wait: no memset before it, no copy after it.
__global__ void gather_kernel(coupler::DeformedLatticeView lat, Vec3f lo, Vec3f hi, WorldTool tool,
                              int has_tool, GatherHit* hits, unsigned long long capacity,
                              unsigned long long* counter, unsigned int* blocks_done,
                              unsigned long long* found_host) {
  const long long n = static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (n < lat.dims.volume() && lat.alive(n)) {
    const int i = static_cast<int>(n % lat.dims.x);
    const int j = static_cast<int>((n / lat.dims.x) % lat.dims.y);
    const int k = static_cast<int>(n / (static_cast<long long>(lat.dims.x) * lat.dims.y));
    const Vec3f u = lat.displacement(n);
    const Vec3f p = lat.rest(i, j, k) + u;
    if (p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z) {
      GatherHit h;
      h.node = n;
      h.u = u;
      h.target = Vec3f{0, 0, 0};
      h.normal = Vec3f{0, 0, 0};
      h.inside = has_tool ? (node_in_tool(tool, p, h.target, h.normal) ? 1 : 0) : 0;
      const unsigned long long slot = atomicAdd(counter, 1ull);
      if (slot < capacity) hits[slot] = h;
    }
  }
  // Every thread's count is in before its block reports done (the fence orders the two), so the
  // block that reports last reads the final count.
  __threadfence();
  __syncthreads();
  if (threadIdx.x == 0 && atomicAdd(blocks_done, 1u) == gridDim.x - 1) {
    __threadfence();
    *found_host = atomicAdd(counter, 0ull);
    *counter = 0;
    *blocks_done = 0;
  }
}

template <unsigned F>
__global__ void spring_force_kernel(crms::LatticeView lat, crms::ConstStateView st,
                                    crms::MaterialPalette palette, const long long* nodes,
                                    int count, Vec3f* forces) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count) return;
  const long long n = nodes[t];
  if (n < 0 || n >= lat.count || !(lat.flags[n] & crms::kAliveBit)) {
    forces[t] = Vec3f{0, 0, 0};
    return;
  }
  const int i = static_cast<int>(n % lat.dims.x);
  const int j = static_cast<int>((n / lat.dims.x) % lat.dims.y);
  const int k = static_cast<int>(n / (static_cast<long long>(lat.dims.x) * lat.dims.y));
  const crms::IndexedStencil s{lat, st, n, i, j, k};
  forces[t] = crms::spring_force<F>(s, lat.rest_length, palette);
}

class CudaCollisionDevice final : public CollisionDevice {
 public:
  CudaCollisionDevice() {
    require(cuda_status().available,
            "collision: the CUDA path is not available: " + cuda_status().reason);
    stream_ = make_stream();
    counter_.resize(1);
    blocks_done_.resize(1);
    counter_.fill_zero(stream_.get());  // then each gather leaves them at zero for the next
    blocks_done_.fill_zero(stream_.get());
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    found_host_.resize(1);
    hits_host_.resize(4096);
  }

  void gather(const coupler::DeformedLatticeView& lattice, const Vec3f& lo, const Vec3f& hi,
              const WorldTool* tool, NodeNeighbourhood& out) override {
    const long long count = lattice.dims.volume();
    out.clear();
    out.lo = lo;
    out.hi = hi;
    if (count <= 0) return;
    const unsigned blocks = static_cast<unsigned>((count + 255) / 256);
    const WorldTool t = tool ? *tool : WorldTool{};
    // The kernel writes its hits and their count straight into page-locked host memory (mapped:
    // one address on both sides under unified addressing), so the gather is one launch and one
    // wait, with no copy of the hits after learning how many there are.
    unsigned long long found = 0;
    for (int attempt = 0; attempt < 2; ++attempt) {
      gather_kernel<<<blocks, 256, 0, stream_.get()>>>(
          lattice, lo, hi, t, tool ? 1 : 0, hits_host_.data(), hits_host_.capacity(),
          counter_.data(), blocks_done_.data(), found_host_.data());
      TSF_CUDA_CHECK_LAUNCH();
      TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
      found = found_host_.data()[0];
      if (found <= hits_host_.capacity()) break;
      hits_host_.resize(static_cast<std::size_t>(found) * 2);  // too many for the buffer: retry
    }
    require(found <= hits_host_.capacity(), "collision: gather overflowed its buffer twice");
    GatherHit* hits = hits_host_.data();  // the kernel is done with them: sorted in place
    const auto n = static_cast<std::size_t>(found);
    std::sort(hits, hits + n,
              [](const GatherHit& a, const GatherHit& b) { return a.node < b.node; });
    out.nodes.resize(n);
    out.displacement.resize(n);
    out.inside.resize(n);
    out.target.resize(n);
    out.normal.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      out.nodes[i] = hits[i].node;
      out.displacement[i] = hits[i].u;
      out.inside[i] = static_cast<std::uint8_t>(hits[i].inside);
      out.target[i] = hits[i].target;
      out.normal[i] = hits[i].normal;
    }
  }

  void spring_forces_at(const crms::LatticeView& lattice, const crms::StateView& state,
                        const crms::MaterialPalette& palette, unsigned features,
                        const std::vector<std::int64_t>& nodes,
                        std::vector<Vec3f>& forces) override {
    forces.assign(nodes.size(), Vec3f{0, 0, 0});
    if (nodes.empty()) return;
    const int count = static_cast<int>(nodes.size());
    // The ids go up and the forces come down through mapped page-locked memory, which the kernel
    // reads and writes directly: one launch and one wait, no copies queued around it.
    ids_host_.resize(nodes.size());
    forces_host_.resize(nodes.size());
    std::copy(nodes.begin(), nodes.end(), ids_host_.data());
    const unsigned blocks = static_cast<unsigned>((count + 127) / 128);
    require(features <= crms::features::kAll,
            "collision: unknown CRMS feature set " + std::to_string(features));
    crms::dispatch_features(features, [&](auto f) {
      constexpr unsigned F = decltype(f)::value;
      spring_force_kernel<F>
          <<<blocks, 128, 0, stream_.get()>>>(lattice, crms::ConstStateView(state), palette,
                                              ids_host_.data(), count, forces_host_.data());
    });
    TSF_CUDA_CHECK_LAUNCH();
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    std::copy(forces_host_.data(), forces_host_.data() + count, forces.begin());
  }

 private:
  DeviceBuffer<unsigned long long> counter_;
  DeviceBuffer<unsigned int> blocks_done_;
  PinnedBuffer<unsigned long long> found_host_;
  PinnedBuffer<GatherHit> hits_host_;  // written by the gather kernel (mapped)
  PinnedBuffer<long long> ids_host_;   // read by the force kernel (mapped)
  PinnedBuffer<Vec3f> forces_host_;    // written by the force kernel (mapped)
  // Last: destroyed first, after waiting for the work that uses the buffers above.
  UniqueStream stream_;
};

}  // namespace

std::unique_ptr<CollisionDevice> make_collision_device() {
  return std::make_unique<CudaCollisionDevice>();
}

}  // namespace tsf::collision
