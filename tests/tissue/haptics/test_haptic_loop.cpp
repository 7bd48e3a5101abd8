// The haptic loop keeps its rate while a solver and a renderer-like thread compete for two
// cores, and the lock-free hand-overs it relies on never tear.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

#include "haptics_test_helpers.h"
#include "tsf/crms/lattice_builders.h"
#include "tsf/haptics/haptic_loop.h"
#include "tsf/haptics/scripted_device.h"
#include "tsf/haptics/seqlock.h"
#include "tsf/haptics/triple_buffer.h"
#include "tsf/interaction/tissue_model.h"

namespace tsf::haptics {
namespace {

TEST(TripleBuffer, TheReaderAlwaysSeesAWholeNewestObject) {
  struct Block {
    std::vector<std::uint64_t> words = std::vector<std::uint64_t>(64, 0);
  };
  TripleBuffer<Block> buffer;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint64_t v = 1; v <= 20000; ++v) {
      Block& b = buffer.back();
      for (auto& w : b.words) w = v;
      buffer.publish();
    }
    done = true;
  });
  std::uint64_t last = 0;
  int torn = 0, backwards = 0;
  while (!done.load()) {
    const Block& b = buffer.acquire();
    for (auto w : b.words) torn += w != b.words[0];
    backwards += b.words[0] < last;
    last = b.words[0];
  }
  writer.join();
  EXPECT_EQ(torn, 0);
  EXPECT_EQ(backwards, 0);
  EXPECT_EQ(buffer.acquire().words[0], 20000u) << "the last publish must reach the reader";
}

TEST(Seqlock, ReadsAreNeverTorn) {
  struct Pair {
    double a, b;
  };
  Seqlock<Pair> lock({0, 0});
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int i = 1; i <= 200000; ++i) lock.store({double(i), -double(i)});
    done = true;
  });
  int torn = 0;
  while (!done.load()) {
    const Pair p = lock.load();
    torn += p.a != -p.b;
  }
  writer.join();
  EXPECT_EQ(torn, 0);
}

TEST(HapticLoop, KeepsItsRateUnderSolverAndRendererLoad) {
  // A property, not a speed benchmark: over 2.5 s at 1 kHz the loop's tick count stays within 5%
  // of the rate while a tissue simulation steps in its own thread (with frame capture) and a
  // renderer-like thread burns ~60% of a core in 10 ms bursts. The rate is what the device got:
  // stalled deadlines are skipped and counted, never made up by a burst. As in tsf, the haptic
  // thread asks for a real-time priority and the others step down to nice +5.
  const Vec3d lo{2, 2, 2}, hi{22, 14, 14};
  const Vec3d centre = (lo + hi) * 0.5, half = (hi - lo) * 0.5;
  interaction::TissueModelOptions o;
  o.lattice.node_spacing_voxels = 2;
  o.solver.materials[0].youngs_modulus_pa = 50e3;
  o.solver.materials[0].viscosity_pa_s = 2.0;
  o.solver.gravity = {0, 0, -9810};
  o.solver.backend = crms::Backend::kCpu;
  o.solver.stability.kinetic_damping = 0.01;
  o.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {5.0, 1e9, 1e9});
  };
  interaction::TissueModel model(
      make_sdf_volume(
          cube_geometry({24, 16, 16}, 1.0),
          [&](const Vec3d& p) { return box_distance_local(half, p - centre); }, 0.5),
      o);
  TissueFrameSource source(model, {2.0, 3.0});
  ForceModelOptions fo;
  fo.stylus_radius_mm = 2.0;
  fo.voxel_resolution = 12;
  const VoxelForceModel force_model(fo);
  ScriptedDevice device(press_and_hold({15, 8, 14}, {0, 0, 1}, 2.0, 1.0, 3.0, 10.0, 10.0));
  TripleBuffer<HapticFrame> frames;
  HapticLoopOptions lo_options;
  lo_options.rate_hz = 1000;
  lo_options.on_thread_start = test::request_realtime;
  HapticLoop loop(device, force_model, frames, lo_options);
  SimulationPump pump(source, frames, loop, 100.0, test::lower_priority);

  std::atomic<bool> stop_renderer{false};
  std::thread renderer([&] {
    test::lower_priority();
    volatile double sink = 0;
    while (!stop_renderer.load()) {
      const auto t0 = std::chrono::steady_clock::now();
      while (std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(6))
        for (int i = 0; i < 1000; ++i) sink = sink + std::sqrt(double(i));
      std::this_thread::sleep_for(std::chrono::milliseconds(4));
    }
  });
  device.start_clock();
  loop.start();
  pump.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  pump.stop();
  loop.stop();
  stop_renderer = true;
  renderer.join();

  const LoopStatistics s = loop.statistics();
  EXPECT_GT(pump.steps(), 5) << "the solver must have run alongside";
  EXPECT_GT(s.elapsed_s, 2.0);
  // Honest accounting whatever the scheduling: the ticks and the skipped deadlines cover the time.
  EXPECT_NEAR(double(s.ticks + s.missed_ticks), s.elapsed_s * 1000.0, 0.02 * s.elapsed_s * 1000.0);
  // With a real-time priority the loop owns its ticks (within 5 %); without one (no
  // CAP_SYS_NICE) it competes with every other thread of the machine, and other processes are
  // beyond this test: within 15 % (the strict 95 % of the command is LiveHaptics.*, in `tsf view`).
  const bool realtime = s.scheduling == "SCHED_FIFO";
  EXPECT_NEAR(s.rate_hz, 1000.0, realtime ? 50.0 : 150.0)
      << s.ticks << " ticks in " << s.elapsed_s << " s, " << s.missed_ticks << " missed, "
      << s.late_ticks << " late; " << s.scheduling;
  EXPECT_TRUE(all_finite(loop.latest_force()));
}

}  // namespace
}  // namespace tsf::haptics
