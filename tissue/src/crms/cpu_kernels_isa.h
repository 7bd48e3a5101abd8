// The CPU kernels (cpu_row_loops.inc) and their flattened entry points for one instruction set.
//
// Included by one translation unit per instruction set, after its `#pragma GCC target(...)` and
// with TSF_CRMS_CPU_ISA naming the namespace and TSF_CRMS_CPU_ISA_KERNELS the lookup function of
// that set. What is compiled for the target lives in that namespace only (unique symbol names),
// so no function compiled for a wider instruction set can be merged by the linker with a
// baseline copy of the same inline function in another translation unit. The physics headers
// were parsed before the pragma and keep the default target; `flatten` inlines them into the
// entry points, where the vectorizer then uses the wider registers.
#if !defined(TSF_CRMS_CPU_ISA) || !defined(TSF_CRMS_CPU_ISA_KERNELS)
#error "define TSF_CRMS_CPU_ISA and TSF_CRMS_CPU_ISA_KERNELS before including cpu_kernels_isa.h"
#endif

// Sanitizer builds keep the compiler's own inlining: flattening the kernels' whole call trees
// under ASan instrumentation took one core 21 minutes for the baseline set's file (89 s without;
// docs/robustness.md, "Tests"). The instrumented code is the same functions, called, not inlined.
#if defined(__SANITIZE_ADDRESS__)
#define TSF_CRMS_CPU_FLATTEN
#else
#define TSF_CRMS_CPU_FLATTEN __attribute__((flatten))
#endif

namespace tsf::crms::cpu::TSF_CRMS_CPU_ISA {

#include "cpu_row_loops.inc"

template <unsigned F>
TSF_CRMS_CPU_FLATTEN std::int64_t step_row_per_node_entry(const StepContext& c, int j, int k,
                                                          const RowScratch& scratch) {
  return step_row_per_node<F>(c, j, k, scratch);
}

template <unsigned F>
TSF_CRMS_CPU_FLATTEN std::int64_t march_tile_entry(const StepContext& c, const TermRing& ring,
                                                   const Tile& tile, const RowScratch& scratch) {
  return march_tile<F>(c, ring, tile, scratch);
}

template <unsigned F>
RowKernels kernels_of() {
  RowKernels k;
  k.step_row_per_node = &step_row_per_node_entry<F>;
  if constexpr ((F & features::kSymmetricReactions) != 0) k.march_tile = &march_tile_entry<F>;
  return k;
}

template <unsigned... Sets>
RowKernels find_kernels(unsigned set, std::integer_sequence<unsigned, Sets...>) {
  RowKernels found;
  ((set == Sets ? (found = kernels_of<Sets>(), true) : false) || ...);
  return found;
}

}  // namespace tsf::crms::cpu::TSF_CRMS_CPU_ISA

namespace tsf::crms::cpu {
RowKernels TSF_CRMS_CPU_ISA_KERNELS(unsigned set) {
  return TSF_CRMS_CPU_ISA::find_kernels(set, CompiledFeatureSets{});
}
}  // namespace tsf::crms::cpu
