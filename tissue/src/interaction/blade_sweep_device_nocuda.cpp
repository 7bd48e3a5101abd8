#include "tsf/common/cuda_support.h"
#include "tsf/common/error.h"
#include "tsf/interaction/tool_stroke.h"

namespace tsf::interaction {

std::unique_ptr<BladeSweeper> make_cuda_blade_sweeper() {
  throw Error("cut: the blade sweep on the CUDA device is not available: " + cuda_status().reason);
}

}  // namespace tsf::interaction
