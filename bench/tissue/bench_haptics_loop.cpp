// The haptic loop's tick-time distribution while the solver runs: the loop ticks at 1 kHz and
// 5 kHz (and 10 kHz) in its own thread, a simulation thread steps a soft block (TissueFrameSource:
// press, advance, capture) at --sim-rate and publishes frames, and the stylus presses and holds
// on the block's top. Baseline in the same run: the same loop with the simulation idle.
//
// Reported per rate: achieved rate (what the device got: a stall's deadlines are skipped and
// counted as missed, never made up by a burst), missed ticks, ticks late by more than a period,
// the tick compute time (device read + frame acquire + voxel model + filter + device write)
// p50 / p99 / p99.9 / max, and the tick latency (deadline → force written) p99 / p99.9 / max.
// Goal: p99.9 ≤ 300 µs at 1 kHz with the solver running (16³ voxel stylus).
//
// As tsf does, the haptic thread asks for SCHED_FIFO (unless --no-realtime) and the simulation
// thread steps down to nice +5; the header says what the loop got.
//
//   bench_haptics_loop [--seconds 3] [--resolution 16] [--sim-rate 200] [--model voxel]
//                      [--no-realtime]
#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <thread>

#include "tsf/crms/lattice_builders.h"
#include "tsf/haptics/force_models.h"
#include "tsf/haptics/haptic_loop.h"
#include "tsf/haptics/haptic_trajectory.h"
#include "tsf/haptics/scripted_device.h"
#include "tsf/interaction/tissue_model.h"
#include "tsf/volume/analytic_volumes.h"

namespace {

using namespace tsf;
using namespace tsf::haptics;

std::unique_ptr<interaction::TissueModel> make_block() {
  // 30 × 20 × 12 mm block on a rigid base, 1 mm voxels, 2 mm nodes (scenes/haptics-block.yaml).
  const Vec3d lo{2, 2, 2}, hi{32, 22, 14};
  const Vec3d centre = (lo + hi) * 0.5, half = (hi - lo) * 0.5;
  interaction::TissueModelOptions o;
  o.lattice.node_spacing_voxels = 2;
  o.solver.materials[0].youngs_modulus_pa = 30e3;
  o.solver.materials[0].viscosity_pa_s = 10.0;
  o.solver.gravity = {0, 0, -9810};
  o.solver.backend = crms::Backend::kCpu;
  o.solver.stability.kinetic_damping = 0.01;
  o.anchor = [](crms::Lattice& l) {
    crms::fix_nodes_in_box(l, {-1e9, -1e9, -1e9}, {1e9, 1e9, 3.5});
  };
  return std::make_unique<interaction::TissueModel>(
      make_sdf_volume(
          cube_geometry({34, 24, 16}, 1.0),
          [&](const Vec3d& p) { return box_distance_local(half, p - centre); }, 0.5),
      o);
}

bool g_realtime = true;
std::string g_scheduling = "not started";

std::string request_realtime() {
  if (g_realtime) {
    sched_param p{};
    p.sched_priority = 10;
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &p) == 0) return "SCHED_FIFO";
  }
  return "normal scheduling";
}

void run(double rate, bool solver, double seconds, const ForceModel& model, double sim_rate) {
  auto block = make_block();
  TissueFrameSource source(*block, {3.0, 3.0});
  ScriptedDevice device(press_and_hold({17, 12, 14}, {0, 0, 1}, 3.0, 1.5, 2.0, 10.0, 100.0));
  TripleBuffer<HapticFrame> frames;
  {
    // First frame before the loop starts, so every tick has tissue to feel.
    StylusPose p;
    p.position = {17, 12, 16};
    source.step(0, p, false, frames.back());
    frames.publish();
  }
  HapticLoopOptions o;
  o.rate_hz = rate;
  o.on_thread_start = request_realtime;
  HapticLoop loop(device, model, frames, o);
  SimulationPump pump(source, frames, loop, sim_rate, [] {
    (void)setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), 5);
  });
  device.start_clock();
  loop.start();
  if (solver) pump.start();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  pump.stop();
  loop.stop();
  const LoopStatistics s = loop.statistics();
  g_scheduling = s.scheduling;
  std::printf(
      "%-8.0f %-7s %9.1f %6lld %6lld %8.1f %8.1f %8.1f %8.1f %9.1f %9.1f %9.1f %8lld %10.0f\n",
      rate, solver ? "running" : "idle", s.rate_hz, static_cast<long long>(s.missed_ticks),
      static_cast<long long>(s.late_ticks), s.compute_p50_us, s.compute_p99_us, s.compute_p999_us,
      s.compute_max_us, s.latency_p99_us, s.latency_p999_us, s.latency_max_us,
      static_cast<long long>(pump.steps()), pump.max_step_us());
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 3.0, sim_rate = 200.0;
  int resolution = 16;
  std::string model_name = "voxel";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--seconds" && has_value)
      seconds = std::atof(argv[++i]);
    else if (a == "--resolution" && has_value)
      resolution = std::atoi(argv[++i]);
    else if (a == "--sim-rate" && has_value)
      sim_rate = std::atof(argv[++i]);
    else if (a == "--model" && has_value)
      model_name = argv[++i];
    else if (a == "--no-realtime")
      g_realtime = false;
    else {
      std::fprintf(stderr,
                   "usage: bench_haptics_loop [--seconds S] [--resolution N] [--sim-rate HZ] "
                   "[--model voxel|lattice|mesh] [--no-realtime]\n");
      return a == "--help" ? 0 : 2;
    }
  }
  try {
    ForceModelOptions fo;
    fo.stylus_radius_mm = 3.0;
    fo.voxel_resolution = resolution;
    fo.sphere_resolution = std::min(resolution, 32);
    const auto model = make_force_model(force_model_from_string(model_name), fo);
    std::printf(
        "haptic loop, %s model (resolution %d), %.1f s per row, simulation at %.0f Hz, "
        "%u hardware threads\n",
        model_name.c_str(), resolution, seconds, sim_rate, std::thread::hardware_concurrency());
    std::printf("%-8s %-7s %9s %6s %6s %8s %8s %8s %8s %9s %9s %9s %8s %10s\n", "rate_hz", "solver",
                "achieved", "missed", "late", "c_p50", "c_p99", "c_p99.9", "c_max", "lat_p99",
                "lat_p99.9", "lat_max", "sim_steps", "sim_max_us");
    for (double rate : {1000.0, 5000.0, 10000.0}) {
      run(rate, false, seconds, *model, sim_rate);
      run(rate, true, seconds, *model, sim_rate);
    }
    std::printf("haptic thread: %s\n", g_scheduling.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_haptics_loop: %s\n", e.what());
    return 1;
  }
  return 0;
}
