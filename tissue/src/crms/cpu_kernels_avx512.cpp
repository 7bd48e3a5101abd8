// CPU kernels compiled for AVX-512 (16-wide float SIMD, 32 vector registers, mask registers for
// the branch-free selects); used when the processor has AVX-512 F/VL/BW/DQ.
//
// Compiled with -fno-math-errno -fno-trapping-math (tissue/CMakeLists.txt says why).

#include "cpu_kernels.h"

// Sanitizer builds (CI's ASan + UBSan job) compile the baseline kernels only: the same templates
// for a wider target cost over 17 CPU-minutes each under ASan (AVX-512, measured; CI has 2 cores,
// 90 minutes), and the robustness tests exercise the templates through the baseline build.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_ADDRESS__)
#pragma GCC target( \
    "avx512f,avx512vl,avx512bw,avx512dq,avx512cd,avx2,fma,bmi,bmi2,popcnt,prefer-vector-width=512")
#define TSF_CRMS_CPU_SIMD_WIDTH 16
#define TSF_CRMS_CPU_ISA avx512
#define TSF_CRMS_CPU_ISA_KERNELS row_kernels_avx512
#include "cpu_kernels_isa.h"
#else
namespace tsf::crms::cpu {
// Not an x86-64 GCC build, or a sanitizer build: the instruction set is never selected.
RowKernels row_kernels_avx512(unsigned) {
  return {};
}
}  // namespace tsf::crms::cpu
#endif
