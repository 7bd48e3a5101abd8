// The live haptic loop's contract with devices: a device picked by name with its parameters, poses
// in the patient frame turned into tissue space and forces turned back, a stall counted as missed
// ticks (the achieved rate is what the device got, not a burst that makes up the count), and one
// tick at a time for reproducible offscreen frames.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "tsf/common/error.h"
#include "tsf/haptics/device_frame.h"
#include "tsf/haptics/device_registry.h"
#include "tsf/haptics/haptic_loop.h"
#include "tsf/haptics/scripted_device.h"

namespace tsf::haptics {
namespace {

/// A model that pushes along +x with the stylus's x as magnitude: the loop's output shows where
/// the stylus was (in tissue space).
class EchoModel final : public ForceModel {
 public:
  ForceModelKind kind() const override { return ForceModelKind::kLattice; }
  HapticForce evaluate(const HapticFrameView&, const StylusPose& pose) const override {
    HapticForce f;
    f.force_un = {pose.position.x, 0, 0};
    return f;
  }
};

/// A device in the patient frame at a fixed pose that records the force it is given; it can
/// stall (sleep) once.
class PatientDevice final : public HapticDevice {
 public:
  explicit PatientDevice(const Vec3d& p) : pose_{p, {}} {}
  DeviceState read() override {
    if (stall_ms_ > 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(stall_ms_));
      stall_ms_ = 0;
    }
    DeviceState s;
    s.pose = pose_;
    return s;
  }
  void apply_force(const Vec3d& f) override { force_ = f; }
  PoseFrame frame() const override { return PoseFrame::kPatient; }
  ToolPose pose_;
  Vec3d force_{0, 0, 0};
  int stall_ms_ = 0;
};

/// A patient frame turned 90° about z and mirrored in x (det D = −1), origin (10, 20, 30).
VolumeGeometry turned_frame() {
  VolumeGeometry g;
  g.dims = {10, 10, 10};
  g.origin = {10, 20, 30};
  g.direction = {0, -1, 0, -1, 0, 0, 0, 0, 1};  // columns: i → (0,−1,0), j → (−1,0,0), k → z
  return g;
}

TEST(DeviceRegistry, DevicesArePickedByNameWithTheirParameters) {
  const DeviceRequest q = parse_device_request("igtl:host=localhost,port=18944");
  EXPECT_EQ(q.name, "igtl");
  EXPECT_EQ(q.get("host"), "localhost");
  EXPECT_EQ(q.get("port"), "18944");
  EXPECT_EQ(q.get("timeout", "5"), "5");
  EXPECT_EQ(parse_device_request("mouse").parameters.size(), 0u);
  for (const char* bad : {"", "a b", "x:", "x:port", "x:=1", "x:a=1,a=2"})
    EXPECT_THROW(parse_device_request(bad), Error) << bad;
  DeviceRegistry r;
  r.add("scripted", "a path", [](const DeviceRequest& req) {
    req.expect_only({"loop"});
    return std::make_unique<ScriptedDevice>(interaction::Trajectory(
        std::vector<interaction::Keyframe>{{0, {{1, 2, 3}, {}}, interaction::ToolMode::kPress}}));
  });
  EXPECT_TRUE(r.has("scripted"));
  EXPECT_NE(r.create(parse_device_request("scripted")), nullptr);
  try {
    r.create(parse_device_request("phantom"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no device named 'phantom'"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("scripted: a path"), std::string::npos) << e.what();
  }
  try {
    r.create(parse_device_request("scripted:speed=3"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no parameter 'speed'"), std::string::npos) << e.what();
  }
}

TEST(DeviceFrame, PatientPosesBecomeTissuePosesAndBack) {
  const VolumeGeometry g = turned_frame();
  const DeviceFrame frame(g);
  const ToolPose tissue{{13, 24, 35}, Rotation::about_axis({0.3, 1, 0.2}, 0.7)};
  const ToolPose patient = frame.to_patient(tissue);
  EXPECT_LT(length(patient.position - g.tissue_to_patient(tissue.position)), 1e-9);
  const ToolPose back = frame.to_tissue(patient);
  EXPECT_LT(length(back.position - tissue.position), 1e-9);
  EXPECT_LT(back.orientation.angle_to(tissue.orientation), 1e-9);
  // A tool axis turns with the frame (up to the mirror's flip of the local z axis).
  const Vec3d x_tissue = tissue.orientation.apply({1, 0, 0});
  EXPECT_LT(length(patient.orientation.apply({1, 0, 0}) - g.direction_to_patient(x_tissue)), 1e-9);
  // Identity frame: nothing changes.
  const DeviceFrame none;
  EXPECT_LT(length(none.to_tissue(tissue).position - tissue.position), 1e-12);
  EXPECT_LT(length(none.vector_to_patient({1, 2, 3}) - Vec3d{1, 2, 3}), 1e-12);
}

TEST(HapticLoop, APatientFrameDeviceIsReadInTissueSpaceAndFeelsItsForceInPatientSpace) {
  const VolumeGeometry g = turned_frame();
  PatientDevice device(g.tissue_to_patient({17, 25, 33}));  // tissue x = 17
  EchoModel model;
  TripleBuffer<HapticFrame> frames;
  HapticLoopOptions o;
  o.frame = DeviceFrame(g);
  HapticLoop loop(device, model, frames, o);
  const Vec3d f = loop.tick_now();  // one tick on this thread: no loop thread
  EXPECT_NEAR(f.x, 17.0, 1e-9) << "the model saw the stylus in tissue space";
  EXPECT_LT(length(loop.latest_device_state().pose.position - Vec3d{17, 25, 33}), 1e-9);
  EXPECT_LT(length(device.force_ - g.direction_to_patient({17, 0, 0})), 1e-9)
      << "the device gets the force in its own frame";
  EXPECT_EQ(loop.ticks(), 1);
}

TEST(HapticLoop, AStallIsCountedAsMissedTicksNotMadeUpByABurst) {
  PatientDevice device({0, 0, 0});
  device.stall_ms_ = 40;  // the first read stalls 40 ms: ~40 deadlines pass
  EchoModel model;
  TripleBuffer<HapticFrame> frames;
  HapticLoopOptions o;
  o.rate_hz = 1000;
  HapticLoop loop(device, model, frames, o);
  loop.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  loop.stop();
  const LoopStatistics s = loop.statistics();
  EXPECT_GE(s.missed_ticks, 30) << "the stalled deadlines are skipped and counted";
  // Honest accounting: ticks plus missed deadlines cover the time, and the achieved rate is below
  // the target by at least the stall's share.
  EXPECT_NEAR(double(s.ticks + s.missed_ticks), s.elapsed_s * 1000.0, 0.05 * s.elapsed_s * 1000.0);
  EXPECT_LT(s.rate_hz, 1000.0 * (1.0 - 0.03 / s.elapsed_s));
  EXPECT_GT(s.latency_max_us, 30000.0) << "the stalled tick's latency";
  EXPECT_LE(s.latency_p50_us, s.latency_p99_us);
}

TEST(HapticLoop, TheThreadStartHookRunsOnTheLoopsThreadAndIsReported) {
  PatientDevice device({0, 0, 0});
  EchoModel model;
  TripleBuffer<HapticFrame> frames;
  HapticLoopOptions o;
  std::thread::id seen;
  o.on_thread_start = [&seen] {
    seen = std::this_thread::get_id();
    return std::string("test scheduling");
  };
  HapticLoop loop(device, model, frames, o);
  loop.start();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  loop.stop();
  EXPECT_NE(seen, std::this_thread::get_id());
  EXPECT_EQ(loop.statistics().scheduling, "test scheduling");
}

}  // namespace
}  // namespace tsf::haptics
