// The haptic devices tsf offers by name (`--device NAME[:KEY=VALUE,…]`, haptics/device_registry.h),
// for every command that drives a live haptic loop (`tsf view`, `tsf haptics --live`):
//
//   scripted   a scripted path played in wall-clock time (tsf haptics: --trajectory; tsf view: the
//              view script's or the scene script's first hand); tissue space
//   mouse      the viewer window's mouse and keys (tsf view only); tissue space;
//              `mouse:speed=MM_PER_S` sets how fast held keys move the tool (default 10)
//   igtl       the live link (OpenIGTLink, docs/live.md): a tracker's or haptic bridge's
//              TRANSFORM in, the force back as SENSOR; patient LPS (built with TSF_WITH_IGTL)
//
// A driver for real hardware or a network link adds itself in haptic_devices() (its poses and
// forces in patient LPS mm, HapticDevice::frame()); every command then offers it.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "tsf/haptics/device_registry.h"
#include "tsf/haptics/haptic_loop.h"
#include "tsf/interaction/tool.h"
#include "tsf/interaction/trajectory.h"

namespace tsf::app {

/// What the command running the loop can give a device.
struct DeviceContext {
  /// scripted: the path (tissue space, seconds); null: the command has none to offer.
  const interaction::Trajectory* trajectory = nullptr;
  /// mouse: whether a window will drive it.
  bool window = false;
};

/// tsf's devices, those the context can make.
haptics::DeviceRegistry haptic_devices(const DeviceContext& context);

/// The haptic thread's start (HapticLoopOptions::on_thread_start): asks for SCHED_FIFO (granted
/// with CAP_SYS_NICE or an rtprio limit; not asked when TSF_HAPTICS_NO_REALTIME is set) and says
/// what it got.
std::string request_haptic_thread_priority();

/// A simulation thread's start: it steps down to nice +5 (Linux: per thread), so the haptic
/// thread at the default priority wins the CPU when both want it. Best effort.
void lower_thread_priority();
/// Every thread of the process but the haptic thread (the renderer, its driver's workers, the
/// simulation) steps down to nice +5; threads made later by them inherit it. Best effort.
void lower_other_threads_priority();

/// The stylus radius of the voxel and mesh models for a tool the device holds, mm: a sphere's or
/// capsule's radius, half a blade's thickness (at least 0.5), half a mesh's smallest extent.
double stylus_radius_of(const interaction::Tool& tool);

/// A live loop's statistics as a report section (rate, missed and late ticks, tick latency and
/// compute percentiles, scheduling).
nlohmann::json loop_statistics_json(const haptics::LoopStatistics& s);

}  // namespace tsf::app
