// The blade sweep of a cut on the CUDA device (ToolStroke::cut_blade with a sweeper). The host's
// sweep visits each voxel of the swept box once per sub-step whose world-axis box reaches it
// (~60 times for the sinus scene's 40 mm blade through 70 mm of face: 1.2 M blade distances);
// here one thread per voxel of the box keeps its smallest distance over those sub-steps
// (BladeDistanceMin, the voxel placed along its row as the host's row loop places it), reading
// the sub-steps as uniform loads (every thread of a warp reads the same one), and takes the
// fall-off once. The weights come back to the host, which applies them with the stroke's memory
// (ToolStroke::apply), so the edit is the host's edit: the distance and the fall-off are
// tool_shapes.h's TSF_HD functions, and this file is compiled with --fmad=false
// (tissue/CMakeLists.txt) as tool_stroke.cpp is with -ffp-contract=off, so both give the same
// weights bit for bit (EditsOnTheDevice.* tests).
#include <cuda_runtime.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "tsf/common/cuda_check.h"
#include "tsf/common/cuda_support.h"
#include "tsf/common/device_buffer.h"
#include "tsf/common/error.h"
#include "tsf/interaction/tool_stroke.h"

namespace tsf::interaction {
namespace {

__global__ void blade_sweep_kernel(BladeTool blade, const BladeSweepStep* steps, int step_count,
                                   VoxelBox box, VolumeGeometry g, double h, float* weight) {
  const Int3 ext = box.extent();
  const std::int64_t count = ext.volume();
  const std::int64_t v = static_cast<std::int64_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (v >= count) return;
  const int i = box.lo.x + static_cast<int>(v % ext.x);
  const int j = box.lo.y + static_cast<int>((v / ext.x) % ext.y);
  const int k = box.lo.z + static_cast<int>(v / (static_cast<std::int64_t>(ext.x) * ext.y));
  // The host's blade_row: the row's frame from its first voxel, the voxel m = i − box.lo.x along.
  const Vec3d first = g.index_to_tissue({double(box.lo.x), double(j), double(k)});
  BladeDistanceMin nearest;
  for (int n = 0; n < step_count; ++n) {
    const BladeSweepStep& s = steps[n];
    if (!s.box.contains(i, j, k)) continue;
    nearest.add(blade.half_extents, blade_row_frame(s.pose, first, g.spacing.x).at(i - box.lo.x));
  }
  const double d = nearest.distance();
  weight[v] = d < h ? falloff_weight(d, h) : 0.0f;
}

class CudaBladeSweeper final : public BladeSweeper {
 public:
  CudaBladeSweeper() {
    require(cuda_status().available,
            "cut: the blade sweep on the CUDA device is not available: " + cuda_status().reason);
    stream_ = make_stream();
    // Room for a large cut (the sinus scene's: 148 sub-steps over 16.6 k voxels) without an
    // allocation during the edit: page-locked memory is slow to allocate and its free waits.
    steps_.grow_to(1024);
    steps_host_.grow_to(1024);
    weights_.grow_to(std::size_t{1} << 18);
    weights_host_.grow_to(std::size_t{1} << 18);
  }

  void sweep(const BladeSweepPlan& plan, const VolumeGeometry& geometry,
             std::vector<float>& weight) override {
    const std::vector<BladeSweepStep>& steps = plan.steps;
    const VoxelBox& box = plan.box;
    const auto count = static_cast<std::size_t>(box.empty() ? 0 : box.voxel_count());
    weight.assign(count, 0.0f);
    if (count == 0 || steps.empty()) return;
    steps_host_.grow_to(steps.size());
    std::copy(steps.begin(), steps.end(), steps_host_.data());
    steps_.grow_to(steps.size());
    steps_.upload(steps_host_.data(), steps.size(), stream_.get());
    weights_.grow_to(count);
    constexpr unsigned kThreads = 256;
    const auto blocks = static_cast<unsigned>((count + kThreads - 1) / kThreads);
    blade_sweep_kernel<<<blocks, kThreads, 0, stream_.get()>>>(plan.blade, steps_.data(),
                                                               static_cast<int>(steps.size()), box,
                                                               geometry, plan.h, weights_.data());
    TSF_CUDA_CHECK_LAUNCH();
    weights_host_.grow_to(count);
    weights_.download(weights_host_.data(), count, stream_.get());
    TSF_CUDA_CHECK(cudaStreamSynchronize(stream_.get()));
    std::copy(weights_host_.data(), weights_host_.data() + count, weight.data());
  }

 private:
  DeviceBuffer<BladeSweepStep> steps_;
  DeviceBuffer<float> weights_;
  PinnedBuffer<BladeSweepStep> steps_host_;
  PinnedBuffer<float> weights_host_;
  UniqueStream stream_;  // after the buffers: destroyed first, it waits for their work
};

}  // namespace

std::unique_ptr<BladeSweeper> make_cuda_blade_sweeper() {
  return std::make_unique<CudaBladeSweeper>();
}

}  // namespace tsf::interaction
