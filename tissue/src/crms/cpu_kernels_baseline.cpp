// CPU kernels for the baseline x86-64 / target instruction set (always available).
//
// Compiled with -fno-math-errno -fno-trapping-math (tissue/CMakeLists.txt says why).

#include "cpu_kernels.h"

#define TSF_CRMS_CPU_SIMD_WIDTH 4
#define TSF_CRMS_CPU_ISA baseline
#define TSF_CRMS_CPU_ISA_KERNELS row_kernels_baseline
#include "cpu_kernels_isa.h"
