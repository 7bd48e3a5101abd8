// The GPU's device-to-device copy bandwidth, measured in the same run as a benchmark so that a
// kernel's bytes per second can be quoted as a fraction of what the memory system delivers.
#pragma once

#include <cstddef>

namespace tsf::crms {

/// Times `repetitions` cudaMemcpy device→device of `buffer_bytes` on device 0 and returns the
/// bandwidth counting bytes read plus bytes written, B/s. Throws tsf::Error (naming
/// cuda_status().reason) when CUDA is not built or has no device.
double measure_device_copy_bandwidth(std::size_t buffer_bytes, int repetitions);

}  // namespace tsf::crms
