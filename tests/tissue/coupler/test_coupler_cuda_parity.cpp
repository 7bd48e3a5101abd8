// The coupler's CUDA kernel and CPU loop run the same per-vertex function: on the same lattice
// state they must give the same render buffer, after a full coupling and after an edit's
// partial one, and the dirty blocks must name what changed.
#include <gtest/gtest.h>

#include <cmath>

#include "../interaction/interaction_test_helpers.h"
#include "tsf/common/cuda_support.h"

namespace tsf::coupler {
namespace {

using interaction::TissueModel;

std::unique_ptr<TissueModel> make_model(crms::Backend backend, CouplerMode mode) {
  auto o = interaction::test::block_options(4.0);
  o.solver.backend = backend;
  o.coupler_mode = mode;
  return std::make_unique<TissueModel>(
      interaction::test::block_volume({34, 18, 16}, {2, 2, 2}, {32, 16, 14}), o);
}

/// Same bent state on both solvers.
void bend(TissueModel& model) {
  const crms::Lattice& l = model.solver().lattice();
  std::vector<Vec3f> du(static_cast<std::size_t>(l.node_count())), v(du.size());
  for (std::int64_t n = 0; n < l.node_count(); ++n) {
    const Vec3d p = l.geometry().rest_position(n);
    du[static_cast<std::size_t>(n)] =
        to_float(Vec3d{0.02 * p.z * p.x, 0.01 * p.y, -0.01 * p.x * p.x});
  }
  model.solver().set_state(du, v);
}

double worst_difference(const TissueModel& a, const TissueModel& b) {
  double worst = 0;
  EXPECT_EQ(a.surface().vertex_slot_count(), b.surface().vertex_slot_count());
  for (std::uint32_t s = 1; s < a.surface().vertex_slot_count(); ++s) {
    if (!a.surface().vertex_live(s)) continue;
    worst =
        std::max(worst, double(length(a.coupler().positions()[s] - b.coupler().positions()[s])));
    worst = std::max(worst, double(length(a.coupler().normals()[s] - b.coupler().normals()[s])));
  }
  return worst;
}

TEST(CouplerCudaParity, CpuAndCudaGiveTheSameRenderBuffer) {
  if (!cuda_status().available) GTEST_SKIP() << "CUDA parity not run: " << cuda_status().reason;
  for (CouplerMode mode : {CouplerMode::kTrilinear, CouplerMode::kLocalFrame}) {
    auto cpu = make_model(crms::Backend::kCpu, mode);
    auto gpu = make_model(crms::Backend::kCuda, mode);
    ASSERT_TRUE(gpu->solver().on_cuda());
    bend(*cpu);
    bend(*gpu);
    cpu->couple();
    gpu->couple();
    EXPECT_LT(worst_difference(*cpu, *gpu), 1e-5) << "full coupling, mode " << int(mode);

    // An edit through every layer on both: the partial coupling of re-bound vertices.
    interaction::Tool ball;
    ball.radius_mm = 3.0;
    for (auto* m : {cpu.get(), gpu.get()}) {
      m->apply_tool(ball, {{16, 9, 16}, {}}, interaction::ToolMode::kAblate);
      m->apply_tool(ball, {{20, 9, 14}, {}}, interaction::ToolMode::kAblate);
    }
    EXPECT_LT(worst_difference(*cpu, *gpu), 1e-5) << "after an edit, mode " << int(mode);
    // Then steps on both backends (the solvers agree to their own parity tolerance).
    cpu->advance(1e-3);
    gpu->advance(1e-3);
    EXPECT_LT(worst_difference(*cpu, *gpu), 1e-3) << "after stepping, mode " << int(mode);

    // Re-coupling an unchanged state stamps nothing on the GPU path either.
    const std::uint64_t v = gpu->coupler().version();
    gpu->couple();
    EXPECT_TRUE(gpu->coupler().changed_ranges(v).empty());
  }
}

}  // namespace
}  // namespace tsf::coupler
