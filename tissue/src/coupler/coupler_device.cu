// The coupler on the GPU, two thin kernels over the functions of couple_vertex.h: one thread per
// frame resolves its corners (resolve_frame), then one thread per vertex slot interpolates
// (couple_from_frame), in blocks of kDirtyBlockSlots threads that vote whether their outputs
// changed (the host then copies only those blocks). Frames, vertex bindings and rest normals are
// mirrored and patched by scatter kernels from what an edit changed. Every call is checked and
// synchronises its own stream before returning, so the solver's stream never sees a half-written
// buffer.
#include <cuda_runtime.h>

#include <algorithm>
#include <string>
#include <vector>

#include "coupler_device.h"
#include "tsf/common/cuda_check.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/device_buffer.h"
#include "tsf/common/error.h"
#include "tsf/coupler/coupler.h"

namespace tsf::coupler {
namespace {

static_assert(sizeof(Vec3f) == 12, "Vec3f arrays are copied as float triples");
static_assert(kDirtyBlockSlots == 256, "the kernels vote per block of 256 threads");

__global__ void resolve_frames_kernel(DeformedLatticeView lattice, const CubeFrame* frames,
                                      std::uint32_t frame_count, int mode, FrameCorners* corners) {
  const std::uint32_t f = blockIdx.x * blockDim.x + threadIdx.x;
  if (f >= frame_count) return;
  const CubeFrame frame = frames[f];
  if (frame.cell < 0) return;  // a free frame slot
  corners[f] =
      resolve_frame(LatticeReader{lattice}, lattice, frame, static_cast<CouplerMode>(mode));
}

__global__ void resolve_listed_frames_kernel(DeformedLatticeView lattice, const CubeFrame* frames,
                                             const std::uint32_t* list, std::uint32_t count,
                                             std::uint32_t frame_capacity, int mode,
                                             FrameCorners* corners) {
  const std::uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count) return;
  const std::uint32_t f = list[t];
  if (f >= frame_capacity) return;
  const CubeFrame frame = frames[f];
  if (frame.cell < 0) return;
  corners[f] =
      resolve_frame(LatticeReader{lattice}, lattice, frame, static_cast<CouplerMode>(mode));
}

__global__ void couple_all_kernel(DeformedLatticeView lattice, const VertexFrameBinding* bindings,
                                  const FrameCorners* corners, std::uint32_t frame_capacity,
                                  const Vec3f* rest_normals, Vec3f* positions, Vec3f* normals,
                                  std::uint32_t slot_count, int mode, std::uint8_t* dirty) {
  const std::uint32_t s = blockIdx.x * blockDim.x + threadIdx.x;
  int changed = 0;
  if (s < slot_count) {
    const VertexFrameBinding b = bindings[s];
    if (b.frame < frame_capacity) {
      const CoupledVertex v = couple_from_frame(corners[b.frame], b.w, lattice.spacing,
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

__global__ void couple_slots_kernel(DeformedLatticeView lattice, const VertexFrameBinding* bindings,
                                    const FrameCorners* corners, std::uint32_t frame_capacity,
                                    const Vec3f* rest_normals, Vec3f* positions, Vec3f* normals,
                                    const std::uint32_t* slots, std::uint32_t count,
                                    std::uint32_t capacity, int mode, Vec3f* out_positions,
                                    Vec3f* out_normals) {
  const std::uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count) return;
  const std::uint32_t s = slots[t];
  if (s >= capacity) return;
  const VertexFrameBinding b = bindings[s];
  if (b.frame < frame_capacity) {
    const CoupledVertex v = couple_from_frame(corners[b.frame], b.w, lattice.spacing,
                                              rest_normals[s], static_cast<CouplerMode>(mode));
    positions[s] = v.position;
    normals[s] = v.normal;
  }
  out_positions[t] = positions[s];
  out_normals[t] = normals[s];
}

template <typename T>
__global__ void scatter_kernel(const std::uint32_t* index, std::uint32_t count,
                               std::uint32_t capacity, const T* values, T* target) {
  const std::uint32_t t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count) return;
  const std::uint32_t i = index[t];
  if (i < capacity) target[i] = values[t];
}

std::uint32_t blocks_for(std::size_t count, std::uint32_t threads) {
  return static_cast<std::uint32_t>((count + threads - 1) / threads);
}

class CudaCouplerDevice final : public CouplerDevice {
 public:
  CudaCouplerDevice() {
    require(cuda_status().available,
            "coupler: the CUDA path is not available: " + cuda_status().reason);
    stream_ = make_stream();
  }

  void reserve(std::uint32_t slots, std::uint32_t frames) override {
    release_all();
    bindings_.resize(slots);
    rest_normals_.resize(slots);
    positions_.resize(slots);
    normals_.resize(slots);
    dirty_.resize(blocks_for(slots, kDirtyBlockSlots));
    frames_.resize(frames);
    corners_.resize(frames);
    const std::size_t n = std::max<std::uint32_t>(slots, 1);
    const std::size_t m = std::max<std::uint32_t>(frames, 1);
    // All bytes 0xff: frame = kNoFrame (unbound vertices), cell = −1 (free frames).
    TSF_CUDA_CHECK(
        cudaMemsetAsync(bindings_.data(), 0xff, n * sizeof(VertexFrameBinding), stream_.get()));
    TSF_CUDA_CHECK(cudaMemsetAsync(frames_.data(), 0xff, m * sizeof(CubeFrame), stream_.get()));
    TSF_CUDA_CHECK(cudaMemsetAsync(corners_.data(), 0, m * sizeof(FrameCorners), stream_.get()));
    TSF_CUDA_CHECK(cudaMemsetAsync(rest_normals_.data(), 0, n * sizeof(Vec3f), stream_.get()));
    TSF_CUDA_CHECK(cudaMemsetAsync(positions_.data(), 0, n * sizeof(Vec3f), stream_.get()));
    TSF_CUDA_CHECK(cudaMemsetAsync(normals_.data(), 0, n * sizeof(Vec3f), stream_.get()));
    wait();
    capacity_ = slots;
    frame_capacity_ = frames;
    // The edit staging, sized here for an eighth of the slots and frames (a cut through the
    // sinus scene re-binds ~5 % of its slots; the full uploads after a reserve grow the upload
    // staging to every slot anyway): an edit that fits allocates nothing. An allocation of
    // page-locked memory (and the free before it, which waits for the device) costs more than
    // the copies it serves.
    const std::size_t v = std::max<std::size_t>(16384, slots / 8);
    const std::size_t f = std::max<std::size_t>(4096, frames / 8);
    vertex_index_.grow_to(v);
    frame_index_.grow_to(f);
    stage_bindings_.grow_to(v);
    stage_normals_.grow_to(v);
    stage_frames_.grow_to(f);
    lists_.grow_to(v + f);
    out_.grow_to(2 * v);
    vertex_index_host_.grow_to(v);
    frame_index_host_.grow_to(f);
    lists_host_.grow_to(v + f);
    bindings_host_.grow_to(v);
    frames_host_.grow_to(f);
    normals_host_.grow_to(v);
    out_host_.grow_to(2 * v);
  }

  // The edit path (upload_frames, upload_vertices, couple_slots, as Coupler::sync_device and
  // couple_slots call them) packs into page-locked staging and queues its copies and kernels on
  // the one stream without waiting: the stream orders them, and couple_slots waits once at its
  // end. Staging grows by doubling (grow_to), so an edit larger than the last allocates a few
  // times in a run, not every call (cudaFree waits for the whole device). A packing call waits
  // first only when its own staging may still be in flight (no wait since it was last queued).
  void upload_vertices(const std::uint32_t* slots, std::size_t count,
                       const VertexFrameBinding* bindings, const Vec3f* rest_normals) override {
    if (count == 0) return;
    settle(vertices_queued_);
    vertex_index_host_.grow_to(count);
    bindings_host_.grow_to(count);
    normals_host_.grow_to(count);
    for (std::size_t i = 0; i < count; ++i) {
      if (slots[i] >= capacity_)
        throw Error("coupler: upload of slot " + std::to_string(slots[i]) +
                    " beyond the device capacity " + std::to_string(capacity_));
      vertex_index_host_.data()[i] = slots[i];
      bindings_host_.data()[i] = bindings[slots[i]];
      normals_host_.data()[i] = rest_normals[slots[i]];
    }
    vertex_index_.grow_to(count);
    stage_bindings_.grow_to(count);
    stage_normals_.grow_to(count);
    vertex_index_.upload(vertex_index_host_.data(), count, stream_.get());
    stage_bindings_.upload(bindings_host_.data(), count, stream_.get());
    stage_normals_.upload(normals_host_.data(), count, stream_.get());
    const auto n = static_cast<std::uint32_t>(count);
    scatter_kernel<VertexFrameBinding><<<blocks_for(count, 256), 256, 0, stream_.get()>>>(
        vertex_index_.data(), n, capacity_, stage_bindings_.data(), bindings_.data());
    TSF_CUDA_CHECK_LAUNCH();
    scatter_kernel<Vec3f><<<blocks_for(count, 256), 256, 0, stream_.get()>>>(
        vertex_index_.data(), n, capacity_, stage_normals_.data(), rest_normals_.data());
    TSF_CUDA_CHECK_LAUNCH();
    vertices_queued_ = true;
  }

  void upload_frames(const std::uint32_t* frames, std::size_t count,
                     const CubeFrame* table) override {
    if (count == 0) return;
    settle(frames_queued_);
    frame_index_host_.grow_to(count);
    frames_host_.grow_to(count);
    for (std::size_t i = 0; i < count; ++i) {
      if (frames[i] >= frame_capacity_)
        throw Error("coupler: upload of frame " + std::to_string(frames[i]) +
                    " beyond the device capacity " + std::to_string(frame_capacity_));
      frame_index_host_.data()[i] = frames[i];
      frames_host_.data()[i] = table[frames[i]];
    }
    frame_index_.grow_to(count);
    stage_frames_.grow_to(count);
    frame_index_.upload(frame_index_host_.data(), count, stream_.get());
    stage_frames_.upload(frames_host_.data(), count, stream_.get());
    scatter_kernel<CubeFrame><<<blocks_for(count, 256), 256, 0, stream_.get()>>>(
        frame_index_.data(), static_cast<std::uint32_t>(count), frame_capacity_,
        stage_frames_.data(), frames_.data());
    TSF_CUDA_CHECK_LAUNCH();
    frames_queued_ = true;
  }

  void couple_all(const DeformedLatticeView& lattice, std::uint32_t frame_count,
                  std::uint32_t slot_count, CouplerMode mode,
                  std::vector<std::uint8_t>& dirty_blocks) override {
    require(slot_count <= capacity_ && frame_count <= frame_capacity_,
            "coupler: more slots or frames than the device holds");
    const std::uint32_t blocks = blocks_for(slot_count, kDirtyBlockSlots);
    dirty_blocks.assign(blocks, 0);
    if (frame_count > 0) {
      resolve_frames_kernel<<<blocks_for(frame_count, 128), 128, 0, stream_.get()>>>(
          lattice, frames_.data(), frame_count, static_cast<int>(mode), corners_.data());
      TSF_CUDA_CHECK_LAUNCH();
    }
    if (blocks == 0) {
      wait();
      return;
    }
    couple_all_kernel<<<blocks, kDirtyBlockSlots, 0, stream_.get()>>>(
        lattice, bindings_.data(), corners_.data(), frame_capacity_, rest_normals_.data(),
        positions_.data(), normals_.data(), slot_count, static_cast<int>(mode), dirty_.data());
    TSF_CUDA_CHECK_LAUNCH();
    TSF_CUDA_CHECK(cudaMemcpyAsync(dirty_blocks.data(), dirty_.data(), blocks,
                                   cudaMemcpyDeviceToHost, stream_.get()));
    wait();
  }

  void couple_slots(const DeformedLatticeView& lattice, const std::uint32_t* frames,
                    std::size_t frame_count, const std::uint32_t* slots, std::size_t count,
                    CouplerMode mode, Vec3f* positions, Vec3f* normals) override {
    if (count == 0) return;
    // One upload of the frame list and the slot list, one kernel each, one download of the
    // positions and normals (count of each), one wait (so its staging is free when it returns).
    const std::size_t listed = frame_count + count;
    lists_host_.grow_to(listed);
    std::copy(frames, frames + frame_count, lists_host_.data());
    std::copy(slots, slots + count, lists_host_.data() + frame_count);
    lists_.grow_to(listed);
    lists_.upload(lists_host_.data(), listed, stream_.get());
    if (frame_count > 0) {
      resolve_listed_frames_kernel<<<blocks_for(frame_count, 128), 128, 0, stream_.get()>>>(
          lattice, frames_.data(), lists_.data(), static_cast<std::uint32_t>(frame_count),
          frame_capacity_, static_cast<int>(mode), corners_.data());
      TSF_CUDA_CHECK_LAUNCH();
    }
    out_.grow_to(2 * count);
    couple_slots_kernel<<<blocks_for(count, 256), 256, 0, stream_.get()>>>(
        lattice, bindings_.data(), corners_.data(), frame_capacity_, rest_normals_.data(),
        positions_.data(), normals_.data(), lists_.data() + frame_count,
        static_cast<std::uint32_t>(count), capacity_, static_cast<int>(mode), out_.data(),
        out_.data() + count);
    TSF_CUDA_CHECK_LAUNCH();
    out_host_.grow_to(2 * count);
    out_.download(out_host_.data(), 2 * count, stream_.get());
    wait();
    const Vec3f* p = out_host_.data();
    const Vec3f* nrm = out_host_.data() + count;
    for (std::size_t i = 0; i < count; ++i) {
      if (slots[i] >= capacity_) continue;
      positions[slots[i]] = p[i];
      normals[slots[i]] = nrm[i];
    }
  }

  void download_ranges(const std::vector<std::pair<std::uint32_t, std::uint32_t>>& ranges,
                       Vec3f* positions, Vec3f* normals) override {
    if (ranges.empty()) return;
    for (const auto& [first, last] : ranges) {
      require(first <= last && last <= capacity_, "coupler: download beyond the device capacity");
      const std::size_t bytes = (last - first) * sizeof(Vec3f);
      TSF_CUDA_CHECK(cudaMemcpyAsync(positions + first, positions_.data() + first, bytes,
                                     cudaMemcpyDeviceToHost, stream_.get()));
      TSF_CUDA_CHECK(cudaMemcpyAsync(normals + first, normals_.data() + first, bytes,
                                     cudaMemcpyDeviceToHost, stream_.get()));
    }
    wait();
  }

  void register_host(Vec3f* positions, Vec3f* normals, std::size_t count) override {
    release_host();
    if (count == 0) return;
    for (Vec3f* p : {positions, normals}) {
      // Registration rounds to whole pages: an array sharing a page with one registered already
      // is refused (cudaErrorHostMemoryAlreadyRegistered) and stays pageable.
      const cudaError_t e = cudaHostRegister(p, count * sizeof(Vec3f), cudaHostRegisterDefault);
      if (e == cudaSuccess)
        registered_.push_back(p);
      else
        (void)cudaGetLastError();  // clear it: the copies still work, only slower
    }
  }

  void release_host() override {
    wait();
    for (Vec3f* p : registered_) TSF_CUDA_CHECK(cudaHostUnregister(p));
    registered_.clear();
  }

  ~CudaCouplerDevice() override {
    // Unregister before the owner frees the arrays (errors ignored: a destructor must not throw).
    if (stream_) cudaStreamSynchronize(stream_.get());
    for (Vec3f* p : registered_) cudaHostUnregister(p);
  }
  CudaCouplerDevice(const CudaCouplerDevice&) = delete;
  CudaCouplerDevice& operator=(const CudaCouplerDevice&) = delete;

 private:
  /// Waits for the stream; no staging is in flight afterwards.
  void wait() {
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    vertices_queued_ = frames_queued_ = false;
  }
  /// Waits only when `queued` says this staging's last copies may not have run yet.
  void settle(bool queued) {
    if (queued) wait();
  }

  void release_all() {
    bindings_.release();
    rest_normals_.release();
    positions_.release();
    normals_.release();
    dirty_.release();
    frames_.release();
    corners_.release();
    capacity_ = frame_capacity_ = 0;
  }

  std::uint32_t capacity_ = 0, frame_capacity_ = 0;
  DeviceBuffer<VertexFrameBinding> bindings_;
  DeviceBuffer<Vec3f> rest_normals_, positions_, normals_;
  DeviceBuffer<std::uint8_t> dirty_;
  DeviceBuffer<CubeFrame> frames_;
  DeviceBuffer<FrameCorners> corners_;
  // Edit staging: device side and its page-locked host side, per call that queues copies.
  DeviceBuffer<std::uint32_t> vertex_index_, frame_index_, lists_;
  DeviceBuffer<VertexFrameBinding> stage_bindings_;
  DeviceBuffer<CubeFrame> stage_frames_;
  DeviceBuffer<Vec3f> stage_normals_, out_;
  PinnedBuffer<std::uint32_t> vertex_index_host_, frame_index_host_, lists_host_;
  PinnedBuffer<VertexFrameBinding> bindings_host_;
  PinnedBuffer<CubeFrame> frames_host_;
  PinnedBuffer<Vec3f> normals_host_, out_host_;
  bool vertices_queued_ = false, frames_queued_ = false;
  std::vector<Vec3f*> registered_;  // host arrays page-locked by register_host
  UniqueStream stream_;
};

}  // namespace

std::unique_ptr<CouplerDevice> make_coupler_device() {
  return std::make_unique<CudaCouplerDevice>();
}

}  // namespace tsf::coupler
