// The OpenIGTLink codec of the live link (app/link/igtl_codec.h), checked against the
// OpenIGTLink library's own message classes: what tsf sends, the library unpacks (CRC checked) to
// the same values; what the library packs, tsf reads back.
#include <gtest/gtest.h>

#include <igtlMessageHeader.h>
#include <igtlPolyDataMessage.h>
#include <igtlSensorMessage.h>
#include <igtlTransformMessage.h>
#include <igtl_unit.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "link/igtl_codec.h"

namespace tsf::link {
namespace {

/// A two-triangle square with normals and labels.
imt::SurfaceMesh square() {
  imt::SurfaceMesh m;
  m.positions = {{0, 0, 0}, {10, 0, 0}, {10, 5, 0}, {0, 5, 1.5f}};
  m.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  m.labels = {1, 1, 2, 2};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

/// Header and content of a packed message, as the link reads it.
struct Read {
  Header header;
  std::vector<std::uint8_t> body;
};
Read read_message(const std::uint8_t* bytes, std::size_t size) {
  Read r;
  EXPECT_GE(size, kHeaderSize);
  EXPECT_EQ(parse_header(bytes, r.header), "");
  EXPECT_EQ(r.header.body_size, size - kHeaderSize);
  r.body.assign(bytes + kHeaderSize, bytes + size);
  return r;
}

TEST(IgtlCodec, TransformPackedByTheLibraryUnpacksToItsMatrix) {
  igtl::TransformMessage::Pointer msg = igtl::TransformMessage::New();
  msg->SetDeviceName("Tracker");
  igtl::Matrix4x4 m;
  const float q[4] = {0.0f, 0.6f, 0.0f, 0.8f};  // a rotation about y
  igtl::QuaternionToMatrix(const_cast<float*>(q), m);
  m[0][3] = 12.5f;
  m[1][3] = -3.0f;
  m[2][3] = 40.0f;
  msg->SetMatrix(m);
  msg->Pack();
  const Read r = read_message(static_cast<const std::uint8_t*>(msg->GetPackPointer()),
                              static_cast<std::size_t>(msg->GetPackSize()));
  EXPECT_EQ(r.header.type, "TRANSFORM");
  EXPECT_EQ(r.header.device, "Tracker");
  EXPECT_EQ(plan_body(r.header, {}).action, BodyAction::kRead);
  EXPECT_TRUE(body_crc_ok(r.header, r.body.data(), r.body.size()));
  std::string why;
  const auto content = message_content(r.header, r.body.data(), r.body.size(), why);
  ASSERT_TRUE(content) << why;
  const auto got = unpack_transform(*content, why);
  ASSERT_TRUE(got) << why;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR((*got)[i][j], m[i][j], 1e-6) << i << "," << j;
}

TEST(IgtlCodec, TransformPackedByTsfUnpacksInTheLibraryWithItsCrc) {
  Matrix4 m = identity_matrix();
  m[0][3] = 1.5;
  m[1][3] = 2.5;
  m[2][3] = -7.0;
  const std::vector<std::uint8_t> bytes = pack_transform(m, "Stylus", 42);
  igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
  header->InitPack();
  std::memcpy(header->GetPackPointer(), bytes.data(), kHeaderSize);
  header->Unpack();
  igtl::TransformMessage::Pointer msg = igtl::TransformMessage::New();
  msg->SetMessageHeader(header);
  msg->AllocatePack();
  std::memcpy(msg->GetPackBodyPointer(), bytes.data() + kHeaderSize, msg->GetPackBodySize());
  ASSERT_TRUE(msg->Unpack(1) & igtl::MessageHeader::UNPACK_BODY) << "CRC or body refused";
  igtl::Matrix4x4 got;
  msg->GetMatrix(got);
  EXPECT_FLOAT_EQ(got[0][3], 1.5f);
  EXPECT_FLOAT_EQ(got[1][3], 2.5f);
  EXPECT_FLOAT_EQ(got[2][3], -7.0f);
  EXPECT_FLOAT_EQ(got[0][0], 1.0f);
  EXPECT_STREQ(msg->GetDeviceName(), "Stylus");
}

TEST(IgtlCodec, PolydataUnpacksInTheLibraryToTheMeshPointsTrianglesAndAttributes) {
  const imt::SurfaceMesh mesh = square();
  const std::vector<std::uint8_t> bytes = pack_polydata(mesh, "cut-block", timestamp_now());
  igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
  header->InitPack();
  std::memcpy(header->GetPackPointer(), bytes.data(), kHeaderSize);
  header->Unpack();
  EXPECT_STREQ(header->GetDeviceType(), "POLYDATA");
  igtl::PolyDataMessage::Pointer msg = igtl::PolyDataMessage::New();
  msg->SetMessageHeader(header);
  msg->AllocatePack();
  ASSERT_EQ(static_cast<std::size_t>(msg->GetPackBodySize()), bytes.size() - kHeaderSize);
  std::memcpy(msg->GetPackBodyPointer(), bytes.data() + kHeaderSize, msg->GetPackBodySize());
  ASSERT_TRUE(msg->Unpack(1) & igtl::MessageHeader::UNPACK_BODY) << "CRC or body refused";
  igtl::PolyDataPointArray::Pointer points = msg->GetPoints();
  ASSERT_TRUE(points.IsNotNull());
  ASSERT_EQ(points->GetNumberOfPoints(), mesh.positions.size());
  for (unsigned i = 0; i < mesh.positions.size(); ++i) {
    igtlFloat32 p[3];
    points->GetPoint(i, p);
    EXPECT_FLOAT_EQ(p[0], mesh.positions[i].x);
    EXPECT_FLOAT_EQ(p[1], mesh.positions[i].y);
    EXPECT_FLOAT_EQ(p[2], mesh.positions[i].z);
  }
  igtl::PolyDataCellArray::Pointer polygons = msg->GetPolygons();
  ASSERT_TRUE(polygons.IsNotNull());
  ASSERT_EQ(polygons->GetNumberOfCells(), mesh.triangles.size());
  for (unsigned i = 0; i < mesh.triangles.size(); ++i) {
    std::list<igtlUint32> cell;
    polygons->GetCell(i, cell);
    const std::vector<igtlUint32> got(cell.begin(), cell.end());
    EXPECT_EQ(got, (std::vector<igtlUint32>{mesh.triangles[i][0], mesh.triangles[i][1],
                                            mesh.triangles[i][2]}));
  }
  ASSERT_EQ(msg->GetNumberOfAttributes(), 2u);
  EXPECT_STREQ(msg->GetAttribute(0)->GetName(), "Normals");
  EXPECT_EQ(msg->GetAttribute(0)->GetType(), igtl::PolyDataAttribute::POINT_NORMAL);
  EXPECT_STREQ(msg->GetAttribute(1)->GetName(), "TissueLabel");
  igtlFloat32 label = 0;
  msg->GetAttribute(1)->GetNthData(2, &label);
  EXPECT_FLOAT_EQ(label, 2.0f);
}

TEST(IgtlCodec, ForceSensorUnpacksInTheLibraryAsThreeNewtonValues) {
  const std::vector<std::uint8_t> bytes = pack_force_sensor({0.25, -1.5, 3.0}, "Tracker", 7);
  igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
  header->InitPack();
  std::memcpy(header->GetPackPointer(), bytes.data(), kHeaderSize);
  header->Unpack();
  igtl::SensorMessage::Pointer msg = igtl::SensorMessage::New();
  msg->SetMessageHeader(header);
  msg->AllocatePack();
  std::memcpy(msg->GetPackBodyPointer(), bytes.data() + kHeaderSize, msg->GetPackBodySize());
  ASSERT_TRUE(msg->Unpack(1) & igtl::MessageHeader::UNPACK_BODY);
  ASSERT_EQ(msg->GetLength(), 3u);
  EXPECT_DOUBLE_EQ(msg->GetValue(0), 0.25);
  EXPECT_DOUBLE_EQ(msg->GetValue(1), -1.5);
  EXPECT_DOUBLE_EQ(msg->GetValue(2), 3.0);
  igtl::Unit::Pointer newton = igtl::Unit::New();
  newton->Init();
  newton->Append(IGTL_UNIT_SI_DERIVED_NEWTON, 1);
  EXPECT_EQ(msg->GetUnit(), newton->Pack());
}

TEST(IgtlCodec, BytesThatAreNotAnOpenIgtlinkHeaderAreRefused) {
  std::string http = "GET / HTTP/1.1\r\nHost: localhost\r\n\r\n";
  http.resize(kHeaderSize, 'x');
  Header h;
  EXPECT_NE(parse_header(reinterpret_cast<const std::uint8_t*>(http.data()), h), "");
  // A well-formed TRANSFORM header with a lower-case type is refused too.
  std::vector<std::uint8_t> bytes = pack_transform(identity_matrix(), "Tracker", 0);
  bytes[2] = 't';
  EXPECT_NE(parse_header(bytes.data(), h), "");
}

TEST(IgtlCodec, BodyLargerThanItsTypeAllowsIsRefusedFromTheHeaderAlone) {
  Header h;
  h.type = "TRANSFORM";
  h.body_size = 49;
  EXPECT_EQ(plan_body(h, {}).action, BodyAction::kRefuse);
  h.type = "STRING";
  h.body_size = 1ull << 40;  // a claimed terabyte is never allocated
  EXPECT_EQ(plan_body(h, {}).action, BodyAction::kRefuse);
  h.type = "IMAGE";  // a type tsf does not act on: skipped within the limit, refused above it
  h.body_size = 1 << 20;
  EXPECT_EQ(plan_body(h, {}).action, BodyAction::kSkip);
  h.body_size = 1ull << 40;
  EXPECT_EQ(plan_body(h, {}).action, BodyAction::kRefuse);
}

TEST(IgtlCodec, CorruptedBodyFailsItsCrc) {
  std::vector<std::uint8_t> bytes = pack_transform(identity_matrix(), "Tracker", 0);
  Header h;
  ASSERT_EQ(parse_header(bytes.data(), h), "");
  EXPECT_TRUE(body_crc_ok(h, bytes.data() + kHeaderSize, bytes.size() - kHeaderSize));
  bytes[kHeaderSize + 5] ^= 0x10;
  EXPECT_FALSE(body_crc_ok(h, bytes.data() + kHeaderSize, bytes.size() - kHeaderSize));
}

TEST(IgtlCodec, TransformWithAValueThatIsNotFiniteIsDropped) {
  Matrix4 m = identity_matrix();
  m[0][3] = std::nan("");
  const std::vector<std::uint8_t> bytes = pack_transform(m, "Tracker", 0);
  std::string why;
  EXPECT_FALSE(unpack_transform({bytes.data() + kHeaderSize, 48}, why));
  EXPECT_NE(why.find("finite"), std::string::npos);
}

TEST(IgtlCodec, RasAndLpsDifferBySigningXAndY) {
  const Vec3d lps{10, 20, 30};
  EXPECT_EQ(lps_to_wire(lps, WireFrame::kRas), (Vec3d{-10, -20, 30}));
  EXPECT_EQ(lps_to_wire(lps, WireFrame::kLps), lps);
  EXPECT_EQ(wire_to_lps(lps_to_wire(lps, WireFrame::kRas), WireFrame::kRas), lps);
}

TEST(IgtlCodec, TimestampKeepsSecondsAndFraction) {
  const std::uint64_t t = (std::uint64_t{1700000000} << 32) | 0x80000000u;  // .5 s
  EXPECT_NEAR(timestamp_seconds(t), 1700000000.5, 1e-6);
  EXPECT_NEAR(timestamp_seconds(timestamp_now()), static_cast<double>(std::time(nullptr)), 2.0);
}

}  // namespace
}  // namespace tsf::link
