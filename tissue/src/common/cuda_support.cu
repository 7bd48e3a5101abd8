// Built only with the CUDA backend (see tissue/CMakeLists.txt).
#include <cuda_runtime.h>

#include "tsf/common/cuda_support.h"

namespace tsf {

const CudaStatus& cuda_status() {
  static const CudaStatus status = [] {
    CudaStatus s;
    s.compiled = true;
    int count = 0;
    const cudaError_t err = cudaGetDeviceCount(&count);
    if (err != cudaSuccess) {
      // No GPU or an old driver reports an error here (e.g. 35, insufficient driver): no device.
      s.reason = std::string("no usable CUDA device: ") + cudaGetErrorName(err) + " (" +
                 cudaGetErrorString(err) + ")";
      cudaGetLastError();  // clear the sticky error state
      return s;
    }
    if (count == 0) {
      s.reason = "no CUDA device present";
      return s;
    }
    cudaDeviceProp prop{};
    if (cudaGetDeviceProperties(&prop, 0) == cudaSuccess) s.device_name = prop.name;
    s.device_count = count;
    s.available = true;
    return s;
  }();
  return status;
}

}  // namespace tsf
