// Built only without CUDA: the CUDA effect passes say why they cannot run.
#include "effects_engine.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/error.h"

namespace tsf::crms {

std::unique_ptr<EffectsEngine> make_cuda_effects(const LatticeGeometry&, unsigned,
                                                 const std::vector<RestOffsets>&, void*) {
  throw Error("the CUDA effect passes are not available: " + cuda_status().reason);
}

}  // namespace tsf::crms
