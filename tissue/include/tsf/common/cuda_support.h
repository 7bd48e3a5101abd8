// Whether the CUDA backend can run here, and why not.
//
// The library always builds; without nvcc it is built without the CUDA backend and says so at
// run time. Without a GPU (or with too old a driver) cudaGetDeviceCount fails: that is "no
// device", not an error. Tests use the reason in their skip message.
#pragma once

#include <string>

namespace tsf {

struct CudaStatus {
  bool compiled = false;   ///< built with the CUDA backend (TSF_HAVE_CUDA)
  bool available = false;  ///< compiled and at least one usable device
  int device_count = 0;
  std::string device_name;  ///< of device 0 when available
  std::string reason;       ///< why not available (empty when available)
};

/// Queried once and cached; cheap to call repeatedly.
const CudaStatus& cuda_status();

}  // namespace tsf
