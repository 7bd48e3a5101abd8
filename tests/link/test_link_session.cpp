// The live link's session and device (app/link/link_session.h, igtl_device.h): which tool follows
// which TRANSFORM, the frames (wire RAS or LPS → patient LPS → tissue space), the registration,
// and the device a haptic loop reads, driven by the OpenIGTLink library's own client.
#include <gtest/gtest.h>

#include <igtlClientSocket.h>
#include <igtlMessageHeader.h>
#include <igtlSensorMessage.h>
#include <igtlTransformMessage.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "link/igtl_device.h"
#include "link/igtl_test_peer.h"
#include "link/link_session.h"
#include "support/error_of.h"
#include "tsf/common/error.h"

namespace tsf::link {
namespace {

using test::eventually;
using tsf::test::error_of;

TEST(LinkSession, ToolBindingReadsToolDeviceAndMode) {
  const ToolBinding b = parse_tool_binding("wand=StylusTipToReference:ablate");
  EXPECT_EQ(b.tool, "wand");
  EXPECT_EQ(b.device, "StylusTipToReference");
  EXPECT_EQ(b.mode, interaction::ToolMode::kAblate);
  const ToolBinding plain = parse_tool_binding("ball");
  EXPECT_EQ(plain.device, "ball");
  EXPECT_EQ(plain.mode, interaction::ToolMode::kPress);
}

TEST(LinkSession, BadToolBindingNamesTheOptionAndWhatIsExpected) {
  EXPECT_NE(error_of([] { parse_tool_binding("ball:squeeze"); }).find("mode 'squeeze'"),
            std::string::npos);
  EXPECT_NE(error_of([] { parse_tool_binding("=Tracker"); }).find("TOOL[=DEVICE][:MODE]"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              parse_tool_binding("ball=ANameLongerThanTwentyChars");
            }).find("longer than 20"),
            std::string::npos);
}

TEST(LinkSession, UnknownSceneToolIsRefusedListingTheScenesTools) {
  LinkOptions o;
  o.port = 0;
  o.tools = {"scalpel=Tracker"};
  interaction::Tool ball;
  const std::string e = error_of([&] { LinkSession s(o, {{"ball", ball}}, "block"); });
  EXPECT_NE(e.find("no tool 'scalpel'"), std::string::npos) << e;
  EXPECT_NE(e.find("ball"), std::string::npos) << e;
}

TEST(LinkSession, RasTransformBecomesThePatientPoseWithXAndYNegated) {
  Matrix4 m = identity_matrix();
  m[0][3] = 10;
  m[1][3] = -20;
  m[2][3] = 30;
  const auto ras = wire_matrix_to_patient_pose(m, WireFrame::kRas, std::nullopt);
  ASSERT_TRUE(ras);
  EXPECT_EQ(ras->position, (Vec3d{-10, 20, 30}));
  // The identity rotation in RAS is a half turn about S in LPS: x and y flip, z stays.
  EXPECT_NEAR(length(ras->orientation.apply({1, 0, 0}) - Vec3d{-1, 0, 0}), 0, 1e-12);
  EXPECT_NEAR(length(ras->orientation.apply({0, 0, 1}) - Vec3d{0, 0, 1}), 0, 1e-12);
  const auto lps = wire_matrix_to_patient_pose(m, WireFrame::kLps, std::nullopt);
  ASSERT_TRUE(lps);
  EXPECT_EQ(lps->position, (Vec3d{10, -20, 30}));
}

TEST(LinkSession, RegistrationIsAppliedBeforeTheWireFrame) {
  Matrix4 reg = identity_matrix();  // tracker → wire: a quarter turn about z and a shift
  reg[0][0] = 0;
  reg[0][1] = -1;
  reg[1][0] = 1;
  reg[1][1] = 0;
  reg[0][3] = 100;
  Matrix4 m = identity_matrix();
  m[0][3] = 5;  // 5 mm along the tracker's x
  const auto p = wire_matrix_to_patient_pose(m, WireFrame::kLps, reg);
  ASSERT_TRUE(p);
  EXPECT_NEAR(p->position.x, 100, 1e-12);
  EXPECT_NEAR(p->position.y, 5, 1e-12);
}

TEST(LinkSession, ScaledOrShearedMatrixIsNotAPose) {
  Matrix4 m = identity_matrix();
  m[0][0] = 2;
  EXPECT_FALSE(wire_matrix_to_patient_pose(m, WireFrame::kRas, std::nullopt));
  m = identity_matrix();
  m[2][2] = -1;  // a mirror
  EXPECT_FALSE(rotation_of(m));
  const Rotation q = Rotation::about_axis({1, 2, 3}, 2.5);
  Matrix4 r = identity_matrix();
  for (int c = 0; c < 3; ++c) {
    const Vec3d col = q.apply({c == 0 ? 1.0 : 0, c == 1 ? 1.0 : 0, c == 2 ? 1.0 : 0});
    r[0][c] = col.x;
    r[1][c] = col.y;
    r[2][c] = col.z;
  }
  ASSERT_TRUE(rotation_of(r));
  EXPECT_LT(rotation_of(r)->angle_to(q), 1e-9);
}

TEST(LinkSession, RegistrationFileThatIsNotRigidIsRefusedNamingTheFile) {
  const auto file = std::filesystem::temp_directory_path() / "tsf-link-registration-test.txt";
  {
    std::ofstream out(file);
    out << "2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
  }
  const std::string e = error_of([&] { read_registration(file.string()); });
  EXPECT_NE(e.find(file.string()), std::string::npos) << e;
  EXPECT_NE(e.find("not a rotation"), std::string::npos) << e;
  {
    std::ofstream out(file);
    out << "1 0 0 5\n0 1 0 6\n0 0 1 7\n";  // 12 numbers: the last row implied
  }
  const Matrix4 m = read_registration(file.string());
  EXPECT_EQ(m[1][3], 6);
  EXPECT_EQ(m[3][3], 1);
  std::filesystem::remove(file);
}

TEST(LinkSession, PatientPoseGoesToTissueSpaceThroughTheVolumeDirection) {
  VolumeGeometry g;
  g.dims = {10, 10, 10};
  g.origin = {5, 6, 7};
  g.direction = {-1, 0, 0, 0, -1, 0, 0, 0, 1};  // a RAS-stored volume
  ToolPose lps{{15, 6, 7}, Rotation{}};         // 10 mm along L from the origin
  const ToolPose t = patient_pose_to_tissue(lps, g);
  EXPECT_NEAR(t.position.x, -5, 1e-9);  // tissue x runs along R: 10 mm back
  EXPECT_NEAR(t.position.y, 6, 1e-9);
  EXPECT_NEAR(t.position.z, 7, 1e-9);
  EXPECT_NEAR(length(g.tissue_to_patient(t.position) - lps.position), 0, 1e-9);
}

TEST(LinkSession, ToolFollowsItsTransformAndAStringSwitchesItsMode) {
  LinkOptions o;
  o.port = 0;
  o.tools = {"ball=Tracker:press"};
  interaction::Tool ball;  // a sphere: press and ablate
  LinkSession session(o, {{"ball", ball}}, "block");
  VolumeGeometry identity;
  identity.dims = {10, 10, 10};
  std::vector<LinkSession::Drive> d = session.drives(identity, 0.0);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_FALSE(d[0].held);  // no TRANSFORM yet: lifted
  igtl::ClientSocket::Pointer tracker = igtl::ClientSocket::New();
  ASSERT_EQ(tracker->ConnectToServer("127.0.0.1", session.server().port()), 0);
  test::send_transform(tracker, "Tracker", -4, 0, 0);  // R −4 = L 4
  ASSERT_TRUE(eventually([&] { return session.server().pose("Tracker").has_value(); }));
  d = session.drives(identity, 0.1);
  ASSERT_TRUE(d[0].held);
  EXPECT_TRUE(d[0].fresh);
  EXPECT_NEAR(d[0].pose.position.x, 4, 1e-6);
  EXPECT_EQ(d[0].mode, interaction::ToolMode::kPress);
  EXPECT_FALSE(session.drives(identity, 0.2)[0].fresh);  // the same TRANSFORM again
  // A pedal on the bridge: STRING "ablate" from the tool's device switches its mode; "cut" (a
  // sphere cannot) is ignored.
  for (const char* text : {"ablate", "cut"}) {
    const std::vector<std::uint8_t> bytes = pack_string(text, "Tracker", 0);
    tracker->Send(bytes.data(), static_cast<int>(bytes.size()));
    const auto n = std::string(text) == "ablate" ? 1u : 2u;
    ASSERT_TRUE(eventually([&] {
      const auto t = session.server().text("Tracker");
      return t && t->second == n;
    }));
    EXPECT_EQ(session.drives(identity, 0.3)[0].mode, interaction::ToolMode::kAblate) << text;
  }
  const nlohmann::json r = session.report_json(1.0);
  EXPECT_EQ(r["tools"][0]["poses_applied"], 1);
  EXPECT_EQ(r["tools"][0]["trace"][0][1], 4.0);  // patient LPS x
}

TEST(IgtlDevice, FollowsTheTrackerInPatientLpsAndSendsTheForceBackInNewtons) {
  IgtlDeviceOptions o;
  o.server.listen = {"127.0.0.1", 0};
  o.server.log = [](const std::string&) {};
  IgtlDevice device(o);
  EXPECT_FALSE(device.read().valid);  // nothing received yet: the tool is lifted
  EXPECT_FALSE(device.read().pressing);
  igtl::ClientSocket::Pointer tracker = igtl::ClientSocket::New();
  ASSERT_EQ(tracker->ConnectToServer("127.0.0.1", device.server().port()), 0);
  tracker->SetReceiveTimeout(5000);
  test::send_transform(tracker, "Tracker", 10, 20, 30);  // R 10, A 20, S 30
  ASSERT_TRUE(eventually([&] { return device.read().valid; }));
  const haptics::DeviceState s = device.read();
  EXPECT_NEAR(s.pose.position.x, -10, 1e-6);  // L = −R
  EXPECT_NEAR(s.pose.position.y, -20, 1e-6);  // P = −A
  EXPECT_NEAR(s.pose.position.z, 30, 1e-6);
  EXPECT_TRUE(s.pressing);
  EXPECT_EQ(device.poses_read(), 1u);
  // A force of 2 N towards L (patient) is 2 N towards −R on the wire.
  device.apply_force({2e6, 0, -1e6});
  igtl::MessageHeader::Pointer h = test::receive_header(tracker);
  ASSERT_TRUE(h.IsNotNull());
  EXPECT_STREQ(h->GetDeviceType(), "SENSOR");
  igtl::SensorMessage::Pointer sensor = test::receive_sensor(tracker, h);
  ASSERT_TRUE(sensor.IsNotNull());
  EXPECT_NEAR(sensor->GetValue(0), -2.0, 1e-12);
  EXPECT_NEAR(sensor->GetValue(1), 0.0, 1e-12);
  EXPECT_NEAR(sensor->GetValue(2), -1.0, 1e-12);
  // The tracker leaves: the device is no longer valid (the loop lifts the tool).
  tracker->CloseSocket();
  EXPECT_TRUE(eventually([&] { return !device.read().valid; }));
}

}  // namespace
}  // namespace tsf::link
