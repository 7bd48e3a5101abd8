// CUDA effect passes: one thread per node around the per-node functions of effect_physics.h, on
// the CUDA backend's stream so that they interleave with its steps without host waits.
#include <cuda_runtime.h>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "effects_engine.h"
#include "tsf/common/cuda_check.h"

namespace tsf::crms {
namespace {

constexpr int kBlock = 256;

__device__ inline bool node_of_thread(const LatticeView& lat, std::int64_t& n, int& i, int& j,
                                      int& k) {
  n = static_cast<std::int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (n >= lat.count) return false;
  i = static_cast<int>(n % lat.dims.x);
  const std::int64_t row = n / lat.dims.x;
  j = static_cast<int>(row % lat.dims.y);
  k = static_cast<int>(row / lat.dims.y);
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

__global__ void kick_kernel(LatticeView lat, StateView s, EffectArrays a, EffectParameters p) {
  std::int64_t n;
  int i, j, k;
  if (!node_of_thread(lat, n, i, j, k)) return;
  const Vec3f v = kicked_velocity(lat, ConstStateView(s), a, p, n);
  s.v[0][n] = v.x;
  s.v[1][n] = v.y;
  s.v[2][n] = v.z;
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
      : count_(static_cast<std::size_t>(g.node_count())),
        enabled_(enabled),
        stream_(static_cast<cudaStream_t>(stream)) {
    if (enabled & effect_bits::kPlasticity)
      for (auto& c : arrays_.plastic_offset) c = allocate();
    if (enabled & effect_bits::kFluid) {
      arrays_.fluid_content = allocate();
      arrays_.fluid_pressure = allocate();
    }
    if (enabled & effect_bits::kForceEffects)
      for (auto& c : arrays_.force) c = allocate();
    if (enabled & effect_bits::kRestAnimation)
      for (const RestOffsets& key : keyframes) {
        std::array<float*, 3> device{};
        for (int c = 0; c < 3; ++c) {
          device[c] = allocate();
          TSF_CUDA_CHECK(cudaMemcpyAsync(device[c], key[c].data(), count_ * sizeof(float),
                                         cudaMemcpyHostToDevice, stream_));
        }
        keyframes_.push_back(device);
      }
    if (enabled & effect_bits::kNodeMasking) {
      TSF_CUDA_CHECK(cudaMalloc(&arrays_.node_mask, count_));
      TSF_CUDA_CHECK(cudaMemsetAsync(arrays_.node_mask, 0, count_, stream_));
    }
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
  }
  ~CudaEffects() override {
    cudaStreamSynchronize(stream_);
    for (float* p : owned_) cudaFree(p);
    cudaFree(arrays_.node_mask);
  }
  CudaEffects(const CudaEffects&) = delete;
  CudaEffects& operator=(const CudaEffects&) = delete;

  void before_step(const LatticeView& lat, const StateView& state,
                   const EffectParameters& p) override {
    if ((enabled_ & effect_bits::kForceEffects) == 0) return;
    const ConstStateView s = state;
    const EffectArrays a = arrays(p);
    if (enabled_ & effect_bits::kFluid) {
      cube_pressure_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, a, p);
      TSF_CUDA_CHECK_LAUNCH();
    }
    effect_force_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, a, p);
    TSF_CUDA_CHECK_LAUNCH();
    kick_kernel<<<grid(), kBlock, 0, stream_>>>(lat, state, a, p);
    TSF_CUDA_CHECK_LAUNCH();
  }

  void after_step(const LatticeView& lat, const StateView& state,
                  const EffectParameters& p) override {
    const ConstStateView s = state;
    const EffectArrays a = arrays(p);
    auto* flags = const_cast<std::uint8_t*>(lat.flags);  // the backend's own flags array
    if (enabled_ & (effect_bits::kPlasticity | effect_bits::kFluid)) {
      update_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, a, p);
      TSF_CUDA_CHECK_LAUNCH();
    }
    if (enabled_ & effect_bits::kTearing) {
      tear_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, p, flags);
      TSF_CUDA_CHECK_LAUNCH();
    }
    if (enabled_ & effect_bits::kNodeMasking) {
      node_mask_kernel<<<grid(), kBlock, 0, stream_>>>(lat, s, a, p);
      TSF_CUDA_CHECK_LAUNCH();
      unmask_kernel<<<grid(), kBlock, 0, stream_>>>(lat, a, flags);
      TSF_CUDA_CHECK_LAUNCH();
    }
  }

  EffectsState read() const override {
    EffectsState r;
    if (arrays_.plastic_offset[0]) {
      std::array<std::vector<float>, 3> c;
      for (int a = 0; a < 3; ++a) c[a] = copy(arrays_.plastic_offset[a]);
      r.plastic_offset.resize(count_);
      for (std::size_t n = 0; n < count_; ++n) r.plastic_offset[n] = {c[0][n], c[1][n], c[2][n]};
    }
    if (arrays_.fluid_content) {
      r.fluid_content = copy(arrays_.fluid_content);
      r.fluid_pressure = copy(arrays_.fluid_pressure);
    }
    return r;
  }

  std::vector<std::uint8_t> read_flags(const LatticeView& lat) const override {
    std::vector<std::uint8_t> flags(count_);
    TSF_CUDA_CHECK(
        cudaMemcpyAsync(flags.data(), lat.flags, count_, cudaMemcpyDeviceToHost, stream_));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
    return flags;
  }

  double bytes_per_node() const override {
    double b = 0;
    if (enabled_ & effect_bits::kPlasticity) b += 3 * sizeof(float);
    if (enabled_ & effect_bits::kFluid) b += 2 * sizeof(float);
    if (enabled_ & effect_bits::kForceEffects) b += 3 * sizeof(float);
    if (enabled_ & effect_bits::kRestAnimation)
      b += 3 * sizeof(float) * static_cast<double>(keyframes_.size());
    if (enabled_ & effect_bits::kNodeMasking) b += 1;
    return b;
  }

 private:
  /// The arrays with the animation's keyframes around the current time.
  EffectArrays arrays(const EffectParameters& p) const {
    EffectArrays a = arrays_;
    if (!keyframes_.empty())
      for (int c = 0; c < 3; ++c) {
        a.rest_from[c] = keyframes_[static_cast<std::size_t>(p.rest_from_key)][c];
        a.rest_to[c] = keyframes_[static_cast<std::size_t>(p.rest_to_key)][c];
      }
    return a;
  }
  unsigned grid() const { return static_cast<unsigned>((count_ + kBlock - 1) / kBlock); }
  float* allocate() {
    float* p = nullptr;
    TSF_CUDA_CHECK(cudaMalloc(&p, count_ * sizeof(float)));
    owned_.push_back(p);
    TSF_CUDA_CHECK(cudaMemsetAsync(p, 0, count_ * sizeof(float), stream_));
    return p;
  }
  std::vector<float> copy(const float* device) const {
    std::vector<float> host(count_);
    TSF_CUDA_CHECK(cudaMemcpyAsync(host.data(), device, count_ * sizeof(float),
                                   cudaMemcpyDeviceToHost, stream_));
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_));
    return host;
  }

  std::size_t count_;
  unsigned enabled_;
  cudaStream_t stream_;
  EffectArrays arrays_;
  std::vector<std::array<float*, 3>> keyframes_;  // device rest offsets (entries in owned_)
  std::vector<float*> owned_;
};

}  // namespace

std::unique_ptr<EffectsEngine> make_cuda_effects(const LatticeGeometry& geometry, unsigned enabled,
                                                 const std::vector<RestOffsets>& keyframes,
                                                 void* stream) {
  return std::make_unique<CudaEffects>(geometry, enabled, keyframes, stream);
}

}  // namespace tsf::crms
