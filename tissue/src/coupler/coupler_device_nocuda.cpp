#include "coupler_device.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/error.h"

namespace tsf::coupler {

std::unique_ptr<CouplerDevice> make_coupler_device() {
  throw Error("coupler: the CUDA path is not available: " + cuda_status().reason);
}

}  // namespace tsf::coupler
