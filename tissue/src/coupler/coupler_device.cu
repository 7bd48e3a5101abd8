// The coupler on the GPU: couple_vertex() in a thin kernel, one thread per vertex slot, blocks of
// kDirtyBlockSlots threads so each block votes whether its outputs changed (the host then copies
// only those blocks). Bindings, sources and rest normals are mirrored per slot and patched by a
// scatter kernel from the slots an edit re-bound. Every call is checked and synchronises its own
// stream before returning, so the solver's stream never sees a half-written buffer.
#include <cuda_runtime.h>

#include <algorithm>
#include <string>
#include <vector>

#include "coupler_device.h"
#include "tsf/common/cuda_check.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/error.h"
#include "tsf/coupler/coupler.h"

namespace tsf::coupler {
namespace {

static_assert(sizeof(Vec3f) == 12, "Vec3f arrays are copied as float triples");
static_assert(kDirtyBlockSlots == 256, "the kernels vote per block of 256 threads");

/// An owning device array (freed on destruction; never copied).
template <typename T>
class DeviceArray {
 public:
  DeviceArray() = default;
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  ~DeviceArray() { release(); }
  void allocate(std::size_t count) {
    if (count <= capacity_) return;
    release();
    TSF_CUDA_CHECK(cudaMalloc(reinterpret_cast<void**>(&data_), std::max<std::size_t>(count, 1) * sizeof(T)));
    capacity_ = count;
  }
  void release() {
    if (data_) cudaFree(data_);
    data_ = nullptr;
    capacity_ = 0;
  }
  T* get() const { return data_; }
  std::size_t capacity() const { return capacity_; }

 private:
  T* data_ = nullptr;
  std::size_t capacity_ = 0;
};

__global__ void couple_all_kernel(DeformedLatticeView lattice, const VertexBinding* bindings,
                                  const std::uint32_t* sources, const Vec3f* rest_normals,
                                  Vec3f* positions, Vec3f* normals, std::uint32_t slot_count,
                                  int mode, std::uint8_t* dirty) {
  const std::uint32_t s = blockIdx.x * blockDim.x + threadIdx.x;
  int changed = 0;
  if (s < slot_count) {
    const VertexBinding b = bindings[s];
    if (b.cell >= 0) {
      const CoupledVertex v = couple_vertex(LatticeReader{lattice}, lattice, b, sources[s],
                                            rest_normals[s], static_cast<CouplerMode>(mode));
      const Vec3f old_p = positions[s], old_n = normals[s];
      if (!(v.position == old_p) || !(v.normal == old_n)) {
        positions[s] = v.position;
        normals[s] = v.normal;
        changed = 1;
      }
    }
  }
  const int any = __syncthreads_or(changed);
  if (threadIdx.x == 0) dirty[blockIdx.x] = any ? 1 : 0;
}

__global__ void couple_slots_kernel(DeformedLatticeView lattice, const VertexBinding* bindings,
                                    const std::uint32_t* sources, const Vec3f* rest_normals,
                                    Vec3f* positions, Vec3f* normals, const std::uint32_t* slots,
                                    std::uint32_t count, std::uint32_t capacity, int mode,
                                    Vec3f* out_positions, Vec3f* out_normals) {
  const std::uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count) return;
  const std::uint32_t s = slots[t];
  if (s >= capacity) return;
  const VertexBinding b = bindings[s];
  if (b.cell < 0) {
    out_positions[t] = positions[s];
    out_normals[t] = normals[s];
    return;
  }
  const CoupledVertex v = couple_vertex(LatticeReader{lattice}, lattice, b, sources[s],
                                        rest_normals[s], static_cast<CouplerMode>(mode));
  positions[s] = v.position;
  normals[s] = v.normal;
  out_positions[t] = v.position;
  out_normals[t] = v.normal;
}

__global__ void scatter_bindings_kernel(const std::uint32_t* slots, std::uint32_t count,
                                        std::uint32_t capacity, const VertexBinding* bindings_in,
                                        const std::uint32_t* sources_in,
                                        const Vec3f* normals_in, VertexBinding* bindings,
                                        std::uint32_t* sources, Vec3f* rest_normals) {
  const std::uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count) return;
  const std::uint32_t s = slots[t];
  if (s >= capacity) return;
  bindings[s] = bindings_in[t];
  sources[s] = sources_in[t];
  rest_normals[s] = normals_in[t];
}

std::uint32_t blocks_for(std::size_t count, std::uint32_t threads) {
  return static_cast<std::uint32_t>((count + threads - 1) / threads);
}

class CudaCouplerDevice final : public CouplerDevice {
 public:
  CudaCouplerDevice() {
    require(cuda_status().available,
            "coupler: the CUDA path is not available: " + cuda_status().reason);
    TSF_CUDA_CHECK(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking));
  }
  ~CudaCouplerDevice() override {
    if (stream_) {
      cudaStreamSynchronize(stream_);
      cudaStreamDestroy(stream_);
    }
  }

  void reserve(std::uint32_t capacity) override {
    if (capacity <= capacity_ && bindings_.get()) return;
    bindings_.release();
    sources_.release();
    rest_normals_.release();
    positions_.release();
    normals_.release();
    bindings_.allocate(capacity);
    sources_.allocate(capacity);
    rest_normals_.allocate(capacity);
    positions_.allocate(capacity);
    normals_.allocate(capacity);
    dirty_.allocate(blocks_for(capacity, kDirtyBlockSlots));
    const std::size_t n = std::max<std::uint32_t>(capacity, 1);
    // All bytes 0xff: cell = −1 (unbound) until uploaded.
    TSF_CUDA_CHECK(cudaMemsetAsync(bindings_.get(), 0xff, n * sizeof(VertexBinding), stream_));
    TSF_CUDA_CHECK(cudaMemsetAsync(sources_.get(), 0, n * sizeof(std::uint32_t), stream_));
    TSF_CUDA_CHECK(cudaMemsetAsync(rest_normals_.get(), 0, n * sizeof(Vec3f), stream_));
    TSF_CUDA_CHECK(cudaMemsetAsync(positions_.get(), 0, n * sizeof(Vec3f), stream_));
    TSF_CUDA_CHECK(cudaMemsetAsync(normals_.get(), 0, n * sizeof(Vec3f), stream_));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
    capacity_ = capacity;
  }

  void upload(const std::uint32_t* slots, std::size_t count, const VertexBinding* bindings,
              const std::uint32_t* sources, const Vec3f* rest_normals) override {
    if (count == 0) return;
    // Pack the listed slots on the host, copy once, scatter on the device.
    packed_bindings_.resize(count);
    packed_sources_.resize(count);
    packed_normals_.resize(count);
    packed_slots_.assign(slots, slots + count);
    for (std::size_t i = 0; i < count; ++i) {
      require(slots[i] < capacity_, "coupler: upload of slot " + std::to_string(slots[i]) +
                                        " beyond the device capacity " +
                                        std::to_string(capacity_));
      packed_bindings_[i] = bindings[slots[i]];
      packed_sources_[i] = sources[slots[i]];
      packed_normals_[i] = rest_normals[slots[i]];
    }
    stage_slots_.allocate(count);
    stage_bindings_.allocate(count);
    stage_sources_.allocate(count);
    stage_normals_.allocate(count);
    TSF_CUDA_CHECK(cudaMemcpyAsync(stage_slots_.get(), packed_slots_.data(),
                                   count * sizeof(std::uint32_t), cudaMemcpyHostToDevice, stream_));
    TSF_CUDA_CHECK(cudaMemcpyAsync(stage_bindings_.get(), packed_bindings_.data(),
                                   count * sizeof(VertexBinding), cudaMemcpyHostToDevice, stream_));
    TSF_CUDA_CHECK(cudaMemcpyAsync(stage_sources_.get(), packed_sources_.data(),
                                   count * sizeof(std::uint32_t), cudaMemcpyHostToDevice, stream_));
    TSF_CUDA_CHECK(cudaMemcpyAsync(stage_normals_.get(), packed_normals_.data(),
                                   count * sizeof(Vec3f), cudaMemcpyHostToDevice, stream_));
    scatter_bindings_kernel<<<blocks_for(count, 256), 256, 0, stream_>>>(
        stage_slots_.get(), static_cast<std::uint32_t>(count), capacity_, stage_bindings_.get(),
        stage_sources_.get(), stage_normals_.get(), bindings_.get(), sources_.get(),
        rest_normals_.get());
    TSF_CUDA_CHECK_LAUNCH();
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
  }

  void couple_all(const DeformedLatticeView& lattice, std::uint32_t slot_count, CouplerMode mode,
                  std::vector<std::uint8_t>& dirty_blocks) override {
    require(slot_count <= capacity_, "coupler: more slots than the device holds");
    const std::uint32_t blocks = blocks_for(slot_count, kDirtyBlockSlots);
    dirty_blocks.assign(blocks, 0);
    if (blocks == 0) return;
    couple_all_kernel<<<blocks, kDirtyBlockSlots, 0, stream_>>>(
        lattice, bindings_.get(), sources_.get(), rest_normals_.get(), positions_.get(),
        normals_.get(), slot_count, static_cast<int>(mode), dirty_.get());
    TSF_CUDA_CHECK_LAUNCH();
    TSF_CUDA_CHECK(cudaMemcpyAsync(dirty_blocks.data(), dirty_.get(), blocks,
                                   cudaMemcpyDeviceToHost, stream_));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
  }

  void couple_slots(const DeformedLatticeView& lattice, const std::uint32_t* slots,
                    std::size_t count, CouplerMode mode, Vec3f* positions,
                    Vec3f* normals) override {
    if (count == 0) return;
    stage_slots_.allocate(count);
    out_positions_.allocate(count);
    out_normals_.allocate(count);
    TSF_CUDA_CHECK(cudaMemcpyAsync(stage_slots_.get(), slots, count * sizeof(std::uint32_t),
                                   cudaMemcpyHostToDevice, stream_));
    couple_slots_kernel<<<blocks_for(count, 256), 256, 0, stream_>>>(
        lattice, bindings_.get(), sources_.get(), rest_normals_.get(), positions_.get(),
        normals_.get(), stage_slots_.get(), static_cast<std::uint32_t>(count), capacity_,
        static_cast<int>(mode), out_positions_.get(), out_normals_.get());
    TSF_CUDA_CHECK_LAUNCH();
    packed_positions_.resize(count);
    packed_out_normals_.resize(count);
    TSF_CUDA_CHECK(cudaMemcpyAsync(packed_positions_.data(), out_positions_.get(),
                                   count * sizeof(Vec3f), cudaMemcpyDeviceToHost, stream_));
    TSF_CUDA_CHECK(cudaMemcpyAsync(packed_out_normals_.data(), out_normals_.get(),
                                   count * sizeof(Vec3f), cudaMemcpyDeviceToHost, stream_));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
    for (std::size_t i = 0; i < count; ++i) {
      if (slots[i] >= capacity_) continue;
      positions[slots[i]] = packed_positions_[i];
      normals[slots[i]] = packed_out_normals_[i];
    }
  }

  void download(std::uint32_t first, std::uint32_t count, Vec3f* positions,
                Vec3f* normals) override {
    if (count == 0) return;
    require(first + count <= capacity_, "coupler: download beyond the device capacity");
    TSF_CUDA_CHECK(cudaMemcpyAsync(positions + first, positions_.get() + first,
                                   count * sizeof(Vec3f), cudaMemcpyDeviceToHost, stream_));
    TSF_CUDA_CHECK(cudaMemcpyAsync(normals + first, normals_.get() + first, count * sizeof(Vec3f),
                                   cudaMemcpyDeviceToHost, stream_));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
  }

 private:
  cudaStream_t stream_ = nullptr;
  std::uint32_t capacity_ = 0;
  DeviceArray<VertexBinding> bindings_;
  DeviceArray<std::uint32_t> sources_;
  DeviceArray<Vec3f> rest_normals_, positions_, normals_;
  DeviceArray<std::uint8_t> dirty_;
  DeviceArray<std::uint32_t> stage_slots_;
  DeviceArray<VertexBinding> stage_bindings_;
  DeviceArray<std::uint32_t> stage_sources_;
  DeviceArray<Vec3f> stage_normals_, out_positions_, out_normals_;
  std::vector<std::uint32_t> packed_slots_, packed_sources_;
  std::vector<VertexBinding> packed_bindings_;
  std::vector<Vec3f> packed_normals_, packed_positions_, packed_out_normals_;
};

}  // namespace

std::unique_ptr<CouplerDevice> make_coupler_device() {
  return std::make_unique<CudaCouplerDevice>();
}

}  // namespace tsf::coupler
