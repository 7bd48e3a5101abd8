// The moving-average filter's latency, and jitter falling with resolution and with the filter.
#include <gtest/gtest.h>

#include <cmath>

#include "haptics_test_helpers.h"
#include "tsf/haptics/haptic_metrics.h"
#include "tsf/haptics/moving_average.h"

namespace tsf::haptics {
namespace {

TEST(MovingAverage, AStepIsFullyFeltAfterExactlyTheWindow) {
  for (int window : {1, 2, 4, 7}) {
    MovingAverageFilter f(window);
    for (int i = 0; i < 10; ++i) {
      EXPECT_EQ(f.filter({0, 0, 0}).x, 0.0);
    }
    int felt = 0;
    for (int i = 1; i <= 20; ++i) {
      const double y = f.filter({1, 0, 0}).x;
      if (felt == 0 && std::fabs(y - 1.0) < 1e-12) felt = i;
      if (i < window) {
        EXPECT_LT(y, 1.0 - 1e-9) << "window " << window << ", sample " << i;
      }
    }
    EXPECT_EQ(felt, window);
    EXPECT_EQ(f.step_latency_samples(), window);
  }
}

TEST(MovingAverage, ARampIsDelayedByHalfTheWindowLessOne) {
  for (int window : {1, 2, 4, 8}) {
    MovingAverageFilter f(window);
    for (int k = 0; k < 40; ++k) {
      const double y = f.filter({double(k), 0, 0}).x;
      if (k >= window) {
        EXPECT_NEAR(k - y, f.group_delay_samples(), 1e-9) << "window " << window;
      }
    }
    EXPECT_DOUBLE_EQ(f.group_delay_samples(), 0.5 * (window - 1));
  }
}

/// Jitter of a voxel-model skim (1 kHz, 20 mm/s) over a binary-voxel sphere.
double pass_jitter(int stylus_resolution, double voxel_mm, int filter_window,
                   DensitySampling sampling = DensitySampling::kNearest) {
  const double R = 8.0, r = 2.5;
  const VoxelVolume tissue = test::sphere_volume_of(R, 24.0, voxel_mm, 0.0);
  const Vec3d c = test::volume_centre(tissue);
  ForceModelOptions o;
  o.stylus_radius_mm = r;
  o.voxel_resolution = stylus_resolution;
  o.sampling = sampling;
  const VoxelForceModel model(o);
  StaticFrameSource source(tissue, nullptr, {r, 1.0});
  // Skim the sphere 1 mm deep along y: a long contact over the curved surface.
  const Vec3d from = c + Vec3d{R + r - 1.0, -6.0, 0}, to = c + Vec3d{R + r - 1.0, 6.0, 0};
  PlaybackOptions p;
  p.haptic_rate_hz = 1000;
  p.sim_rate_hz = 1000;
  p.filter_window = filter_window;
  const auto samples = play_trajectory(straight_pass(from, to, 20.0), source, model, p);
  MetricOptions m;
  m.tick_s = 1e-3;
  m.filter_window = filter_window;
  return compute_metrics(samples, m).jitter_relative;
}

// Binary voxels read at the nearest voxel (the thesis's test): the force steps by one cell volume
// whenever a cell centre crosses a voxel face, so a finer stylus steps less.
TEST(HapticJitter, FallsAsTheStylusResolutionRises) {
  const double coarse = pass_jitter(4, 0.5, 1), fine = pass_jitter(16, 0.5, 1);
  EXPECT_GT(coarse, 1.5 * fine) << "coarse " << coarse << ", fine " << fine;
}

// Binary voxels, nearest reads, a fine stylus: the sphere's voxel staircase is felt as bumps
// along the skim, smaller with finer voxels.
TEST(HapticJitter, FallsAsTheVoxelResolutionRises) {
  const double coarse = pass_jitter(16, 2.0, 1), fine = pass_jitter(16, 0.5, 1);
  EXPECT_GT(coarse, 1.4 * fine) << "coarse voxels " << coarse << ", fine " << fine;
}

TEST(HapticJitter, TrilinearDensityIsFarSmootherThanNearest) {
  const double nearest = pass_jitter(8, 1.0, 1),
               trilinear = pass_jitter(8, 1.0, 1, DensitySampling::kTrilinear);
  EXPECT_GT(nearest, 10.0 * trilinear) << "nearest " << nearest << ", trilinear " << trilinear;
}

TEST(HapticJitter, FallsWithTheFilter) {
  const double raw = pass_jitter(4, 0.5, 1), filtered = pass_jitter(4, 0.5, 4);
  EXPECT_GT(raw, 1.5 * filtered) << "raw " << raw << ", filtered " << filtered;
}

}  // namespace
}  // namespace tsf::haptics
