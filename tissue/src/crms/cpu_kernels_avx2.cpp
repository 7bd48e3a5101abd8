// CPU kernels compiled for AVX2 + FMA (8-wide float SIMD); used when the processor has them.
//
// Compiled with -fno-math-errno -fno-trapping-math (tissue/CMakeLists.txt says why).

#include "cpu_kernels.h"

// Sanitizer builds (CI's ASan + UBSan job) compile the baseline kernels only: the same templates
// for a wider target cost over 17 CPU-minutes each under ASan (AVX-512, measured; CI has 2 cores,
// 90 minutes), and the robustness tests exercise the templates through the baseline build.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_ADDRESS__)
#pragma GCC target("avx2,fma,bmi,bmi2,popcnt")
#define TSF_CRMS_CPU_SIMD_WIDTH 8
#define TSF_CRMS_CPU_ISA avx2
#define TSF_CRMS_CPU_ISA_KERNELS row_kernels_avx2
#include "cpu_kernels_isa.h"
#else
namespace tsf::crms::cpu {
// Not an x86-64 GCC build, or a sanitizer build: the instruction set is never selected.
RowKernels row_kernels_avx2(unsigned) {
  return {};
}
}  // namespace tsf::crms::cpu
#endif
