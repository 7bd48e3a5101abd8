// Host/device annotations for the one copy of the physics.
//
// Per-node, per-tet and per-vertex math lives in headers whose functions are marked TSF_HD:
// nvcc compiles them for both sides, g++ sees plain inline functions. `.cpp` files call them from
// OpenMP loops, `.cu` files from thin kernels.
#pragma once

#if defined(__CUDACC__)
#define TSF_HD __host__ __device__
#define TSF_HD_INLINE __host__ __device__ __forceinline__
#define TSF_DEVICE __device__
#else
#define TSF_HD
#define TSF_HD_INLINE inline
#define TSF_DEVICE
#endif
