// Built only without the CUDA backend (see tissue/CMakeLists.txt).
#include "tsf/common/cuda_support.h"

namespace tsf {

const CudaStatus& cuda_status() {
  static const CudaStatus status = [] {
    CudaStatus s;
    s.reason = "tsf was built without the CUDA backend (nvcc not found or TSF_WITH_CUDA=OFF)";
    return s;
  }();
  return status;
}

}  // namespace tsf
