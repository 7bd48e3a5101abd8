// CUDA effect passes: one thread per node around the per-node functions of effect_physics.h, on
// the CUDA backend's stream so that they interleave with its steps without host waits, in the
// order of effects_engine.h.
#include <cuda_runtime.h>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "effects_engine.h"
#include "tsf/common/cuda_check.h"
#include "tsf/common/device_buffer.h"

namespace tsf::crms {
namespace {

constexpr int kBlock = 256;

__device__ inline bool node_of_thread(const LatticeView& lat, std::int64_t& n, int& i, int& j,
                                      int& k) {
  n = static_cast<std::int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (n >= lat.count) return false;
  const Int3 c = node_coords(lat, n);
  i = c.x, j = c.y, k = c.z;
  return true;
}

__global__ void cube_pressure_kernel(LatticeView lat, ConstStateView s, EffectArrays a,
                                     EffectParameters p) {
  std::int64_t n;
  int i, j, k;
  if (!node_of_thread(lat, n, i, j, k)) return;
  a.fluid_pressure[n] = cube_pressure(lat, s, a, p, n, i, j, k);
}

__global__ void effect_force_kernel(LatticeView lat, ConstStateView s, EffectArrays a,
                                    EffectParameters p) {
  std::int64_t n;
  int i, j, k;
  if (!node_of_thread(lat, n, i, j, k)) return;
  const Vec3f f = effect_force(lat, s, a, p, n, i, j, k);
  a.force[0][n] = f.x;
  a.force[1][n] = f.y;
  a.force[2][n] = f.z;
}

__global__ void volume_terms_kernel(LatticeView lat, ConstStateView s, EffectArrays a,
                                    EffectParameters p) {
  std::int64_t n;
  int i, j, k;
  if (!node_of_thread(lat, n, i, j, k)) return;
  cube_volume_terms(lat, s, p.volume, n, i, j, k, a.volume_terms);
}

/// Σ over the cubes of cube_volume_energy, one block's share added to *sum (double).
__global__ void volume_energy_kernel(LatticeView lat, ConstStateView s, EffectParameters p,
                                     double* sum) {
  __shared__ double partial[kBlock];
  std::int64_t n;
  int i, j, k;
  double e = 0.0;
  if (node_of_thread(lat, n, i, j, k)) e = cube_volume_energy(lat, s, p.volume, n, i, j, k);
  partial[threadIdx.x] = e;
  __syncthreads();
  for (int stride = kBlock / 2; stride > 0; stride >>= 1) {
    if (static_cast<int>(threadIdx.x) < stride)
      partial[threadIdx.x] += partial[threadIdx.x + stride];
    __syncthreads();
  }
  if (threadIdx.x == 0) atomicAdd(sum, partial[0]);
}

__global__ void kick_kernel(LatticeView lat, StateView s, EffectArrays a, EffectParameters p) {
  std::int64_t n;
  int i, j, k;
  if (!node_of_thread(lat, n, i, j, k)) return;
  kick_node(lat, s, a, p, n, i, j, k);
}

__global__ void update_kernel(LatticeView lat, ConstStateView s, EffectArrays a,
                              EffectParameters p) {
  std::int64_t n;
  int i, j, k;
  if (!node_of_thread(lat, n, i, j, k)) return;
  if (p.enabled & effect_bits::kPlasticity) update_plastic_offsets(lat, s, a, p, n, i, j, k);
  if (p.enabled & effect_bits::kFluid) update_fluid_content(lat, a, p, n, i, j, k);
}

__global__ void node_mask_kernel(LatticeView lat, ConstStateView s, EffectArrays a,
                                 EffectParameters p) {
  std::int64_t n;
  int i, j, k;
  if (!node_of_thread(lat, n, i, j, k)) return;
  a.node_mask[n] = node_overloaded(lat, s, p, n, i, j, k);
}

__global__ void unmask_kernel(LatticeView lat, EffectArrays a, std::uint8_t* flags) {
  std::int64_t n;
  int i, j, k;
  if (!node_of_thread(lat, n, i, j, k)) return;
  const std::uint8_t f = unmasked_flags(lat, a, n);
  if (f != flags[n]) flags[n] = f;
}

__global__ void tear_kernel(LatticeView lat, ConstStateView s, EffectParameters p,
                            std::uint8_t* flags) {
  std::int64_t n;
  int i, j, k;
  if (!node_of_thread(lat, n, i, j, k)) return;
  const std::uint8_t f = torn_flags(lat, s, p, n, i, j, k);
  if (f != flags[n]) flags[n] = f;
}

class CudaEffects final : public EffectsEngine {
 public:
  CudaEffects(const LatticeGeometry& g, unsigned enabled, const std::vector<RestOffsets>& keyframes,
              void* stream)
      : EffectsEngine(enabled, keyframes.size()),
        count_(static_cast<std::size_t>(g.node_count())),
        stream_(static_cast<cudaStream_t>(stream)) {
    // Every array is a DeviceBuffer (device_buffer.h): a throw below frees what was allocated.
    if (enabled & effect_bits::kPlasticity)
      for (auto& c : plastic_) allocate_zeroed(c);
    if (enabled & effect_bits::kFluid) {
      allocate_zeroed(content_);
      allocate_zeroed(pressure_);
    }
    if (enabled & effect_bits::kForceEffects)
      for (auto& c : force_) allocate_zeroed(c);
    if (enabled & effect_bits::kRestAnimation) {
      keyframes_.resize(keyframes.size());
      for (std::size_t key = 0; key < keyframes.size(); ++key)
        for (int c = 0; c < 3; ++c) {
          keyframes_[key][c].resize(count_);
          keyframes_[key][c].upload(keyframes[key][c].data(), count_, stream_);
        }
    }
    if (enabled & effect_bits::kNodeMasking) {
      mask_.resize(count_);
      mask_.fill_zero(stream_);
    }
    if (enabled & effect_bits::kVolumetric) {
      for (auto& c : volume_terms_) allocate_zeroed(c);
      energy_sum_.resize(1);
      energy_host_.resize(1);
    }
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));  // the host keyframes may go out of scope
  }
  ~CudaEffects() override {
    cudaStreamSynchronize(stream_);  // queued passes may still use the arrays freed next
  }

  EffectsState read() const override {
    EffectsState r;
    if (!plastic_[0].empty()) {
      std::array<std::vector<float>, 3> c;
      for (int a = 0; a < 3; ++a) c[a] = copy(plastic_[a]);
      r.plastic_offset.resize(count_);
      for (std::size_t n = 0; n < count_; ++n) r.plastic_offset[n] = {c[0][n], c[1][n], c[2][n]};
    }
    if (!content_.empty()) {
      r.fluid_content = copy(content_);
      r.fluid_pressure = copy(pressure_);
    }
    return r;
  }

  std::optional<double> volume_energy_here(const LatticeView& lat, const ConstStateView& s,
                                           const EffectParameters& p) const override {
    queue_volume_energy(lat, s, p);
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
    return queued_volume_energy();
  }

  bool queue_volume_energy(const LatticeView& lat, const ConstStateView& s,
                           const EffectParameters& p) const override {
    if ((enabled() & effect_bits::kVolumetric) == 0) {
      *energy_host_.data() = 0.0;
      return true;
    }
    TSF_CUDA_CHECK(cudaMemsetAsync(energy_sum_.data(), 0, sizeof(double), stream_));
    volume_energy_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, p, energy_sum_.data());
    TSF_CUDA_CHECK_LAUNCH();
    TSF_CUDA_CHECK(cudaMemcpyAsync(energy_host_.data(), energy_sum_.data(), sizeof(double),
                                   cudaMemcpyDeviceToHost, stream_));
    return true;
  }
  double queued_volume_energy() const override { return *energy_host_.data(); }

  float* const* volume_term_arrays() override {
    if (volume_terms_[0].empty()) return nullptr;
    for (int c = 0; c < 9; ++c) volume_pointers_[c] = volume_terms_[c].data();
    return volume_pointers_.data();
  }

  std::vector<std::uint8_t> read_flags(const LatticeView& lat) const override {
    std::vector<std::uint8_t> flags(count_);
    TSF_CUDA_CHECK(
        cudaMemcpyAsync(flags.data(), lat.flags, count_, cudaMemcpyDeviceToHost, stream_));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
    return flags;
  }

 protected:
  void run_pass(EffectPass pass, const LatticeView& lat, const StateView& state,
                const EffectParameters& p) override {
    const ConstStateView s = state;
    const EffectArrays a = arrays(p);
    auto* flags = const_cast<std::uint8_t*>(lat.flags);  // the backend's own flags array
    switch (pass) {
      case EffectPass::kCubePressure:
        cube_pressure_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, a, p);
        break;
      case EffectPass::kVolumeTerms:
        volume_terms_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, a, p);
        break;
      case EffectPass::kEffectForce:
        effect_force_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, a, p);
        break;
      case EffectPass::kKick:
        kick_kernel<<<grid(), kBlock, 0, stream_>>>(lat, state, a, p);
        break;
      case EffectPass::kUpdateStores:
        update_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, a, p);
        break;
      case EffectPass::kTear:
        tear_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, p, flags);
        break;
      case EffectPass::kMarkOverloaded:
        node_mask_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, a, p);
        break;
      case EffectPass::kUnlinkMasked:
        unmask_kernel<<<grid(), kBlock, 0, stream_>>>(lat, a, flags);
        break;
    }
    TSF_CUDA_CHECK_LAUNCH();
  }

 private:
  /// The arrays, with the animation's keyframes around the current time.
  EffectArrays arrays(const EffectParameters& p) const {
    EffectArrays a;
    for (int c = 0; c < 3; ++c) {
      a.plastic_offset[c] = plastic_[c].data();
      a.force[c] = force_[c].data();
    }
    a.fluid_content = content_.data();
    a.fluid_pressure = pressure_.data();
    a.node_mask = mask_.data();
    for (int c = 0; c < 9; ++c) a.volume_terms[c] = volume_terms_[c].data();
    if (!keyframes_.empty())
      for (int c = 0; c < 3; ++c) {
        a.rest_from[c] = keyframes_[static_cast<std::size_t>(p.rest_from_key)][c].data();
        a.rest_to[c] = keyframes_[static_cast<std::size_t>(p.rest_to_key)][c].data();
      }
    return a;
  }
  unsigned grid() const { return static_cast<unsigned>((count_ + kBlock - 1) / kBlock); }
  void allocate_zeroed(DeviceBuffer<float>& buffer) {
    buffer.resize(count_);
    buffer.fill_zero(stream_);
  }
  std::vector<float> copy(const DeviceBuffer<float>& device) const {
    std::vector<float> host(count_);
    device.download(host.data(), count_, stream_);
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
    return host;
  }

  std::size_t count_;
  cudaStream_t stream_;  // the backend's (not owned)
  std::array<DeviceBuffer<float>, 3> plastic_, force_;
  DeviceBuffer<float> content_, pressure_;
  std::vector<std::array<DeviceBuffer<float>, 3>> keyframes_;  // device rest offsets
  DeviceBuffer<std::uint8_t> mask_;
  std::array<DeviceBuffer<float>, 9> volume_terms_;
  std::array<float*, 9> volume_pointers_{};
  mutable DeviceBuffer<double> energy_sum_;  // volume_energy_here's reduction
  mutable PinnedBuffer<double> energy_host_;
};

}  // namespace

std::unique_ptr<EffectsEngine> make_cuda_effects(const LatticeGeometry& geometry, unsigned enabled,
                                                 const std::vector<RestOffsets>& keyframes,
                                                 void* stream) {
  return std::make_unique<CudaEffects>(geometry, enabled, keyframes, stream);
}

}  // namespace tsf::crms
