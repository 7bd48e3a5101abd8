// The live link's server (app/link/link_server.h) on localhost, with clients made of the
// OpenIGTLink library's own socket and message classes: a tracker's TRANSFORM becomes the pose,
// GET_POLYDATA is answered with the newest surface, the force goes back to the peer that drives
// the tool, and a peer that breaks the protocol is disconnected while the others stay.
#include <gtest/gtest.h>

#include <igtlClientSocket.h>
#include <igtlMessageHeader.h>
#include <igtlPolyDataMessage.h>
#include <igtlSensorMessage.h>
#include <igtlServerSocket.h>
#include <igtlTransformMessage.h>

#include <chrono>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "link/igtl_test_peer.h"
#include "link/link_server.h"
#include "tsf/common/error.h"

namespace tsf::link {
namespace {

ServerOptions quiet_any_port() {
  ServerOptions o;
  o.listen = {"127.0.0.1", 0};
  o.log = [](const std::string&) {};
  return o;
}

using test::eventually;
using test::receive_header;
using test::send_transform;

igtl::ClientSocket::Pointer connect_to(const LinkServer& server) {
  igtl::ClientSocket::Pointer s = test::connect_to_port(server.port());
  EXPECT_TRUE(s.IsNotNull());
  return s;
}

std::shared_ptr<const imt::SurfaceMesh> triangle(float z) {
  auto m = std::make_shared<imt::SurfaceMesh>();
  m->positions = {{0, 0, z}, {1, 0, z}, {0, 1, z}};
  m->triangles = {{0, 1, 2}};
  return m;
}

TEST(LinkServer, TransformFromATrackerBecomesThePoseOfItsDevice) {
  LinkServer server(quiet_any_port());
  ASSERT_GT(server.port(), 0);
  EXPECT_FALSE(server.pose("Tracker"));
  igtl::ClientSocket::Pointer tracker = connect_to(server);
  send_transform(tracker, "Tracker", 1, 2, 3);
  send_transform(tracker, "Tracker", 4, 5, 6);
  ASSERT_TRUE(eventually([&] {
    const auto p = server.pose("Tracker");
    return p && p->count == 2;
  }));
  const PoseUpdate p = *server.pose("Tracker");
  EXPECT_DOUBLE_EQ(p.matrix[0][3], 4);
  EXPECT_DOUBLE_EQ(p.matrix[1][3], 5);
  EXPECT_DOUBLE_EQ(p.matrix[2][3], 6);
  EXPECT_FALSE(server.pose("Other"));
  // The tracker leaves: its device has no pose any more (the tool lifts).
  tracker->CloseSocket();
  EXPECT_TRUE(eventually([&] { return !server.pose("Tracker"); }));
  EXPECT_EQ(server.statistics().transforms_in, 2);
}

TEST(LinkServer, GetPolydataIsAnsweredWithTheNewestSurface) {
  LinkServer server(quiet_any_port());
  server.publish_surface("tissue", triangle(1), timestamp_now());
  server.publish_surface("tissue", triangle(2), timestamp_now());  // replaces the first
  igtl::ClientSocket::Pointer client = connect_to(server);
  igtl::GetPolyDataMessage::Pointer get = igtl::GetPolyDataMessage::New();
  get->SetDeviceName("tissue");
  get->Pack();
  client->Send(get->GetPackPointer(), get->GetPackSize());
  igtl::MessageHeader::Pointer h = receive_header(client);
  ASSERT_TRUE(h.IsNotNull());
  EXPECT_STREQ(h->GetDeviceType(), "POLYDATA");
  EXPECT_STREQ(h->GetDeviceName(), "tissue");
  igtl::PolyDataMessage::Pointer poly = igtl::PolyDataMessage::New();
  poly->SetMessageHeader(h);
  poly->AllocatePack();
  ASSERT_EQ(client->Receive(poly->GetPackBodyPointer(), poly->GetPackBodySize()),
            poly->GetPackBodySize());
  ASSERT_TRUE(poly->Unpack(1) & igtl::MessageHeader::UNPACK_BODY);
  ASSERT_EQ(poly->GetPoints()->GetNumberOfPoints(), 3u);
  igtlFloat32 p[3];
  poly->GetPoints()->GetPoint(0, p);
  EXPECT_FLOAT_EQ(p[2], 2.0f);
}

TEST(LinkServer, SurfaceNoPeerTakesIsNeverPackedAndOneTakenIsPackedOnce) {
  LinkServer server(quiet_any_port());
  for (int i = 0; i < 5; ++i) server.publish_surface("tissue", triangle(1), timestamp_now());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(server.statistics().surfaces_packed, 0);
  igtl::ClientSocket::Pointer a = connect_to(server);
  igtl::ClientSocket::Pointer b = connect_to(server);
  for (igtl::ClientSocket::Pointer* c : {&a, &b}) {
    igtl::GetPolyDataMessage::Pointer get = igtl::GetPolyDataMessage::New();
    get->SetDeviceName("tissue");
    get->Pack();
    (*c)->Send(get->GetPackPointer(), get->GetPackSize());
    ASSERT_TRUE(receive_header(*c).IsNotNull());
  }
  EXPECT_EQ(server.statistics().surfaces_packed, 1);  // both got the same bytes
}

TEST(LinkServer, ListenerThatAsksNothingIsStreamedEverySurface) {
  LinkServer server(quiet_any_port());
  igtl::ClientSocket::Pointer viewer = connect_to(server);  // 3D Slicer: connects and listens
  ASSERT_TRUE(eventually([&] { return server.statistics().peers_now == 1; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // past the grace time
  for (int i = 0; i < 3; ++i) {
    server.publish_surface("tissue", triangle(static_cast<float>(i)), timestamp_now());
    igtl::MessageHeader::Pointer h = receive_header(viewer);
    ASSERT_TRUE(h.IsNotNull()) << "surface " << i << " not streamed";
    EXPECT_STREQ(h->GetDeviceType(), "POLYDATA");
    std::vector<char> body(h->GetBodySizeToRead());
    ASSERT_EQ(viewer->Receive(body.data(), static_cast<int>(body.size())),
              static_cast<int>(body.size()));
  }
}

TEST(LinkServer, ForceGoesBackToThePeerThatSentThePoseWithItsTimestamp) {
  LinkServer server(quiet_any_port());
  igtl::ClientSocket::Pointer tracker = connect_to(server);
  igtl::ClientSocket::Pointer other = connect_to(server);
  // The other peer asks for surfaces (so it is not streamed any) and must get no SENSOR.
  igtl::GetPolyDataMessage::Pointer get = igtl::GetPolyDataMessage::New();
  get->SetDeviceName("none");
  get->Pack();
  other->Send(get->GetPackPointer(), get->GetPackSize());
  send_transform(tracker, "Tracker", 0, 0, 0);
  ASSERT_TRUE(eventually([&] { return server.pose("Tracker").has_value(); }));
  server.send_force("Tracker", {0.5, -0.25, 1.0}, 1234);
  igtl::MessageHeader::Pointer h = receive_header(tracker);
  ASSERT_TRUE(h.IsNotNull());
  EXPECT_STREQ(h->GetDeviceType(), "SENSOR");
  EXPECT_STREQ(h->GetDeviceName(), "Tracker");
  igtl::SensorMessage::Pointer sensor = test::receive_sensor(tracker, h);
  ASSERT_TRUE(sensor.IsNotNull());
  EXPECT_DOUBLE_EQ(sensor->GetValue(0), 0.5);
  EXPECT_DOUBLE_EQ(sensor->GetValue(1), -0.25);
  EXPECT_DOUBLE_EQ(sensor->GetValue(2), 1.0);
  igtl::TimeStamp::Pointer ts = igtl::TimeStamp::New();
  sensor->GetTimeStamp(ts);
  igtlUint32 sec = 0, frac = 0;
  ts->GetTimeStamp(&sec, &frac);
  EXPECT_EQ(sec, 0u);  // 1234 = seconds 0, fraction 1234: the pose's stamp comes back
  EXPECT_TRUE(eventually([&] { return server.statistics().sensors_sent == 1; }));
}

TEST(LinkServer, PeerSendingWhatIsNotOpenIgtlinkIsDisconnectedAndOthersStay) {
  LinkServer server(quiet_any_port());
  igtl::ClientSocket::Pointer good = connect_to(server);
  igtl::ClientSocket::Pointer bad = connect_to(server);
  ASSERT_TRUE(eventually([&] { return server.statistics().peers_now == 2; }));
  std::string http = "GET / HTTP/1.1\r\nHost: localhost\r\n\r\n";
  http.resize(kHeaderSize, ' ');
  bad->Send(http.data(), static_cast<int>(http.size()));
  ASSERT_TRUE(eventually([&] { return server.statistics().peers_refused == 1; }));
  EXPECT_EQ(server.statistics().peers_now, 1);
  send_transform(good, "Tracker", 7, 8, 9);
  EXPECT_TRUE(eventually([&] { return server.pose("Tracker").has_value(); }));
}

TEST(LinkServer, MessageWithABadCrcIsDroppedAndCounted) {
  LinkServer server(quiet_any_port());
  igtl::ClientSocket::Pointer tracker = connect_to(server);
  std::vector<std::uint8_t> bytes = pack_transform(identity_matrix(), "Tracker", 0);
  bytes[kHeaderSize + 3] ^= 0x01;
  tracker->Send(bytes.data(), static_cast<int>(bytes.size()));
  ASSERT_TRUE(eventually([&] { return server.statistics().bad_crc == 1; }));
  EXPECT_FALSE(server.pose("Tracker"));
  send_transform(tracker, "Tracker", 1, 1, 1);  // the connection stays usable
  EXPECT_TRUE(eventually([&] { return server.pose("Tracker").has_value(); }));
}

TEST(LinkServer, PortInUseIsRefusedNamingTheAddress) {
  LinkServer first(quiet_any_port());
  ServerOptions o = quiet_any_port();
  o.listen.port = first.port();
  try {
    LinkServer second(o);
    FAIL() << "a second server bound the same port";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(first.port())),
              std::string::npos)
        << e.what();
  }
}

TEST(LinkServer, ConnectsToAServerAndTakesItsTransforms) {
  // A PlusServer stands in: the library's server socket sending one TRANSFORM.
  igtl::ServerSocket::Pointer plus = igtl::ServerSocket::New();
  int port = 0;
  for (port = 23000; port < 23100 && plus->CreateServer(port) != 0; ++port) {
  }
  ASSERT_LT(port, 23100);
  ServerOptions o = quiet_any_port();
  o.listen.port = -1;
  o.connect = {{"127.0.0.1", port}};
  LinkServer server(o);
  igtl::ClientSocket::Pointer peer = plus->WaitForConnection(5000);
  ASSERT_TRUE(peer.IsNotNull());
  igtl::TransformMessage::Pointer msg = igtl::TransformMessage::New();
  msg->SetDeviceName("StylusTipToReference");
  msg->Pack();
  peer->Send(msg->GetPackPointer(), msg->GetPackSize());
  EXPECT_TRUE(eventually([&] { return server.pose("StylusTipToReference").has_value(); }));
  peer->CloseSocket();
  plus->CloseSocket();
}

}  // namespace
}  // namespace tsf::link

namespace tsf::link {
namespace {

// Hostile peers: random bytes, headers claiming huge bodies, truncated and bit-flipped messages,
// each from its own connection that then drops. The server stays up, bounded, and a good tracker
// afterwards is still heard (CI also runs this under ASan + UBSan).
TEST(LinkServerRobustness, RandomTruncatedAndCorruptedMessagesNeverStopTheServer) {
  LinkServer server(quiet_any_port());
  std::mt19937 rng(20261126);
  const std::vector<std::uint8_t> good = pack_transform(identity_matrix(), "Tracker", 0);
  const std::vector<std::uint8_t> poly = pack_polydata(*triangle(0), "x", 0);
  for (int round = 0; round < 150; ++round) {
    igtl::ClientSocket::Pointer peer = igtl::ClientSocket::New();
    ASSERT_EQ(peer->ConnectToServer("127.0.0.1", server.port()), 0);
    std::vector<std::uint8_t> bytes;
    switch (round % 5) {
      case 0:  // random bytes
        bytes.resize(std::uniform_int_distribution<int>(1, 400)(rng));
        for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
        break;
      case 1: {  // a TRANSFORM header claiming a huge body
        bytes.assign(good.begin(), good.begin() + kHeaderSize);
        for (int i = 42; i < 50; ++i) bytes[i] = static_cast<std::uint8_t>(rng());
        break;
      }
      case 2:  // a message cut short
        bytes.assign(good.begin(),
                     good.begin() + std::uniform_int_distribution<int>(1, good.size() - 1)(rng));
        break;
      case 3:  // bits flipped anywhere
        bytes = good;
        for (int k = 0; k < 3; ++k)
          bytes[std::uniform_int_distribution<std::size_t>(0, bytes.size() - 1)(rng)] ^=
              static_cast<std::uint8_t>(1u << (rng() % 8));
        break;
      default:  // a type tsf does not act on (skipped), then bits flipped in a TRANSFORM
        bytes = poly;
        bytes.insert(bytes.end(), good.begin(), good.end());
        bytes[bytes.size() - 1 - rng() % 48] ^= 0x40;
        break;
    }
    peer->Send(bytes.data(), static_cast<int>(bytes.size()));
    peer->CloseSocket();
    // One hostile peer at a time: a burst would only fill the listen queue (the kernel then
    // delays the next connect by a second), which is not what is tested here.
    ASSERT_TRUE(eventually([&] { return server.statistics().peers_connected == round + 1; }));
  }
  ASSERT_TRUE(eventually([&] { return server.statistics().peers_now == 0; }));
  igtl::ClientSocket::Pointer tracker = connect_to(server);
  send_transform(tracker, "Tracker", 3, 2, 1);
  ASSERT_TRUE(eventually([&] {
    const auto p = server.pose("Tracker");
    return p && p->matrix[0][3] == 3;
  }));
  EXPECT_GT(server.statistics().peers_refused, 0);
}

}  // namespace
}  // namespace tsf::link
