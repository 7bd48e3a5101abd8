// Compile-time feature set of the CRMS kernels ("simulate only the effects a scene calls for").
//
// The per-node functions and the CPU/CUDA loops are templates over an `unsigned` bit set; each
// bit selects a code path with `if constexpr`, so a disabled feature compiles to nothing, and the
// solver allocates a feature's per-node arrays only when its bit is set. The solver picks one
// instantiation per step from the scene's configuration (dispatch_features below).
//
// Bits fall in two groups:
//   knobs   — alternative formulations of the same physics, measured against each other
//   effects — extra physics that needs per-node data
// Issue 6 adds plasticity, anisotropy, fluid pressure, animation and tearing as further effect
// bits with their own arrays in EffectArrays (node_state_view.h).
#pragma once

#include <type_traits>
#include <utility>

namespace tsf::crms {

namespace features {
/// Knob: angular springs use the cosine form ψ = cos θ (U = ½k·cos²θ, no asin, no 1/sin θ)
/// instead of the thesis deflection ψ = θ0 − acos(cos θ).
constexpr unsigned kCosineAngular = 1u << 0;
/// Knob: each node also gathers the reactions of the angles at its neighbours where it is an arm,
/// so angular forces derive from one potential (momentum and energy consistent; 19-node stencil).
constexpr unsigned kSymmetricReactions = 1u << 1;
/// Effect: per-node external force (tools, loads), #nodes×3 µN.
constexpr unsigned kExternalForces = 1u << 2;
/// Effect: per-node material index into the spring-constant palette (heterogeneous tissue).
constexpr unsigned kHeterogeneous = 1u << 3;

constexpr unsigned kCount = 4;
constexpr unsigned kAll = (1u << kCount) - 1;
}  // namespace features

/// Calls `f(std::integral_constant<unsigned, F>{})` with the compile-time F equal to the run-time
/// `set` (which must be ≤ features::kAll). One instantiation per feature set in use.
template <typename Function, unsigned... Sets>
decltype(auto) dispatch_features_impl(unsigned set, Function&& f,
                                      std::integer_sequence<unsigned, Sets...>) {
  using Result = decltype(f(std::integral_constant<unsigned, 0>{}));
  if constexpr (std::is_void_v<Result>) {
    ((set == Sets ? (f(std::integral_constant<unsigned, Sets>{}), true) : false) || ...);
  } else {
    Result r{};
    ((set == Sets ? (r = f(std::integral_constant<unsigned, Sets>{}), true) : false) || ...);
    return r;
  }
}
template <typename Function>
decltype(auto) dispatch_features(unsigned set, Function&& f) {
  return dispatch_features_impl(set, std::forward<Function>(f),
                                std::make_integer_sequence<unsigned, features::kAll + 1>{});
}

}  // namespace tsf::crms
