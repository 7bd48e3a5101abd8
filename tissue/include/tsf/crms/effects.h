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
// The optional effects (plasticity, anisotropy, fluid pressure, animation, tearing; see
// docs/effects.md) are not feature bits: they have their own bits and arrays (effect_physics.h)
// and run as separate passes around the core step (effects_engine.h).
//
// Which sets are compiled is an explicit list (CompiledFeatureSets), not every subset of the
// bits: each set costs a few kernels of compile time per backend, and 2^kCount stops being
// affordable beyond a handful of bits. A set outside the list is rejected with an error naming
// its bits (Solver checks at construction and whenever its set changes).
#pragma once

#include <cstdio>
#include <string>
#include <type_traits>
#include <utility>

#include "tsf/common/error.h"

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

/// Name of one bit, for messages and reports.
inline const char* name(unsigned bit) {
  switch (bit) {
    case kCosineAngular:
      return "cosine-angular";
    case kSymmetricReactions:
      return "symmetric-reactions";
    case kExternalForces:
      return "external-forces";
    case kHeterogeneous:
      return "heterogeneous";
    default:
      return "unknown";
  }
}
}  // namespace features

/// The feature sets the backends compile kernels for. With the 4 bits of today that is all 16
/// subsets; a new bit adds the sets scenes use (e.g. `kSymmetricReactions | kPlasticity`, with
/// and without kExternalForces), not all 2^kCount.
using CompiledFeatureSets =
    std::integer_sequence<unsigned, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15>;

/// "{symmetric-reactions, external-forces}" for a set of bits.
inline std::string describe_features(unsigned set) {
  std::string s = "{";
  for (unsigned b = 0; b < 32; ++b)
    if (set & (1u << b)) {
      if (s.size() > 1) s += ", ";
      s += features::name(1u << b);
    }
  return s + "}";
}

template <unsigned... Sets>
constexpr bool is_compiled_feature_set_impl(unsigned set,
                                            std::integer_sequence<unsigned, Sets...>) {
  return ((set == Sets) || ...);
}
/// True when the kernels of `set` are compiled (listed in CompiledFeatureSets).
constexpr bool is_compiled_feature_set(unsigned set) {
  return is_compiled_feature_set_impl(set, CompiledFeatureSets{});
}

/// Throws tsf::Error naming the set when it is not compiled.
inline void require_compiled_feature_set(unsigned set) {
  if (is_compiled_feature_set(set)) return;
  char bits[16];
  std::snprintf(bits, sizeof bits, "0x%x", set);
  throw Error("the CRMS kernels are not compiled for the feature set " + describe_features(set) +
              " (bits " + bits + "): add it to CompiledFeatureSets in tsf/crms/effects.h");
}

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

/// Calls `f(std::integral_constant<unsigned, F>{})` with the compile-time F equal to the run-time
/// `set`, one instantiation per set of CompiledFeatureSets; throws tsf::Error for a set outside.
template <typename Function>
decltype(auto) dispatch_features(unsigned set, Function&& f) {
  require_compiled_feature_set(set);
  return dispatch_features_impl(set, std::forward<Function>(f), CompiledFeatureSets{});
}

}  // namespace tsf::crms
