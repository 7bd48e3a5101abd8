// Checked CUDA calls: every runtime call goes through TSF_CUDA_CHECK, which throws tsf::Error
// naming the call, the file and the line. Include only from .cu files.
#pragma once

#include <cuda_runtime.h>

#include <string>

#include "tsf/common/error.h"

namespace tsf::detail {
[[noreturn]] inline void throw_cuda_error(cudaError_t code, const char* call, const char* file,
                                          int line) {
  throw Error(std::string("CUDA error ") + cudaGetErrorName(code) + " (" +
              cudaGetErrorString(code) + ") in " + call + " at " + file + ":" +
              std::to_string(line));
}
}  // namespace tsf::detail

#define TSF_CUDA_CHECK(call)                                                        \
  do {                                                                              \
    const cudaError_t tsf_cuda_status_ = (call);                                    \
    if (tsf_cuda_status_ != cudaSuccess)                                            \
      ::tsf::detail::throw_cuda_error(tsf_cuda_status_, #call, __FILE__, __LINE__); \
  } while (0)

/// After a kernel launch: launch-configuration errors surface here, execution errors at the
/// next synchronising call.
#define TSF_CUDA_CHECK_LAUNCH() TSF_CUDA_CHECK(cudaGetLastError())
