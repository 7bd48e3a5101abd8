#include "collision_device.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/error.h"

namespace tsf::collision {

std::unique_ptr<CollisionDevice> make_collision_device() {
  throw Error("collision: the CUDA path is not available: " + cuda_status().reason);
}

}  // namespace tsf::collision
