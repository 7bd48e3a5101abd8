// Contact pressing for a long hold (docs/stability.md "Hard cases"): a ball pressed 1 mm into a
// block under gravity and held for 0.5 s of simulated time (500 frames, two contact passes
// each). The tool's work goes into the monitor's balance between the passes; the tissue model's
// verdict must end stable with no energy from nowhere, on the CPU and (on the GPU machine) CUDA.
#include <gtest/gtest.h>

#include <cstdio>

#include "interaction_test_helpers.h"
#include "tsf/common/cuda_support.h"

namespace tsf::interaction {
namespace {

using test::block_options;
using test::block_volume;

void long_press(crms::Backend backend) {
  TissueModelOptions o = block_options(-1, -9810.0);
  o.solver.backend = backend;
  o.solver.materials[0].youngs_modulus_pa = 50e3;
  o.solver.materials[0].viscosity_pa_s = 10.0;
  o.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, 3.0});
  };
  TissueModel model(block_volume({24, 24, 20}, {2, 2, 2}, {22, 22, 18}), o);
  Tool ball;
  ball.shape = collision::ToolShape::kSphere;
  ball.radius_mm = 5.0;
  for (int frame = 0; frame < 500; ++frame) {
    const double depth = std::min(1.0, frame * 0.05);  // in over 20 frames, then held
    model.apply_tool(ball, {{12.5, 12.5, 18.0 + 5.0 - depth}, {}}, ToolMode::kPress);
    model.advance(1e-3);
  }
  ASSERT_TRUE(test::all_finite(model));
  EXPECT_GT(model.contact().nodes_held, 0u);
  const crms::StabilitySummary r = model.stability();
  std::printf(
      "| contact press held 0.5 s | %s | %lld | %.2f | %s | %.3g%% | %.3g%% | %.2f | %.3g | %.3g "
      "|\n",
      model.solver().on_cuda() ? "cuda" : "cpu", static_cast<long long>(r.steps),
      model.time_step_choice().ratio(), crms::to_string(r.verdict), 100 * r.gain_fraction,
      100 * r.max_limit_fraction, r.max_period2, r.work_in_nj, r.dissipated_nj);
  EXPECT_EQ(r.verdict, crms::StabilityVerdict::kStable) << r.headline();
  EXPECT_LE(r.gain_fraction, crms::StabilityThresholds{}.energy_gain);
  EXPECT_NE(r.work_in_nj, 0.0) << "the tool's pressing must count as work";
}

TEST(StabilityContact, LongPressHoldEndsStableOnTheCpu) {
  long_press(crms::Backend::kCpu);
}

TEST(StabilityContact, LongPressHoldEndsStableOnCuda) {
  if (!cuda_status().available)
    GTEST_SKIP() << "CUDA variant not run: " << cuda_status().reason
                 << " (runs on the GPU machine)";
  long_press(crms::Backend::kCuda);
}

}  // namespace
}  // namespace tsf::interaction
