// CPU effect passes: the per-node functions of effect_physics.h in OpenMP loops over rows, in the
// order of effects_engine.h.
#include <omp.h>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "effects_engine.h"

namespace tsf::crms {
namespace {

/// Below this many nodes a pass runs on one thread (thread start-up would dominate).
constexpr std::int64_t kParallelNodes = 8192;

/// Calls body(n, i, j, k) for every node, rows spread over threads.
template <class Body>
void for_each_node(const LatticeView& lat, Body&& body) {
  const int nx = lat.dims.x, ny = lat.dims.y;
  const std::int64_t rows = static_cast<std::int64_t>(ny) * lat.dims.z;
#pragma omp parallel for schedule(static) if (lat.count >= kParallelNodes)
  for (std::int64_t row = 0; row < rows; ++row) {
    const int j = static_cast<int>(row % ny), k = static_cast<int>(row / ny);
    const std::int64_t base = row * nx;
    for (int i = 0; i < nx; ++i) body(base + i, i, j, k);
  }
}

class CpuEffects final : public EffectsEngine {
 public:
  CpuEffects(const LatticeGeometry& g, unsigned enabled, const std::vector<RestOffsets>& keyframes)
      : EffectsEngine(enabled, keyframes.size()), count_(static_cast<std::size_t>(g.node_count())) {
    if (enabled & effect_bits::kRestAnimation) keyframes_ = keyframes;
    if (enabled & effect_bits::kNodeMasking) mask_.assign(count_, 0);
    if (enabled & effect_bits::kPlasticity)
      for (auto& c : plastic_) c.assign(count_, 0.0f);
    if (enabled & effect_bits::kFluid) {
      content_.assign(count_, 0.0f);
      pressure_.assign(count_, 0.0f);
    }
    if (enabled & effect_bits::kForceEffects)
      for (auto& c : force_) c.assign(count_, 0.0f);
    if (enabled & effect_bits::kVolumetric)
      for (auto& c : volume_terms_) c.assign(count_, 0.0f);
  }

  EffectsState read() const override {
    EffectsState r;
    if (!plastic_[0].empty()) {
      r.plastic_offset.resize(count_);
      for (std::size_t n = 0; n < count_; ++n)
        r.plastic_offset[n] = {plastic_[0][n], plastic_[1][n], plastic_[2][n]};
    }
    r.fluid_content = content_;
    r.fluid_pressure = pressure_;
    return r;
  }

  std::vector<std::uint8_t> read_flags(const LatticeView& lat) const override {
    return std::vector<std::uint8_t>(lat.flags, lat.flags + lat.count);
  }

 protected:
  void run_pass(EffectPass pass, const LatticeView& lat, const StateView& state,
                const EffectParameters& p) override {
    const EffectArrays a = arrays(p);
    const ConstStateView s = state;
    auto* flags = const_cast<std::uint8_t*>(lat.flags);  // the backend's own flags array
    switch (pass) {
      case EffectPass::kVolumeTerms:
        for_each_node(lat, [&](std::int64_t n, int i, int j, int k) {
          cube_volume_terms(lat, s, p.volume, n, i, j, k, a.volume_terms);
        });
        break;
      case EffectPass::kCubePressure:
        for_each_node(lat, [&](std::int64_t n, int i, int j, int k) {
          a.fluid_pressure[n] = cube_pressure(lat, s, a, p, n, i, j, k);
        });
        break;
      case EffectPass::kEffectForce:
        for_each_node(lat, [&](std::int64_t n, int i, int j, int k) {
          const Vec3f f = effect_force(lat, s, a, p, n, i, j, k);
          a.force[0][n] = f.x;
          a.force[1][n] = f.y;
          a.force[2][n] = f.z;
        });
        break;
      case EffectPass::kKick:
        for_each_node(lat, [&](std::int64_t n, int i, int j, int k) {
          kick_node(lat, state, a, p, n, i, j, k);
        });
        break;
      case EffectPass::kUpdateStores: {
        const bool plastic = (enabled() & effect_bits::kPlasticity) != 0;
        const bool fluid = (enabled() & effect_bits::kFluid) != 0;
        for_each_node(lat, [&](std::int64_t n, int i, int j, int k) {
          if (plastic) update_plastic_offsets(lat, s, a, p, n, i, j, k);
          if (fluid) update_fluid_content(lat, a, p, n, i, j, k);
        });
        break;
      }
      case EffectPass::kTear:
        for_each_node(lat, [&](std::int64_t n, int i, int j, int k) {
          flags[n] = torn_flags(lat, s, p, n, i, j, k);
        });
        break;
      case EffectPass::kMarkOverloaded:
        for_each_node(lat, [&](std::int64_t n, int i, int j, int k) {
          a.node_mask[n] = node_overloaded(lat, s, p, n, i, j, k);
        });
        break;
      case EffectPass::kUnlinkMasked:
        for_each_node(lat,
                      [&](std::int64_t n, int, int, int) { flags[n] = unmasked_flags(lat, a, n); });
        break;
    }
  }

 private:
  EffectArrays arrays(const EffectParameters& p) const {
    EffectArrays a;
    auto data = [](const std::vector<float>& v) {
      return v.empty() ? nullptr : const_cast<float*>(v.data());
    };
    for (int c = 0; c < 3; ++c) {
      a.plastic_offset[c] = data(plastic_[c]);
      a.force[c] = data(force_[c]);
    }
    a.fluid_content = data(content_);
    a.fluid_pressure = data(pressure_);
    if (!keyframes_.empty())
      for (int c = 0; c < 3; ++c) {
        a.rest_from[c] = keyframes_[static_cast<std::size_t>(p.rest_from_key)][c].data();
        a.rest_to[c] = keyframes_[static_cast<std::size_t>(p.rest_to_key)][c].data();
      }
    a.node_mask = mask_.empty() ? nullptr : const_cast<std::uint8_t*>(mask_.data());
    for (int c = 0; c < 9; ++c) a.volume_terms[c] = data(volume_terms_[c]);
    return a;
  }

  std::size_t count_;
  std::array<std::vector<float>, 3> plastic_, force_;
  std::vector<float> content_, pressure_;
  std::vector<RestOffsets> keyframes_;
  std::vector<std::uint8_t> mask_;
  std::array<std::vector<float>, 9> volume_terms_;
};

}  // namespace

std::unique_ptr<EffectsEngine> make_cpu_effects(const LatticeGeometry& geometry, unsigned enabled,
                                                const std::vector<RestOffsets>& keyframes) {
  return std::make_unique<CpuEffects>(geometry, enabled, keyframes);
}

}  // namespace tsf::crms
