// Built only without the CUDA backend: the CUDA entry points say why they cannot run.
#include "solver_backend.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/error.h"
#include "tsf/crms/device_bandwidth.h"

namespace tsf::crms {

std::unique_ptr<SolverBackend> make_cuda_backend(const LatticeGeometry&, const BackendOptions&) {
  throw Error("the CUDA backend is not available: " + cuda_status().reason);
}

double measure_device_copy_bandwidth(std::size_t, int) {
  throw Error("cannot measure device bandwidth: " + cuda_status().reason);
}

}  // namespace tsf::crms
