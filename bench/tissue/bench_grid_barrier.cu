// What one grid-wide synchronisation costs on this GPU, the floor under a small lattice's step
// when a call's steps run in one launch (docs/crms.md "Small lattices"): every block of a
// persistent launch waits for every other (or for its neighbours) `iterations` times, with no
// other work, and the time per iteration is printed for each way of waiting:
//   cg        cooperative_groups::this_grid().sync() (what the node-parallel kernel used)
//   counter   one monotonic arrival counter: a release add per block, every block polls it with
//             acquire loads until it reaches blocks × (iteration + 1); no reset, no second hop
//   cluster   the same counter, but blocks first meet in their thread-block cluster (hardware
//             barrier), one block per cluster adds the cluster's count and polls, and the cluster
//             meets again
//   neighbours  no global barrier: each block publishes its iteration and waits for the two
//             blocks beside it (a slab decomposition's exchange), so waits do not serialise on one
//             address
// Usage: bench_grid_barrier [--iterations N]   (prints a table; exit 1 without a GPU)
#include <cooperative_groups.h>
#include <cuda_runtime.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace cg = cooperative_groups;

#define CHECK(x)                                                                             \
  do {                                                                                       \
    cudaError_t e = (x);                                                                     \
    if (e != cudaSuccess) {                                                                  \
      std::fprintf(stderr, "%s:%d %s: %s\n", __FILE__, __LINE__, #x, cudaGetErrorString(e)); \
      std::exit(1);                                                                          \
    }                                                                                        \
  } while (0)

__device__ __forceinline__ unsigned load_acquire(const unsigned* p) {
  unsigned v;
  asm volatile("ld.acquire.gpu.global.u32 %0, [%1];" : "=r"(v) : "l"(p) : "memory");
  return v;
}
__device__ __forceinline__ void add_release(unsigned* p, unsigned v) {
  asm volatile("red.release.gpu.global.add.u32 [%0], %1;" ::"l"(p), "r"(v) : "memory");
}
__device__ __forceinline__ void store_release(unsigned* p, unsigned v) {
  asm volatile("st.release.gpu.global.u32 [%0], %1;" ::"l"(p), "r"(v) : "memory");
}

__global__ void cg_kernel(int iterations, float* sink) {
  cg::grid_group grid = cg::this_grid();
  float acc = 0.0f;
  for (int it = 0; it < iterations; ++it) {
    acc += 1.0f;
    grid.sync();
  }
  if (acc < 0.0f) sink[0] = acc;
}

__global__ void counter_kernel(int iterations, unsigned* counter, float* sink) {
  float acc = 0.0f;
  const unsigned blocks = gridDim.x;
  for (int it = 0; it < iterations; ++it) {
    acc += 1.0f;
    __syncthreads();
    if (threadIdx.x == 0) {
      add_release(counter, 1u);
      const unsigned target = blocks * static_cast<unsigned>(it + 1);
      while (load_acquire(counter) < target) {
      }
    }
    __syncthreads();
  }
  if (acc < 0.0f) sink[0] = acc;
}

__global__ void cluster_kernel(int iterations, unsigned* counter, float* sink) {
  cg::cluster_group cluster = cg::this_cluster();
  float acc = 0.0f;
  const unsigned clusters = gridDim.x / cluster.num_blocks();
  for (int it = 0; it < iterations; ++it) {
    acc += 1.0f;
    cluster.sync();
    if (cluster.block_rank() == 0 && threadIdx.x == 0) {
      add_release(counter, 1u);
      const unsigned target = clusters * static_cast<unsigned>(it + 1);
      while (load_acquire(counter) < target) {
      }
    }
    cluster.sync();
  }
  if (acc < 0.0f) sink[0] = acc;
}

__global__ void neighbour_kernel(int iterations, unsigned* flags, float* sink) {
  float acc = 0.0f;
  const int b = blockIdx.x, blocks = gridDim.x;
  for (int it = 0; it < iterations; ++it) {
    acc += 1.0f;
    __syncthreads();
    if (threadIdx.x == 0) store_release(&flags[b * 32], static_cast<unsigned>(it + 1));
    if (threadIdx.x == 1 && b > 0)
      while (load_acquire(&flags[(b - 1) * 32]) < static_cast<unsigned>(it + 1)) {
      }
    if (threadIdx.x == 2 && b + 1 < blocks)
      while (load_acquire(&flags[(b + 1) * 32]) < static_cast<unsigned>(it + 1)) {
      }
    __syncthreads();
  }
  if (acc < 0.0f) sink[0] = acc;
}

int main(int argc, char** argv) {
  int iterations = 20000;
  for (int a = 1; a < argc; ++a)
    if (std::strcmp(argv[a], "--iterations") == 0 && a + 1 < argc)
      iterations = std::atoi(argv[++a]);
  int count = 0;
  if (cudaGetDeviceCount(&count) != cudaSuccess || count == 0) {
    std::fprintf(stderr, "bench_grid_barrier: no CUDA device\n");
    return 1;
  }
  cudaDeviceProp prop{};
  CHECK(cudaGetDeviceProperties(&prop, 0));
  const int sms = prop.multiProcessorCount;
  std::printf("device %s, %d multiprocessors, %d iterations per launch\n", prop.name, sms,
              iterations);
  unsigned* counter = nullptr;
  float* sink = nullptr;
  CHECK(cudaMalloc(&counter, sizeof(unsigned) * 32 * 1024));
  CHECK(cudaMalloc(&sink, sizeof(float)));
  cudaEvent_t start, stop;
  CHECK(cudaEventCreate(&start));
  CHECK(cudaEventCreate(&stop));

  auto time_launch = [&](auto&& launch) {
    CHECK(cudaMemset(counter, 0, sizeof(unsigned) * 32 * 1024));
    launch(100);  // warm-up
    CHECK(cudaDeviceSynchronize());
    CHECK(cudaMemset(counter, 0, sizeof(unsigned) * 32 * 1024));
    CHECK(cudaEventRecord(start));
    launch(iterations);
    CHECK(cudaEventRecord(stop));
    CHECK(cudaEventSynchronize(stop));
    float ms = 0.0f;
    CHECK(cudaEventElapsedTime(&ms, start, stop));
    return 1e3 * ms / iterations;
  };

  std::printf("%-11s %7s %8s %10s\n", "barrier", "blocks", "threads", "us/iter");
  for (int threads : {256, 1024}) {
    for (int per_sm : {1, 2, 3}) {
      const int blocks = sms * per_sm;
      if (threads * per_sm > 2048) continue;
      int resident = 0;
      CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&resident, cg_kernel, threads, 0));
      if (resident < per_sm) continue;
      const double cg_us = time_launch([&](int n) {
        void* args[] = {&n, &sink};
        CHECK(cudaLaunchCooperativeKernel((void*)cg_kernel, blocks, threads, args, 0, nullptr));
      });
      std::printf("%-11s %7d %8d %10.3f\n", "cg", blocks, threads, cg_us);
      const double counter_us = time_launch([&](int n) {
        void* args[] = {&n, &counter, &sink};
        CHECK(
            cudaLaunchCooperativeKernel((void*)counter_kernel, blocks, threads, args, 0, nullptr));
      });
      std::printf("%-11s %7d %8d %10.3f\n", "counter", blocks, threads, counter_us);
      const double neighbour_us = time_launch([&](int n) {
        void* args[] = {&n, &counter, &sink};
        CHECK(cudaLaunchCooperativeKernel((void*)neighbour_kernel, blocks, threads, args, 0,
                                          nullptr));
      });
      std::printf("%-11s %7d %8d %10.3f\n", "neighbours", blocks, threads, neighbour_us);
      for (int cluster : {2, 4, 8}) {
        const int cblocks = (blocks / cluster) * cluster;
        cudaLaunchConfig_t cfg{};
        cfg.gridDim = dim3(cblocks);
        cfg.blockDim = dim3(threads);
        cudaLaunchAttribute attr[2];
        attr[0].id = cudaLaunchAttributeClusterDimension;
        attr[0].val.clusterDim.x = cluster;
        attr[0].val.clusterDim.y = 1;
        attr[0].val.clusterDim.z = 1;
        attr[1].id = cudaLaunchAttributeCooperative;
        attr[1].val.cooperative = 1;
        cfg.attrs = attr;
        cfg.numAttrs = 2;
        int max_clusters = 0;
        if (cudaOccupancyMaxActiveClusters(&max_clusters, cluster_kernel, &cfg) != cudaSuccess ||
            max_clusters * cluster < cblocks) {
          cudaGetLastError();
          std::printf("%-11s %7d %8d %10s (cluster %d: %d clusters resident)\n", "cluster", cblocks,
                      threads, "-", cluster, max_clusters);
          continue;
        }
        const double cluster_us = time_launch(
            [&](int n) { CHECK(cudaLaunchKernelEx(&cfg, cluster_kernel, n, counter, sink)); });
        std::printf("%-11s %7d %8d %10.3f (cluster %d)\n", "cluster", cblocks, threads, cluster_us,
                    cluster);
      }
    }
  }
  return 0;
}
